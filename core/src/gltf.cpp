// glTF 2.0 reader (https://registry.khronos.org/glTF/specs/2.0/glTF-2.0.html) on tinygltf.
//
// Steps: read the whole file; decide GLB or JSON by the magic bytes "glTF"; check the GLB header
// and chunks ourselves (tinygltf 2.7 does not check that the BIN chunk header fits); pre-check the
// JSON with nlohmann (valid JSON, a glTF 2.x asset, required extensions we know, external buffers
// and images that exist) so the message names the exact problem; parse with tinygltf; convert to
// the Scene model, checking every index, accessor range and value on the way.
//
// Behaviour worth knowing:
// - Only triangle primitives load; TRIANGLE_STRIP and TRIANGLE_FAN become lists. POINTS and
//   LINE* primitives are an error naming mesh and primitive (the renderer, baker and LOD tools
//   draw triangles only; dropping geometry silently would hide a broken export).
// - Missing normals are area-weighted vertex normals; a vertex with no area gets +Y.
// - A node matrix is decomposed into TRS (glm::decompose); a singular matrix keeps its
//   translation and per-axis scale lengths and drops the rotation.
// - Images decode to RGBA8 whatever their channel count or bit depth (stb).
// - A light placed by several nodes is repeated once per extra node (Scene::Light has one node).
//
// Time: linear in the file size plus the decoded texels. Memory: the file, tinygltf's model
// (buffers and decoded images) and the Scene, all alive at the peak.
#include "hmdnode/core/gltf.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <limits>
#include <numbers>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

#include <stb_image.h>
#include <tiny_gltf.h>
#include <nlohmann/json.hpp>

#define GLM_ENABLE_EXPERIMENTAL
#include <glm/gtx/matrix_decompose.hpp>

#include "hmdnode/core/atomic_file.hpp"
#include "hmdnode/core/str_cat.hpp"

