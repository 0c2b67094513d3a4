// Mesh file input for the LOD tool: PLY (G. Turk, "The PLY polygon file format", Stanford
// University, 1994: ascii and both binary byte orders) and OFF (Geomview) readers written here,
// glTF and OBJ through core's loaders. Cost: O(file size) time, the mesh plus the file in memory.
#include "hmdnode/lod/mesh_file.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <sstream>

#include "hmdnode/core/atomic_file.hpp"
#include "hmdnode/core/gltf.hpp"
#include "hmdnode/core/obj.hpp"
#include "hmdnode/core/str_cat.hpp"

namespace hmdnode {

Scene single_mesh_scene(Mesh mesh) {
    Scene s;
    Node n;
    n.name = mesh.name;
    n.mesh = 0;
    s.meshes.push_back(std::move(mesh));
    s.nodes.push_back(std::move(n));
    s.roots.push_back(0);
    return s;
}

namespace {

// A vertex index read as a double: -1 (out of range for add_polygon) when it is not finite or
// does not fit, so the conversion is never undefined.
int64_t to_index(double v) {
    return v >= -1e18 && v <= 1e18 ? int64_t(v) : -1;
}

// Fan-triangulates a polygon; indices checked against `vertices`. where(): the file and the face
// or line, for an error (made only then: a string per face was a third of loading a large PLY).
template <class Where>
Status add_polygon(const std::vector<int64_t>& poly, size_t vertices, Primitive& p, Where&& where) {
    if (poly.size() < 3) return make_error(cat(where(), ": a face with ", poly.size(), " corners"));
    for (int64_t i : poly)
        if (i < 0 || uint64_t(i) >= vertices)
            return make_error(
                cat(where(), ": vertex index ", i, " out of range (", vertices, " vertices)"));
    for (size_t k = 1; k + 1 < poly.size(); ++k)
        p.indices.insert(p.indices.end(),
                         {uint32_t(poly[0]), uint32_t(poly[k]), uint32_t(poly[k + 1])});
    return {};
}

// ---- PLY ----

enum class PlyType { Int8, Uint8, Int16, Uint16, Int32, Uint32, Float32, Float64 };

bool ply_type(const std::string& s, PlyType& out) {
    static const std::pair<const char*, PlyType> names[] = {
        {"char", PlyType::Int8},      {"int8", PlyType::Int8},       {"uchar", PlyType::Uint8},
        {"uint8", PlyType::Uint8},    {"short", PlyType::Int16},     {"int16", PlyType::Int16},
        {"ushort", PlyType::Uint16},  {"uint16", PlyType::Uint16},   {"int", PlyType::Int32},
        {"int32", PlyType::Int32},    {"uint", PlyType::Uint32},     {"uint32", PlyType::Uint32},
        {"float", PlyType::Float32},  {"float32", PlyType::Float32}, {"double", PlyType::Float64},
        {"float64", PlyType::Float64}};
    for (auto& [n, t] : names)
        if (s == n) {
            out = t;
            return true;
        }
    return false;
}

size_t ply_size(PlyType t) {
    switch (t) {
        case PlyType::Int8:
        case PlyType::Uint8:
            return 1;
        case PlyType::Int16:
        case PlyType::Uint16:
            return 2;
        case PlyType::Int32:
        case PlyType::Uint32:
        case PlyType::Float32:
            return 4;
        case PlyType::Float64:
            return 8;
    }
    return 1;
}

bool ply_integer(PlyType t) {
    return t != PlyType::Float32 && t != PlyType::Float64;
}

struct PlyProperty {
    std::string name;
    PlyType type = PlyType::Float32;
    bool list = false;
    PlyType count_type = PlyType::Uint8;
};

struct PlyElement {
    std::string name;
    size_t count = 0;
    std::vector<PlyProperty> properties;
};

// Reads scalars from the body in the file's encoding.
class PlyBody {
  public:
    PlyBody(const std::string& bytes, size_t offset, int format)
        : bytes_(bytes), pos_(offset), format_(format) {}

    // Returns false at the end of the data or on a malformed token.
    bool read(PlyType t, double& out) {
        if (format_ == 0) {
            while (pos_ < bytes_.size() && std::isspace(static_cast<unsigned char>(bytes_[pos_])))
                ++pos_;
            if (pos_ >= bytes_.size()) return false;
            const char* begin = bytes_.data() + pos_;
            char* end = nullptr;
            out = std::strtod(begin, &end);
            if (end == begin) return false;
            pos_ += size_t(end - begin);
            return true;
        }
        const size_t n = ply_size(t);
        if (pos_ + n > bytes_.size()) return false;
        unsigned char b[8];
        std::memcpy(b, bytes_.data() + pos_, n);
        pos_ += n;
        const bool little = format_ == 1;
        if (little != (std::endian::native == std::endian::little)) std::reverse(b, b + n);
        switch (t) {
            case PlyType::Int8:
                out = double(int8_t(b[0]));
                break;
            case PlyType::Uint8:
                out = double(b[0]);
                break;
            case PlyType::Int16:
                out = double(load<int16_t>(b));
                break;
            case PlyType::Uint16:
                out = double(load<uint16_t>(b));
                break;
            case PlyType::Int32:
                out = double(load<int32_t>(b));
                break;
            case PlyType::Uint32:
                out = double(load<uint32_t>(b));
                break;
            case PlyType::Float32:
                out = double(load<float>(b));
                break;
            case PlyType::Float64:
                out = load<double>(b);
                break;
        }
        return true;
    }