namespace hmdnode {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

// note: the conversion reports a problem by throwing LoadError; load_gltf catches it (and any
// other exception) and returns it as an Error prefixed with the file name. Nothing escapes.
struct LoadError {
    std::string message;
};

template <class... Args>
[[noreturn]] void fail(const Args&... args) {
    throw LoadError{cat(args...)};
}

std::string quote_text(std::string_view s) {
    std::string out = "\"";
    for (char c : s.substr(0, 200)) out += (c >= 0x20 && c < 0x7f) ? c : '?';
    if (s.size() > 200) out += "...";
    return out + "\"";
}

// "node 3" or "node 3 \"lamp\"": how messages name an element of the asset.
std::string label_of(const char* kind, size_t index, const std::string& name) {
    return name.empty() ? cat(kind, " ", index) : cat(kind, " ", index, " ", quote_text(name));
}

std::string one_line(std::string s) {
    for (char& c : s)
        if (c == '\n' || c == '\r') c = ' ';
    while (!s.empty() && s.back() == ' ') s.pop_back();
    return s;
}

constexpr uint32_t kGlbMagic = 0x46546C67;     // "glTF"
constexpr uint32_t kChunkJson = 0x4E4F534A;    // "JSON"
constexpr uint32_t kChunkBin = 0x004E4942;     // "BIN\0"
constexpr size_t kMaxZeroAccessor = 1u << 24;  // elements of an accessor without a bufferView

uint32_t read_u32le(const unsigned char* p) {
    return uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 | uint32_t(p[3]) << 24;
}

// The JSON text of a GLB after checking its header and chunk table; *out_length is the GLB's
// declared length (trailing bytes after it are ignored).
std::string_view check_glb(const std::string& bytes, size_t* out_length) {
    const auto* p = reinterpret_cast<const unsigned char*>(bytes.data());
    const size_t size = bytes.size();
    if (size < 12) fail("truncated GLB: ", size, " bytes, shorter than the 12-byte header");
    const uint32_t version = read_u32le(p + 4);
    const uint32_t length = read_u32le(p + 8);
    if (version != 2) fail("GLB container version ", version, " is not supported (need 2)");
    if (length > size)
        fail("truncated GLB: the header declares ", length, " bytes but the file has ", size);
    if (length < 20) fail("corrupt GLB: declared length ", length, " leaves no room for a chunk");
    const uint32_t json_length = read_u32le(p + 12);
    if (read_u32le(p + 16) != kChunkJson) fail("corrupt GLB: the first chunk is not JSON");
    if (uint64_t(json_length) + 20 > length)
        fail("truncated GLB: the JSON chunk declares ", json_length, " bytes but only ",
             length - 20, " follow the header");
    const uint64_t bin_at = 20 + uint64_t(json_length);
    if (bin_at < length) {
        if (bin_at + 8 > length)
            fail("truncated GLB: ", length - bin_at,
                 " bytes after the JSON chunk, too few for a chunk header");
        const uint32_t bin_length = read_u32le(p + bin_at);
        if (read_u32le(p + bin_at + 4) == kChunkBin && bin_at + 8 + bin_length > length)
            fail("truncated GLB: the BIN chunk declares ", bin_length, " bytes but only ",
                 length - bin_at - 8, " remain");
    }
    *out_length = length;
    return std::string_view(bytes.data() + 20, json_length);
}

std::string url_decode(const std::string& s) {
    std::string out;
    for (size_t i = 0; i < s.size(); ++i) {
        if (s[i] == '%' && i + 2 < s.size() &&
            std::isxdigit(static_cast<unsigned char>(s[i + 1])) &&
            std::isxdigit(static_cast<unsigned char>(s[i + 2]))) {
            out += char(std::stoi(s.substr(i + 1, 2), nullptr, 16));
            i += 2;
        } else {
            out += s[i];
        }
    }
    return out;
}

// A buffer's or image's uri: a data URI tinygltf decodes, or a local file that exists.
void check_uri(const Json& object, const char* kind, size_t index, const fs::path& base_dir) {
    auto it = object.find("uri");
    if (it == object.end()) return;
    if (!it->is_string()) fail(kind, " ", index, ": uri is not a string");
    const std::string uri = it->get<std::string>();
    if (uri.rfind("data:", 0) == 0) {
        if (!tinygltf::IsDataURI(uri))
            fail(kind, " ", index, ": unsupported data URI ", quote_text(uri.substr(0, 40)),
                 " (need base64 with a glTF media type)");
        return;
    }
    if (uri.find("://") != std::string::npos)
        fail(kind, " ", index, ": uri ", quote_text(uri), " is not a local file");
    std::error_code ec;
    const fs::path file = base_dir / url_decode(uri);
    if (!fs::is_regular_file(file, ec))
        fail(kind, " ", index, ": uri ", quote_text(uri), " not found (looked for ", file.string(),
             ")");
}

// What tinygltf does not check, or words vaguely: is this a glTF 2.x asset we can read?
void precheck_json(std::string_view text, const fs::path& base_dir) {
    Json doc;
    try {
        doc = Json::parse(text.begin(), text.end());
    } catch (const Json::exception& e) {
        fail("not glTF: invalid JSON: ", e.what());
    }
    if (!doc.is_object()) fail("not glTF: the JSON top level is not an object");
    auto asset = doc.find("asset");
    if (asset == doc.end() || !asset->is_object()) {
        std::string keys;
        for (auto it = doc.begin(); it != doc.end() && keys.size() < 80; ++it)
            keys += (keys.empty() ? "" : ", ") + it.key();
        fail("not a glTF asset: no \"asset\" object (top-level keys: ",
             keys.empty() ? "none" : keys, ")");
    }
    auto version = asset->find("version");
    if (version == asset->end() || !version->is_string())
        fail("not a glTF asset: asset.version is missing or not a string");
    const std::string v = version->get<std::string>();
    if (v.size() < 2 || v[0] != '2' || v[1] != '.')
        fail("unsupported glTF version ", quote_text(v), ": only 2.x is supported");
    auto min_version = asset->find("minVersion");
    if (min_version != asset->end() && min_version->is_string() &&
        min_version->get<std::string>() != "2.0")
        fail("asset.minVersion ", quote_text(min_version->get<std::string>()),
             " is newer than 2.0");

    static const char* const kSupported[] = {
        "KHR_lights_punctual", "KHR_mesh_quantization",
        "KHR_materials_unlit", "KHR_materials_emissive_strength",
        "MOZ_lightmap",        "MSFT_lod"};
    auto required = doc.find("extensionsRequired");
    if (required != doc.end() && required->is_array())
        for (const Json& name : *required) {
            if (!name.is_string()) fail("extensionsRequired holds a non-string");
            const std::string n = name.get<std::string>();
            if (std::find(std::begin(kSupported), std::end(kSupported), n) == std::end(kSupported))
                fail("requires extension ", quote_text(n), ", which is not supported");
        }

    for (const char* key : {"buffers", "images"}) {
        auto list = doc.find(key);
        if (list == doc.end() || !list->is_array()) continue;
        for (size_t i = 0; i < list->size(); ++i)
            if ((*list)[i].is_object())
                check_uri((*list)[i], key[0] == 'b' ? "buffer" : "image", i, base_dir);
    }
}

// Decodes any image stb reads into RGBA8; on failure returns false with *out_why.
bool decode_rgba8(tinygltf::Image* image, const unsigned char* bytes, size_t size,
                  std::string* out_why) {
    if (size == 0 || size > size_t(std::numeric_limits<int>::max())) {
        *out_why = cat("image data of ", size, " bytes is empty or too large");
        return false;
    }
    int w = 0, h = 0, n = 0;
    unsigned char* px = stbi_load_from_memory(bytes, int(size), &w, &h, &n, 4);
    if (!px) {
        const char* reason = stbi_failure_reason();
        *out_why = cat("cannot decode image: ", reason ? reason : "unknown reason");
        return false;
    }
    image->width = w;
    image->height = h;
    image->component = 4;
    image->bits = 8;
    image->pixel_type = TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE;
    image->image.assign(px, px + size_t(w) * size_t(h) * 4);
    stbi_image_free(px);
    return true;
}

// tinygltf's image callback. Images inside a bufferView are skipped here and decoded after
// parsing, once the view's range has been checked (tinygltf 2.7 reads them unchecked).
bool load_image_callback(tinygltf::Image* image, const int image_index, std::string* err,
                         std::string*, int, int, const unsigned char* bytes, int size, void*) {
    if (image->bufferView >= 0) return true;
    std::string why;
    if (decode_rgba8(image, bytes, size_t(std::max(size, 0)), &why)) return true;
    if (err)
        *err +=
            cat("image ", image_index, " ", quote_text(image->uri.substr(0, 60)), ": ", why, "\n");
    return false;
}

// ---- accessors ----

// A checked accessor: count elements of `components` values; `data` is null for an accessor
// without a bufferView (all zeros before sparse substitution).
struct AccessorView {
    const unsigned char* data = nullptr;
    size_t stride = 0;
    size_t count = 0;
    int components = 0;
    int component_type = 0;
    bool normalized = false;
    // sparse substitution
    size_t sparse_count = 0;
    const unsigned char* sparse_indices = nullptr;
    int sparse_index_type = 0;
    const unsigned char* sparse_values = nullptr;
};

std::string type_name(int type) {
    switch (type) {
        case TINYGLTF_TYPE_SCALAR:
            return "SCALAR";
        case TINYGLTF_TYPE_VEC2:
            return "VEC2";
        case TINYGLTF_TYPE_VEC3:
            return "VEC3";
        case TINYGLTF_TYPE_VEC4:
            return "VEC4";
        case TINYGLTF_TYPE_MAT2:
            return "MAT2";
        case TINYGLTF_TYPE_MAT3:
            return "MAT3";
        case TINYGLTF_TYPE_MAT4:
            return "MAT4";
        default:
            return cat("unknown (", type, ")");
    }
}

bool is_integer_type(int t) {
    return t == TINYGLTF_COMPONENT_TYPE_BYTE || t == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE ||
           t == TINYGLTF_COMPONENT_TYPE_SHORT || t == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT ||
           t == TINYGLTF_COMPONENT_TYPE_INT || t == TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT;
}

double read_component(const unsigned char* p, int type, bool normalized) {
    switch (type) {
        case TINYGLTF_COMPONENT_TYPE_BYTE: {
            int8_t v;
            std::memcpy(&v, p, 1);
            return normalized ? std::max(v / 127.0, -1.0) : v;
        }
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
            return normalized ? p[0] / 255.0 : p[0];
        case TINYGLTF_COMPONENT_TYPE_SHORT: {
            int16_t v;
            std::memcpy(&v, p, 2);
            return normalized ? std::max(v / 32767.0, -1.0) : v;
        }
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
            uint16_t v;
            std::memcpy(&v, p, 2);
            return normalized ? v / 65535.0 : v;
        }
        case TINYGLTF_COMPONENT_TYPE_INT: {
            int32_t v;
            std::memcpy(&v, p, 4);
            return v;
        }
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: {
            uint32_t v;
            std::memcpy(&v, p, 4);
            return v;
        }
        default: {
            float v;
            std::memcpy(&v, p, 4);
            return v;
        }
    }
}

// Bytes [offset, offset + needed) of bufferView `index`, range-checked against view and buffer.
// *out_stride is the view's byteStride (0: tightly packed).
const unsigned char* view_bytes(const tinygltf::Model& m, int index, uint64_t offset,
                                uint64_t needed, const std::string& what,
                                size_t* out_stride = nullptr) {
    if (index < 0 || size_t(index) >= m.bufferViews.size())
        fail(what, ": bufferView ", index, " does not exist (", m.bufferViews.size(),
             " bufferViews)");
    const tinygltf::BufferView& bv = m.bufferViews[size_t(index)];
    if (bv.buffer < 0 || size_t(bv.buffer) >= m.buffers.size())
        fail(what, ": bufferView ", index, " refers to buffer ", bv.buffer,
             ", which does not exist");
    const size_t buffer_size = m.buffers[size_t(bv.buffer)].data.size();
    if (bv.byteLength > buffer_size || bv.byteOffset > buffer_size - bv.byteLength)
        fail(what, ": bufferView ", index, " (bytes ", bv.byteOffset, " + ", bv.byteLength,
             ") is out of range of buffer ", bv.buffer, " (", buffer_size, " bytes)");
    if (offset > bv.byteLength || needed > bv.byteLength - offset)
        fail(what, ": needs bytes [", offset, ", ", offset + needed, ") of bufferView ", index,
             ", which has ", bv.byteLength, " bytes (accessor out of range)");
    if (out_stride) *out_stride = bv.byteStride;
    return m.buffers[size_t(bv.buffer)].data.data() + bv.byteOffset + offset;
}

// Checks accessor `index` for use as `what`: its type among `types` (TINYGLTF_TYPE_*), integer
// components only when `integers_only`, and every byte it reads inside its buffer.
AccessorView check_accessor(const tinygltf::Model& m, int index, const std::string& what,
                            std::initializer_list<int> types, bool integers_only) {
    if (index < 0 || size_t(index) >= m.accessors.size())
        fail(what, ": accessor ", index, " does not exist (", m.accessors.size(), " accessors)");
    const tinygltf::Accessor& a = m.accessors[size_t(index)];
    const std::string label = cat(what, " (accessor ", index, ")");
    if (std::find(types.begin(), types.end(), a.type) == types.end()) {
        std::string allowed;
        for (int t : types) allowed += (allowed.empty() ? "" : " or ") + type_name(t);
        fail(label, ": type ", type_name(a.type), " where ", allowed, " is needed");
    }
    const int type = a.componentType;
    if (!is_integer_type(type) && (integers_only || type != TINYGLTF_COMPONENT_TYPE_FLOAT))
        fail(label, ": component type ", type, " is not ",
             integers_only ? "an integer type" : "FLOAT or an integer type");

    AccessorView v;
    v.components = tinygltf::GetNumComponentsInType(uint32_t(a.type));
    v.component_type = type;
    v.normalized = a.normalized;
    v.count = a.count;
    const size_t elem =
        size_t(tinygltf::GetComponentSizeInBytes(uint32_t(type))) * size_t(v.components);
    if (a.bufferView >= 0) {
        size_t stride = 0;
        view_bytes(m, a.bufferView, 0, 0, label, &stride);  // the view itself
        v.stride = stride ? stride : elem;
        if (v.stride < elem)
            fail(label, ": byteStride ", v.stride, " is smaller than an element (", elem,
                 " bytes)");
        const uint64_t view_length = m.bufferViews[size_t(a.bufferView)].byteLength;
        if (v.count > view_length)
            fail(label, ": count ", v.count, " exceeds bufferView ", a.bufferView, " (",
                 view_length, " bytes; accessor out of range)");
        const uint64_t needed = v.count ? uint64_t(v.stride) * (v.count - 1) + elem : 0;
        v.data = view_bytes(m, a.bufferView, a.byteOffset, needed, label);
    } else if (v.count > kMaxZeroAccessor) {
        fail(label, ": count ", v.count, " without a bufferView is implausibly large");
    }
    if (a.sparse.isSparse) {
        const int itype = a.sparse.indices.componentType;
        if (a.sparse.count < 1 || size_t(a.sparse.count) > v.count)
            fail(label, ": sparse count ", a.sparse.count, " is not in [1, ", v.count, "]");
        if (itype != TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE &&
            itype != TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT &&
            itype != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT)
            fail(label, ": sparse indices have component type ", itype);
        if (a.sparse.indices.byteOffset < 0 || a.sparse.values.byteOffset < 0)
            fail(label, ": negative sparse byteOffset");
        v.sparse_count = size_t(a.sparse.count);
        v.sparse_index_type = itype;
        v.sparse_indices = view_bytes(
            m, a.sparse.indices.bufferView, uint64_t(a.sparse.indices.byteOffset),
            uint64_t(v.sparse_count) * tinygltf::GetComponentSizeInBytes(uint32_t(itype)),
            label + " sparse indices");
        v.sparse_values =
            view_bytes(m, a.sparse.values.bufferView, uint64_t(a.sparse.values.byteOffset),
                       uint64_t(v.sparse_count) * elem, label + " sparse values");
    }
    return v;
}