  private:
    template <class T>
    static T load(const unsigned char* b) {
        T v;
        std::memcpy(&v, b, sizeof v);
        return v;
    }
    const std::string& bytes_;
    size_t pos_;
    int format_;  // 0 ascii, 1 little, 2 big
};

// The header: the body's format (0 ascii, 1 little, 2 big endian), its elements in file order
// and where the body starts.
struct PlyHeader {
    int format = -1;
    std::vector<PlyElement> elements;
    size_t body = 0;
};

// A "property" line after its keyword: a scalar or a list property of the last element.
Status read_ply_property(std::istringstream& in, const std::string& where,
                         std::vector<PlyElement>& elements) {
    if (elements.empty()) return make_error(cat(where, ": property before any element"));
    PlyProperty p;
    std::string type;
    in >> type;
    if (type == "list") {
        std::string ct, it;
        in >> ct >> it >> p.name;
        if (!ply_type(ct, p.count_type) || !ply_type(it, p.type))
            return make_error(cat(where, ": unknown list type \"", ct, " ", it, "\""));
        p.list = true;
    } else {
        if (!ply_type(type, p.type)) return make_error(cat(where, ": unknown type \"", type, "\""));
        in >> p.name;
    }
    elements.back().properties.push_back(std::move(p));
    return {};
}

// The header: lines up to "end_header".
Result<PlyHeader> read_ply_header(const std::string& file, const std::string& bytes) {
    PlyHeader h;
    size_t pos = 0;
    int line_no = 0;
    bool ended = false;
    while (pos < bytes.size()) {
        size_t eol = bytes.find('\n', pos);
        if (eol == std::string::npos) eol = bytes.size();
        std::string line = bytes.substr(pos, eol - pos);
        pos = std::min(bytes.size(), eol + 1);
        ++line_no;
        if (!line.empty() && line.back() == '\r') line.pop_back();
        std::istringstream in(line);
        std::string word;
        in >> word;
        const std::string where = cat(file, ": header line ", line_no);
        if (word == "ply" || word == "comment" || word == "obj_info" || word.empty()) continue;
        if (word == "end_header") {
            ended = true;
            break;
        }
        if (word == "format") {
            std::string f;
            in >> f;
            if (f == "ascii")
                h.format = 0;
            else if (f == "binary_little_endian")
                h.format = 1;
            else if (f == "binary_big_endian")
                h.format = 2;
            else
                return make_error(cat(where, ": unknown format \"", f, "\""));
        } else if (word == "element") {
            PlyElement e;
            long long count = -1;
            in >> e.name >> count;
            if (e.name.empty() || count < 0)
                return make_error(cat(where, ": malformed element line"));
            e.count = size_t(count);
            h.elements.push_back(std::move(e));
        } else if (word == "property") {
            if (Status s = read_ply_property(in, where, h.elements); !s.ok()) return s.error();
        } else {
            return make_error(cat(where, ": unknown keyword \"", word, "\""));
        }
    }
    if (!ended) return make_error(cat(file, ": PLY header without end_header"));
    if (h.format < 0) return make_error(cat(file, ": PLY header without a format line"));
    h.body = pos;
    return h;
}

// What the body builds: the primitive, and which vertex attributes the file has.
struct PlyMesh {
    Primitive prim;
    size_t vertex_count = 0;
    bool have_vertices = false, have_faces = false;
    bool any_normal = false, any_uv = false, any_color = false;
};

// The role of each property of an element: for "vertex" the index into kPlyVertexNames (0-2
// position, 3-5 normal, 6-11 texture coordinates, 12-15 colour), -1 for none; for "face" which
// property is the vertex index list.
constexpr const char* kPlyVertexNames[] = {"x",   "y",     "z",    "nx",   "ny",        "nz",
                                           "u",   "v",     "s",    "t",    "texture_u", "texture_v",
                                           "red", "green", "blue", "alpha"};
struct PlyRoles {
    std::vector<int> role;
    int face_list = -1;
};

PlyRoles ply_roles(const PlyElement& e, bool is_vertex, bool is_face) {
    PlyRoles r;
    r.role.assign(e.properties.size(), -1);
    for (size_t i = 0; i < e.properties.size(); ++i) {
        const PlyProperty& p = e.properties[i];
        if (is_vertex && !p.list)
            for (int k = 0; k < 16; ++k)
                if (p.name == kPlyVertexNames[k]) r.role[i] = k;
        if (is_face && p.list && (p.name == "vertex_indices" || p.name == "vertex_index"))
            r.face_list = int(i);
    }
    return r;
}

// Checks a vertex or face element before its items and notes what a vertex element brings.
Status begin_ply_element(const std::string& file, const PlyElement& e, bool is_vertex, bool is_face,
                         const PlyRoles& roles, size_t file_size, PlyMesh& m) {
    if (is_vertex) {
        bool xyz[3] = {false, false, false};
        for (int r : roles.role)
            if (r >= 0 && r < 3) xyz[r] = true;
        if (!xyz[0] || !xyz[1] || !xyz[2])
            return make_error(cat(file, ": element vertex lacks x, y or z"));
        for (int r : roles.role) {
            m.any_normal |= r >= 3 && r <= 5;
            m.any_uv |= r >= 6 && r <= 11;
            m.any_color |= r >= 12;
        }
        m.have_vertices = true;
        m.vertex_count = e.count;
        m.prim.positions.reserve(std::min(e.count, file_size));
    }
    if (is_face) {
        if (roles.face_list < 0)
            return make_error(cat(file, ": element face has no vertex_indices list"));
        m.have_faces = true;
    }
    return {};
}

// One item's vertex attributes, with their defaults.
struct PlyVertex {
    glm::vec3 pos{0.0f}, nrm{0.0f};
    glm::vec2 uv{0.0f};
    glm::vec4 col{1.0f};
};

// Reads the properties of item `item` of `e`: vertex attributes into v, the face's vertex index
// list into poly, the rest skipped.
Status read_ply_item(const std::string& file, const PlyElement& e, size_t item,
                     const PlyRoles& roles, PlyBody& body, PlyVertex& v,
                     std::vector<int64_t>& poly) {
    for (size_t i = 0; i < e.properties.size(); ++i) {
        const PlyProperty& p = e.properties[i];
        auto truncated = [&] {
            return make_error(cat(file, ": element ", e.name, " ", item, " property ", p.name,
                                  ": truncated or not a number"));
        };
        if (p.list) {
            double n = 0;
            if (!body.read(p.count_type, n)) return truncated();
            if (!(n >= 0 && n <= 1e6))
                return make_error(cat(file, ": element ", e.name, " ", item, " property ", p.name,
                                      ": list length ", n));
            if (int(i) == roles.face_list) poly.clear();
            for (size_t k = 0; k < size_t(n); ++k) {
                double x = 0;
                if (!body.read(p.type, x)) return truncated();
                if (int(i) == roles.face_list) poly.push_back(to_index(x));
            }
            continue;
        }
        double x = 0;
        if (!body.read(p.type, x)) return truncated();
        const int r = roles.role[i];
        if (r < 0) continue;
        if (r < 3)
            v.pos[r] = float(x);
        else if (r < 6)
            v.nrm[r - 3] = float(x);
        else if (r < 12)
            v.uv[(r - 6) % 2] = float(x);
        else
            v.col[r - 12] = ply_integer(p.type) ? float(x / 255.0) : float(x);
    }
    return {};
}

// One element of the body: its items as vertices or faces of m, or skipped.
Status read_ply_element(const std::string& file, const PlyElement& e, size_t file_size,
                        PlyBody& body, PlyMesh& m) {
    const bool is_vertex = e.name == "vertex";
    const bool is_face = e.name == "face";
    const PlyRoles roles = ply_roles(e, is_vertex, is_face);
    if (Status s = begin_ply_element(file, e, is_vertex, is_face, roles, file_size, m); !s.ok())
        return s;
    std::vector<int64_t> poly;
    // An element without properties has no data: nothing to read however large its count.
    for (size_t item = 0; item < e.count && !e.properties.empty(); ++item) {
        PlyVertex v;
        if (Status s = read_ply_item(file, e, item, roles, body, v, poly); !s.ok()) return s;
        if (is_vertex) {
            m.prim.positions.push_back(v.pos);
            if (m.any_normal) m.prim.normals.push_back(v.nrm);
            if (m.any_uv) m.prim.uv0.emplace_back(v.uv.x, 1.0f - v.uv.y);
            if (m.any_color) m.prim.colors.push_back(v.col);
        } else if (is_face) {
            if (!m.have_vertices)
                return make_error(cat(file, ": element face before element vertex"));
            if (Status s = add_polygon(poly, m.vertex_count, m.prim,
                                       [&] { return cat(file, ": face ", item); });
                !s.ok())
                return s;
        }
    }
    return {};
}

Result<Scene> load_ply(const std::filesystem::path& path, const std::string& bytes) {
    const std::string file = path.string();
    auto header = read_ply_header(file, bytes);
    if (!header) return header.error();
    PlyMesh m;
    PlyBody body(bytes, header->body, header->format);
    for (const PlyElement& e : header->elements)
        if (Status s = read_ply_element(file, e, bytes.size(), body, m); !s.ok()) return s.error();
    if (!m.have_vertices) return make_error(cat(file, ": no element vertex"));
    if (!m.have_faces || m.prim.indices.empty()) return make_error(cat(file, ": no faces"));
    if (m.prim.normals.empty()) compute_vertex_normals(m.prim);
    Mesh mesh;
    mesh.name = path.stem().string();
    mesh.primitives.push_back(std::move(m.prim));
    return single_mesh_scene(std::move(mesh));
}

// ---- OFF ----

Result<Scene> load_off(const std::filesystem::path& path, const std::string& bytes) {
    const std::string file = path.string();
    std::istringstream in(bytes);
    std::string line;
    int line_no = 0;
    // Tokens with their line numbers, comments stripped.
    std::vector<std::pair<std::string, int>> tokens;
    while (std::getline(in, line)) {
        ++line_no;
        if (size_t h = line.find('#'); h != std::string::npos) line.resize(h);
        std::istringstream ls(line);
        std::string t;
        while (ls >> t) tokens.emplace_back(t, line_no);
    }
    size_t k = 0;
    if (tokens.empty() || tokens[0].first.find("OFF") == std::string::npos)
        return make_error(cat(file, ": not an OFF file"));
    ++k;
    auto number = [&](double& out) -> Status {
        if (k >= tokens.size()) return make_error(cat(file, ": truncated (line ", line_no, ")"));
        const std::string& t = tokens[k].first;
        char* end = nullptr;
        out = std::strtod(t.c_str(), &end);
        if (end == t.c_str() || *end)
            return make_error(
                cat(file, ": line ", tokens[k].second, ": \"", t, "\" is not a number"));
        ++k;
        return {};
    };
    double v = 0, f = 0, e = 0;
    for (double* x : {&v, &f, &e})
        if (Status s = number(*x); !s.ok()) return s.error();
    if (!(v >= 0 && f >= 0 && v <= 1e9 && f <= 1e9)) return make_error(cat(file, ": bad counts"));
    Mesh mesh;
    mesh.name = path.stem().string();
    Primitive prim;
    for (size_t i = 0; i < size_t(v); ++i) {
        glm::dvec3 p;
        for (int c = 0; c < 3; ++c)
            if (Status s = number(p[c]); !s.ok()) return s.error();
        prim.positions.emplace_back(p);
    }
    std::vector<int64_t> poly;
    for (size_t i = 0; i < size_t(f); ++i) {
        double n = 0;
        if (Status s = number(n); !s.ok()) return s.error();
        const int line_of_face = tokens[k - 1].second;
        if (!(n >= 0 && n <= 1e6))
            return make_error(cat(file, ": line ", line_of_face, ": bad corner count ", n));
        poly.clear();
        for (size_t c = 0; c < size_t(n); ++c) {
            double idx = 0;
            if (Status s = number(idx); !s.ok()) return s.error();
            poly.push_back(to_index(idx));
        }
        // Skip optional colour values up to the end of the face's line.
        while (k < tokens.size() && tokens[k].second == line_of_face) ++k;
        if (Status s = add_polygon(poly, prim.positions.size(), prim,
                                   [&] { return cat(file, ": line ", line_of_face); });
            !s.ok())
            return s.error();
    }
    if (prim.indices.empty()) return make_error(cat(file, ": no faces"));
    compute_vertex_normals(prim);
    mesh.primitives.push_back(std::move(prim));
    return single_mesh_scene(std::move(mesh));
}

}  // namespace

Result<Scene> load_mesh_file(const std::filesystem::path& path) {
    Result<std::string> bytes = read_file(path);
    if (!bytes.ok()) return bytes.error();
    const std::string& b = *bytes;
    if (b.empty()) return make_error(cat(path.string(), ": empty file"));
    if (b.compare(0, 4, "glTF") == 0) return load_gltf(path);
    if (b.compare(0, 3, "ply") == 0) return load_ply(path, b);
    const size_t first = b.find_first_not_of(" \t\r\n");
    if (first != std::string::npos && b[first] == '{') return load_gltf(path);
    const size_t off = b.find("OFF");
    if (off != std::string::npos && off < 4 && b.find_first_of("\n", 0) > off)
        return load_off(path, b);
    std::string ext = path.extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(),
                   [](unsigned char c) { return std::tolower(c); });
    if (ext == ".obj") {
        Result<Mesh> m = load_obj(path);
        if (!m.ok()) return m.error();
        return single_mesh_scene(std::move(m).value());
    }
    return make_error(
        cat(path.string(), ": not a glTF, .glb, OBJ, PLY or OFF file (by content and extension)"));
}

}  // namespace hmdnode