// Calls put(element, component, value) for every value of the accessor: the base data (zeros
// without a bufferView), then the sparse substitutions, which may overwrite.
template <class Put>
void decode(const AccessorView& v, const std::string& what, Put&& put) {
    const size_t csize = size_t(tinygltf::GetComponentSizeInBytes(uint32_t(v.component_type)));
    for (size_t i = 0; i < v.count; ++i)
        for (int c = 0; c < v.components; ++c)
            put(i, c,
                v.data ? read_component(v.data + i * v.stride + size_t(c) * csize, v.component_type,
                                        v.normalized)
                       : 0.0);
    const size_t isize = size_t(tinygltf::GetComponentSizeInBytes(uint32_t(v.sparse_index_type)));
    for (size_t s = 0; s < v.sparse_count; ++s) {
        const double target =
            read_component(v.sparse_indices + s * isize, v.sparse_index_type, false);
        if (target >= double(v.count))
            fail(what, ": sparse index ", static_cast<long long>(target),
                 " is out of range (count ", v.count, ")");
        const unsigned char* src = v.sparse_values + s * csize * size_t(v.components);
        for (int c = 0; c < v.components; ++c)
            put(size_t(target), c,
                read_component(src + size_t(c) * csize, v.component_type, v.normalized));
    }
}

template <class Vec>
std::vector<Vec> read_vectors(const tinygltf::Model& m, int index, const std::string& what,
                              std::initializer_list<int> types, size_t expected_count,
                              bool normalized_if_integer = false) {
    const AccessorView v = check_accessor(m, index, what, types, false);
    if (normalized_if_integer && is_integer_type(v.component_type) && !v.normalized)
        fail(what, " (accessor ", index, "): integer components must be normalized");
    if (expected_count != size_t(-1) && v.count != expected_count)
        fail(what, " (accessor ", index, "): count ", v.count, " differs from POSITION's ",
             expected_count);
    std::vector<Vec> out(v.count, Vec(0));
    if constexpr (Vec::length() == 4)
        for (Vec& x : out) x.w = 1.0f;  // COLOR_0 as VEC3: opaque
    decode(v, what, [&](size_t i, int c, double x) {
        if (c < Vec::length()) out[i][c] = float(x);
    });
    return out;
}

// ---- scene conversion ----

const char* mode_name(int mode) {
    switch (mode) {
        case TINYGLTF_MODE_POINTS:
            return "POINTS";
        case TINYGLTF_MODE_LINE:
            return "LINES";
        case TINYGLTF_MODE_LINE_LOOP:
            return "LINE_LOOP";
        case TINYGLTF_MODE_LINE_STRIP:
            return "LINE_STRIP";
        default:
            return "unknown";
    }
}

Primitive convert_primitive(const tinygltf::Model& m, const tinygltf::Primitive& src,
                            const std::string& label) {
    const int mode = src.mode < 0 ? TINYGLTF_MODE_TRIANGLES : src.mode;
    if (mode != TINYGLTF_MODE_TRIANGLES && mode != TINYGLTF_MODE_TRIANGLE_STRIP &&
        mode != TINYGLTF_MODE_TRIANGLE_FAN)
        fail(label, ": mode ", mode_name(mode), " (", mode,
             ") is not supported; only TRIANGLES, TRIANGLE_STRIP and TRIANGLE_FAN load");
    auto attribute = [&](const char* name) {
        auto it = src.attributes.find(name);
        return it == src.attributes.end() ? -1 : it->second;
    };
    Primitive p;
    const int pos = attribute("POSITION");
    if (pos < 0) fail(label, ": no POSITION attribute");
    p.positions =
        read_vectors<glm::vec3>(m, pos, label + " POSITION", {TINYGLTF_TYPE_VEC3}, size_t(-1));
    const size_t n = p.positions.size();
    if (n > std::numeric_limits<uint32_t>::max())
        fail(label, ": ", n, " vertices exceed 32-bit indices");
    for (size_t i = 0; i < n; ++i) {
        const glm::vec3& x = p.positions[i];
        if (!std::isfinite(x.x) || !std::isfinite(x.y) || !std::isfinite(x.z))
            fail(label, ": POSITION ", i, " is not finite (", x.x, ", ", x.y, ", ", x.z, ")");
    }
    if (int a = attribute("NORMAL"); a >= 0)
        p.normals = read_vectors<glm::vec3>(m, a, label + " NORMAL", {TINYGLTF_TYPE_VEC3}, n, true);
    if (int a = attribute("TEXCOORD_0"); a >= 0) {
        p.uv0 = read_vectors<glm::vec2>(m, a, label + " TEXCOORD_0", {TINYGLTF_TYPE_VEC2}, n);
        // An accessor without data is all zeros: what the writer puts as the TEXCOORD_0 that
        // glTF requires before a TEXCOORD_1. The renderer reads a missing uv0 as 0 as well.
        const tinygltf::Accessor& acc = m.accessors[size_t(a)];
        if (acc.bufferView < 0 && !acc.sparse.isSparse) p.uv0.clear();
    }
    if (int a = attribute("TEXCOORD_1"); a >= 0)
        p.uv1 = read_vectors<glm::vec2>(m, a, label + " TEXCOORD_1", {TINYGLTF_TYPE_VEC2}, n);
    if (int a = attribute("COLOR_0"); a >= 0)
        p.colors = read_vectors<glm::vec4>(m, a, label + " COLOR_0",
                                           {TINYGLTF_TYPE_VEC3, TINYGLTF_TYPE_VEC4}, n, true);
    if (int a = attribute("_LIGHT_0"); a >= 0) {
        p.light = read_vectors<glm::vec3>(m, a, label + " _LIGHT_0", {TINYGLTF_TYPE_VEC3}, n);
    } else if (!p.colors.empty()) {
        // Files baked before _LIGHT_0 stored the light as COLOR_0 = (E / pi, 1), above 1 where
        // bright (which glTF does not allow): such colours are read as the light they are.
        bool opaque = true, above_one = false;
        for (const glm::vec4& c : p.colors) {
            opaque &= c.a == 1.0f;
            above_one |= c.r > 1.0f || c.g > 1.0f || c.b > 1.0f;
        }
        if (opaque && above_one) {
            p.light.resize(n);
            for (size_t i = 0; i < n; ++i)
                p.light[i] = glm::vec3(p.colors[i]) * std::numbers::pi_v<float>;
            p.colors.clear();
        }
    }

    std::vector<uint32_t> order;  // vertex order as stored, before strip/fan expansion
    if (src.indices >= 0) {
        const std::string what = label + " indices";
        const AccessorView v = check_accessor(m, src.indices, what, {TINYGLTF_TYPE_SCALAR}, true);
        order.resize(v.count);
        decode(v, what, [&](size_t i, int, double x) {
            if (x < 0 || x >= double(n))
                fail(label, ": index ", static_cast<long long>(x), " (at position ", i,
                     ") is out of range: the primitive has ", n, " vertices");
            order[i] = uint32_t(x);
        });
    } else {
        order.resize(n);
        for (size_t i = 0; i < n; ++i) order[i] = uint32_t(i);
    }
    if (mode == TINYGLTF_MODE_TRIANGLES) {
        if (order.size() % 3 != 0)
            fail(label, ": ", order.size(), " indices is not a multiple of 3 for TRIANGLES");
        p.indices = std::move(order);
    } else if (order.size() >= 3) {
        p.indices.reserve((order.size() - 2) * 3);
        for (size_t i = 0; i + 2 < order.size(); ++i) {
            if (mode == TINYGLTF_MODE_TRIANGLE_STRIP)  // keep the winding of every other triangle
                p.indices.insert(p.indices.end(),
                                 {order[i], order[i + 1 + i % 2], order[i + 2 - i % 2]});
            else
                p.indices.insert(p.indices.end(), {order[i + 1], order[i + 2], order[0]});
        }
    }
    if (src.material >= 0 && size_t(src.material) >= m.materials.size())
        fail(label, ": material ", src.material, " does not exist (", m.materials.size(),
             " materials)");
    p.material = src.material;
    if (p.normals.empty()) compute_vertex_normals(p);
    return p;
}

int texture_ref(const tinygltf::Model& m, int index, const std::string& what) {
    if (index < -1 || (index >= 0 && size_t(index) >= m.textures.size()))
        fail(what, ": texture ", index, " does not exist (", m.textures.size(), " textures)");
    return index;
}

Material convert_material(const tinygltf::Model& m, const tinygltf::Material& src,
                          const std::string& label) {
    Material out;
    out.name = src.name;
    const std::vector<double>& f = src.pbrMetallicRoughness.baseColorFactor;
    if (f.size() != 4) fail(label, ": baseColorFactor has ", f.size(), " values, not 4");
    out.base_color_factor = glm::vec4(float(f[0]), float(f[1]), float(f[2]), float(f[3]));
    out.base_color_texture = texture_ref(m, src.pbrMetallicRoughness.baseColorTexture.index,
                                         label + " baseColorTexture");
    out.double_sided = src.doubleSided;
    if (src.emissiveFactor.size() == 3)
        out.emissive_factor = glm::vec3(float(src.emissiveFactor[0]), float(src.emissiveFactor[1]),
                                        float(src.emissiveFactor[2]));
    if (auto es = src.extensions.find("KHR_materials_emissive_strength");
        es != src.extensions.end() && es->second.IsObject() && es->second.Has("emissiveStrength")) {
        // Emitted radiance = emissiveFactor x emissiveStrength (the extension lets emission go
        // above the core spec's [0, 1] factor).
        const tinygltf::Value& v = es->second.Get("emissiveStrength");
        if (!v.IsNumber() || !std::isfinite(v.GetNumberAsDouble()) || v.GetNumberAsDouble() < 0.0)
            fail(label,
                 " KHR_materials_emissive_strength: emissiveStrength is not a finite "
                 "number >= 0");
        out.emissive_factor *= float(v.GetNumberAsDouble());
    }
    auto ext = src.extensions.find("MOZ_lightmap");
    if (ext != src.extensions.end()) {
        const tinygltf::Value& v = ext->second;
        const std::string what = label + " MOZ_lightmap";
        if (!v.IsObject() || !v.Has("index") || !v.Get("index").IsInt())
            fail(what, ": needs an integer \"index\"");
        out.lightmap.texture = texture_ref(m, v.Get("index").GetNumberAsInt(), what);
        if (out.lightmap.texture < 0) fail(what, ": index ", out.lightmap.texture, " is negative");
        if (v.Has("texCoord")) {
            if (!v.Get("texCoord").IsInt() || v.Get("texCoord").GetNumberAsInt() < 0)
                fail(what, ": texCoord is not a non-negative integer");
            out.lightmap.tex_coord = v.Get("texCoord").GetNumberAsInt();
        }
        if (v.Has("intensity")) {
            if (!v.Get("intensity").IsNumber() ||
                !std::isfinite(v.Get("intensity").GetNumberAsDouble()))
                fail(what, ": intensity is not a finite number");
            out.lightmap.intensity = float(v.Get("intensity").GetNumberAsDouble());
        }
        if (v.Has("extras") && v.Get("extras").IsObject() && v.Get("extras").Has("encoding")) {
            const tinygltf::Value& e = v.Get("extras").Get("encoding");
            const std::string name = e.IsString() ? e.Get<std::string>() : std::string();
            if (name == "RGBM")
                out.lightmap.encoding = LightmapEncoding::Rgbm;
            else if (name != "linear")
                fail(what, ": extras.encoding is not \"linear\" or \"RGBM\"");
        }
    }
    return out;
}

bool finite3(const glm::dvec3& v) {
    return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

bool all_finite(const std::vector<double>& v) {
    return std::all_of(v.begin(), v.end(), [](double x) { return std::isfinite(x); });
}

void set_transform(const tinygltf::Node& src, Node* out, const std::string& label) {
    if (!src.matrix.empty()) {
        if (src.matrix.size() != 16 || !all_finite(src.matrix))
            fail(label, ": matrix needs 16 finite numbers");
        glm::dmat4 mat;
        for (int c = 0; c < 4; ++c)
            for (int r = 0; r < 4; ++r) mat[c][r] = src.matrix[size_t(c * 4 + r)];
        if (mat[0][3] != 0.0 || mat[1][3] != 0.0 || mat[2][3] != 0.0 || mat[3][3] != 1.0)
            fail(label, ": matrix is not affine (last row must be 0 0 0 1)");
        glm::dvec3 skew;
        glm::dvec4 perspective;
        glm::dvec3 scale, translation;
        glm::dquat rotation;
        const bool ok = glm::decompose(mat, scale, rotation, translation, skew, perspective);
        const bool finite = finite3(scale) && finite3(translation) && std::isfinite(rotation.w) &&
                            std::isfinite(rotation.x) && std::isfinite(rotation.y) &&
                            std::isfinite(rotation.z);
        if (ok && finite && glm::length(rotation) > 0.0) {
            out->translation = translation;
            out->rotation = glm::normalize(rotation);
            out->scale = scale;
        } else {  // singular: keep what survives
            out->translation = glm::dvec3(mat[3]);
            out->rotation = glm::dquat(1.0, 0.0, 0.0, 0.0);
            out->scale =
                glm::dvec3(glm::length(glm::dvec3(mat[0])), glm::length(glm::dvec3(mat[1])),
                           glm::length(glm::dvec3(mat[2])));
        }
        return;
    }
    if (!src.translation.empty()) {
        if (src.translation.size() != 3 || !all_finite(src.translation))
            fail(label, ": translation needs 3 finite numbers");
        out->translation = glm::dvec3(src.translation[0], src.translation[1], src.translation[2]);
    }
    if (!src.rotation.empty()) {
        if (src.rotation.size() != 4 || !all_finite(src.rotation))
            fail(label, ": rotation needs 4 finite numbers");
        const glm::dquat q(src.rotation[3], src.rotation[0], src.rotation[1], src.rotation[2]);
        if (glm::length(q) < 1e-12) fail(label, ": rotation is a zero quaternion");
        out->rotation = glm::normalize(q);
    }
    if (!src.scale.empty()) {
        if (src.scale.size() != 3 || !all_finite(src.scale))
            fail(label, ": scale needs 3 finite numbers");
        out->scale = glm::dvec3(src.scale[0], src.scale[1], src.scale[2]);
    }
}

Node convert_node(const tinygltf::Model& m, const tinygltf::Node& src, int self,
                  const std::string& label) {
    Node out;
    out.name = src.name;
    set_transform(src, &out, label);
    if (src.mesh < -1 || (src.mesh >= 0 && size_t(src.mesh) >= m.meshes.size()))
        fail(label, ": mesh ", src.mesh, " does not exist (", m.meshes.size(), " meshes)");
    out.mesh = src.mesh;
    for (int c : src.children) {
        if (c < 0 || size_t(c) >= m.nodes.size())
            fail(label, ": child ", c, " does not exist (", m.nodes.size(), " nodes)");
        if (c == self) fail(label, ": node graph cycle: the node is its own child");
    }
    out.children = src.children;

    if (auto ext = src.extensions.find("MSFT_lod"); ext != src.extensions.end()) {
        const tinygltf::Value& v = ext->second;
        if (!v.IsObject() || !v.Has("ids") || !v.Get("ids").IsArray())
            fail(label, ": MSFT_lod needs an \"ids\" array");
        const tinygltf::Value& ids = v.Get("ids");
        for (size_t i = 0; i < ids.ArrayLen(); ++i) {
            const tinygltf::Value& id = ids.Get(int(i));
            if (!id.IsInt()) fail(label, ": MSFT_lod ids[", i, "] is not an integer");
            const int n = id.GetNumberAsInt();
            if (n < 0 || size_t(n) >= m.nodes.size())
                fail(label, ": MSFT_lod id ", n, " is out of range (", m.nodes.size(), " nodes)");
            if (n == self) fail(label, ": MSFT_lod id ", n, " is the node itself");
            out.lod_ids.push_back(n);
        }
    }
    if (src.extras.IsObject()) {
        if (src.extras.Has("MSFT_screencoverage")) {
            const tinygltf::Value& sc = src.extras.Get("MSFT_screencoverage");
            if (!sc.IsArray()) fail(label, ": extras.MSFT_screencoverage is not an array");
            for (size_t i = 0; i < sc.ArrayLen(); ++i) {
                const tinygltf::Value& x = sc.Get(int(i));
                if (!x.IsNumber() || !std::isfinite(x.GetNumberAsDouble()))
                    fail(label, ": extras.MSFT_screencoverage[", i, "] is not a finite number");
                out.screen_coverage.push_back(x.GetNumberAsDouble());
            }
        }
        if (src.extras.Has("geometric_error")) {
            const tinygltf::Value& e = src.extras.Get("geometric_error");
            if (!e.IsNumber() || !std::isfinite(e.GetNumberAsDouble()) ||
                e.GetNumberAsDouble() < 0.0)
                fail(label, ": extras.geometric_error is not a finite number >= 0");
            out.geometric_error_m = e.GetNumberAsDouble();
        }
    }
    return out;
}

// glTF nodes form disjoint strict trees: one parent at most, no cycles.
std::vector<int> check_forest(const std::vector<Node>& nodes) {
    std::vector<int> parent(nodes.size(), -1);
    for (size_t p = 0; p < nodes.size(); ++p)
        for (int c : nodes[p].children) {
            if (parent[size_t(c)] >= 0)
                fail("node ", c, " is a child of both node ", parent[size_t(c)], " and node ", p,
                     " (glTF nodes must form trees)");
            parent[size_t(c)] = int(p);
        }
    std::vector<char> reached(nodes.size(), 0);
    std::vector<int> stack;
    for (size_t i = 0; i < nodes.size(); ++i)
        if (parent[i] < 0) stack.push_back(int(i));
    while (!stack.empty()) {
        const int i = stack.back();
        stack.pop_back();
        reached[size_t(i)] = 1;
        for (int c : nodes[size_t(i)].children) stack.push_back(c);
    }
    for (size_t i = 0; i < nodes.size(); ++i) {
        if (reached[i]) continue;
        // every unreached node hangs below a cycle: walking up n parents lands on it
        int k = int(i);
        for (size_t step = 0; step < nodes.size(); ++step) k = parent[size_t(k)];
        fail("node graph cycle through node ", k);
    }
    return parent;
}

Light convert_light(const tinygltf::Light& src, const std::string& label) {
    Light out;
    out.name = src.name;
    if (src.type == "point")
        out.type = Light::Type::Point;
    else if (src.type == "spot")
        out.type = Light::Type::Spot;
    else if (src.type == "directional")
        out.type = Light::Type::Directional;
    else
        fail(label, ": unknown type ", quote_text(src.type));
    if (!src.color.empty()) {
        if (src.color.size() != 3 || !all_finite(src.color))
            fail(label, ": color needs 3 finite numbers");
        out.color = glm::vec3(float(src.color[0]), float(src.color[1]), float(src.color[2]));
    }
    if (!std::isfinite(src.intensity) || !std::isfinite(src.range) || src.range < 0.0)
        fail(label, ": intensity or range is not a finite number (range >= 0)");
    out.intensity = float(src.intensity);
    out.range = float(src.range);
    if (out.type == Light::Type::Spot) {
        out.inner_cone_rad = float(src.spot.innerConeAngle);
        out.outer_cone_rad = float(src.spot.outerConeAngle);
        if (!(out.inner_cone_rad >= 0.0f && out.inner_cone_rad < out.outer_cone_rad &&
              out.outer_cone_rad <= 1.5707964f))
            fail(label, ": spot cones need 0 <= inner < outer <= pi/2");
    }
    return out;
}

Scene convert(const tinygltf::Model& m) {
    Scene scene;
    // textures: one RGBA8 image per glTF texture, decoded from its source
    for (size_t i = 0; i < m.images.size(); ++i) {
        const tinygltf::Image& img = m.images[i];
        if (img.bufferView < 0 && img.image.empty())
            fail("image ", i, ": uri ", quote_text(img.uri), " could not be loaded");
    }
    std::vector<tinygltf::Image> images = m.images;
    for (size_t i = 0; i < images.size(); ++i) {
        tinygltf::Image& img = images[i];
        if (img.bufferView < 0) continue;
        const std::string what = cat("image ", i);
        const unsigned char* bytes = view_bytes(m, img.bufferView, 0, 0, what);  // checks the view
        const size_t length = m.bufferViews[size_t(img.bufferView)].byteLength;
        std::string why;
        if (!decode_rgba8(&img, bytes, length, &why)) fail(what, ": ", why);
    }
    for (size_t i = 0; i < m.textures.size(); ++i) {
        const tinygltf::Texture& t = m.textures[i];
        if (t.source < 0 || size_t(t.source) >= images.size())
            fail("texture ", i, ": source image ", t.source, " does not exist (", images.size(),
                 " images)");
        const tinygltf::Image& img = images[size_t(t.source)];
        Texture tex;
        tex.name = !t.name.empty() ? t.name : !img.name.empty() ? img.name : img.uri;
        tex.width = img.width;
        tex.height = img.height;
        tex.rgba8 = img.image;
        scene.textures.push_back(std::move(tex));
    }
    for (size_t i = 0; i < m.materials.size(); ++i)
        scene.materials.push_back(
            convert_material(m, m.materials[i], label_of("material", i, m.materials[i].name)));
    for (size_t i = 0; i < m.meshes.size(); ++i) {
        Mesh mesh;
        mesh.name = m.meshes[i].name;
        for (size_t j = 0; j < m.meshes[i].primitives.size(); ++j)
            mesh.primitives.push_back(
                convert_primitive(m, m.meshes[i].primitives[j],
                                  label_of("mesh", i, mesh.name) + cat(" primitive ", j)));
        scene.meshes.push_back(std::move(mesh));
    }
    for (size_t i = 0; i < m.nodes.size(); ++i)
        scene.nodes.push_back(
            convert_node(m, m.nodes[i], int(i), label_of("node", i, m.nodes[i].name)));
    const std::vector<int> parent = check_forest(scene.nodes);

    // default scene roots
    if (m.defaultScene >= 0 && size_t(m.defaultScene) >= m.scenes.size())
        fail("default scene ", m.defaultScene, " does not exist (", m.scenes.size(), " scenes)");
    if (!m.scenes.empty()) {
        const tinygltf::Scene& s = m.scenes[size_t(std::max(m.defaultScene, 0))];
        const int index = std::max(m.defaultScene, 0);
        for (int r : s.nodes) {
            if (r < 0 || size_t(r) >= scene.nodes.size())
                fail("scene ", index, ": node ", r, " does not exist (", scene.nodes.size(),
                     " nodes)");
            if (parent[size_t(r)] >= 0)
                fail("scene ", index, ": node ", r, " is not a root (it is a child of node ",
                     parent[size_t(r)], ")");
        }
        scene.roots = s.nodes;
    } else {
        for (size_t i = 0; i < parent.size(); ++i)
            if (parent[i] < 0) scene.roots.push_back(int(i));
    }

    // KHR_lights_punctual
    for (size_t i = 0; i < m.lights.size(); ++i)
        scene.lights.push_back(convert_light(m.lights[i], label_of("light", i, m.lights[i].name)));
    const size_t declared_lights = scene.lights.size();
    for (size_t i = 0; i < m.nodes.size(); ++i) {
        auto ext = m.nodes[i].extensions.find("KHR_lights_punctual");
        if (ext == m.nodes[i].extensions.end()) continue;
        const tinygltf::Value& v = ext->second;
        if (!v.IsObject() || !v.Has("light") || !v.Get("light").IsInt())
            fail("node ", i, ": KHR_lights_punctual needs an integer \"light\"");
        const int l = v.Get("light").GetNumberAsInt();
        if (l < 0 || size_t(l) >= declared_lights)
            fail("node ", i, ": light ", l, " does not exist (", declared_lights, " lights)");
        if (scene.lights[size_t(l)].node < 0) {
            scene.lights[size_t(l)].node = int(i);
        } else {
            Light copy = scene.lights[size_t(l)];
            copy.node = int(i);
            scene.lights.push_back(std::move(copy));
        }
    }
    return scene;
}

Scene load(const fs::path& path) {
    std::error_code ec;
    if (!fs::exists(path, ec)) fail("file not found");
    if (fs::is_directory(path, ec)) fail("is a directory, not a glTF file");
    Result<std::string> read = read_file(path);
    if (!read.ok()) {
        // read_file's message already names the file; keep only the reason
        std::string msg = read.error().message;
        const std::string prefix = path.string() + ": ";
        if (msg.rfind(prefix, 0) == 0) msg = msg.substr(prefix.size());
        fail("cannot read: ", msg);
    }
    const std::string& bytes = read.value();
    if (bytes.empty()) fail("empty file");
    if (bytes.size() > std::numeric_limits<uint32_t>::max())
        fail("file of ", bytes.size(), " bytes exceeds 4 GiB");
    const fs::path base_dir = path.parent_path().empty() ? fs::path(".") : path.parent_path();

    const bool glb = bytes.size() >= 4 &&
                     read_u32le(reinterpret_cast<const unsigned char*>(bytes.data())) == kGlbMagic;
    size_t glb_length = 0;
    std::string_view json_text;
    if (glb) {
        json_text = check_glb(bytes, &glb_length);
    } else {
        const size_t bom = bytes.rfind("\xEF\xBB\xBF", 0) == 0 ? 3 : 0;
        const size_t first = bytes.find_first_not_of(" \t\r\n", bom);
        if (first == std::string::npos || bytes[first] != '{')
            fail("not glTF: neither the GLB magic \"glTF\" nor a JSON object (first bytes ",
                 quote_text(bytes.substr(0, 8)), ")");
        json_text = bytes;
    }
    precheck_json(json_text, base_dir);

    tinygltf::Model model;
    tinygltf::TinyGLTF parser;
    parser.SetImageLoader(&load_image_callback, nullptr);
    std::string err, warn;
    const bool parsed =
        glb ? parser.LoadBinaryFromMemory(&model, &err, &warn,
                                          reinterpret_cast<const unsigned char*>(bytes.data()),
                                          unsigned(glb_length), base_dir.string())
            : parser.LoadASCIIFromString(&model, &err, &warn, bytes.data(), unsigned(bytes.size()),
                                         base_dir.string());
    const std::string notes = one_line((err.empty() ? "" : "tinygltf error: " + err) +
                                       (warn.empty() ? "" : " tinygltf warning: " + warn));
    if (!parsed) fail("glTF parse failed: ", notes.empty() ? "no reason given" : notes);
    try {
        return convert(model);
    } catch (LoadError& e) {
        if (!notes.empty()) e.message += " [" + notes + "]";
        throw;
    }
}

}  // namespace

Result<Scene> load_gltf(const std::filesystem::path& path) {
    try {
        return load(path);
    } catch (const LoadError& e) {
        return make_error(path.string() + ": " + e.message);
    } catch (const std::bad_alloc&) {
        return make_error(path.string() + ": out of memory while loading (implausible sizes?)");
    } catch (const std::exception& e) {
        return make_error(path.string() + ": malformed glTF: " + e.what());
    } catch (...) {
        return make_error(path.string() + ": malformed glTF: unknown failure");
    }
}

}  // namespace hmdnode
