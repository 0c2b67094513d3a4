// Wavefront OBJ reader: one pass over the lines collects v/vt/vn and face corners, then corners
// are de-duplicated per (v, vt, vn) triple. Time O(file size); memory O(elements + corners).
#include "hmdnode/core/obj.hpp"

#include <charconv>
#include <cmath>
#include <cstdint>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "hmdnode/core/atomic_file.hpp"

namespace hmdnode {
namespace {

struct Corner {
    int v = -1, vt = -1, vn = -1;  // 0-based, -1 = absent
    bool operator==(const Corner&) const = default;
};

struct CornerHash {
    size_t operator()(const Corner& c) const {
        uint64_t h = uint64_t(uint32_t(c.v)) * 0x9E3779B97F4A7C15ull;
        h ^= (uint64_t(uint32_t(c.vt)) + 0x632BE59BD9B4E019ull + (h << 6) + (h >> 2));
        h ^= (uint64_t(uint32_t(c.vn)) + 0x85EBCA77C2B2AE63ull + (h << 6) + (h >> 2));
        return size_t(h);
    }
};

bool is_space(char c) {
    return c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v';
}

// Splits a line into whitespace-separated tokens (views into the line).
void tokenize(std::string_view line, std::vector<std::string_view>* out) {
    out->clear();
    size_t i = 0;
    while (i < line.size()) {
        while (i < line.size() && is_space(line[i])) ++i;
        size_t start = i;
        while (i < line.size() && !is_space(line[i])) ++i;
        if (i > start) out->push_back(line.substr(start, i - start));
    }
}

bool parse_float(std::string_view s, float* out) {
    if (!s.empty() && s.front() == '+') s.remove_prefix(1);
    if (s.empty()) return false;
    auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), *out);
    return ec == std::errc() && end == s.data() + s.size() && std::isfinite(*out);
}

bool parse_int(std::string_view s, long long* out) {
    if (!s.empty() && s.front() == '+') s.remove_prefix(1);
    if (s.empty()) return false;
    auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), *out);
    return ec == std::errc() && end == s.data() + s.size();
}

class Parser {
  public:
    explicit Parser(const std::filesystem::path& path) : path_(path) {}

    Error error(size_t line, const std::string& what) const {
        return make_error(path_.string() + ":" + std::to_string(line) + ": " + what);
    }

    // Resolves a 1-based (or negative, relative) OBJ index against `count` elements.
    bool resolve(std::string_view field, size_t count, const char* kind, size_t line, int* out,
                 Error* out_error) const {
        long long i = 0;
        if (!parse_int(field, &i)) {
            *out_error =
                error(line, std::string("bad ") + kind + " index '" + std::string(field) + "'");
            return false;
        }
        long long resolved = i > 0 ? i - 1 : (i < 0 ? (long long)count + i : -1);
        if (resolved < 0 || resolved >= (long long)count) {
            *out_error = error(line, std::string(kind) + " index " + std::to_string(i) +
                                         " out of range (" + std::to_string(count) + " defined)");
            return false;
        }
        *out = int(resolved);
        return true;
    }

    Result<Mesh> run(std::string_view text) {
        std::vector<glm::vec3> v;
        std::vector<glm::vec2> vt;
        std::vector<glm::vec3> vn;
        std::vector<Corner> corners;  // 3 per triangle
        std::vector<std::string_view> tok;
        std::vector<Corner> poly;

        size_t line_no = 0;
        size_t pos = 0;
        while (pos < text.size()) {
            size_t end = text.find('\n', pos);
            if (end == std::string_view::npos) end = text.size();
            std::string_view line = text.substr(pos, end - pos);
            pos = end + 1;
            ++line_no;
            if (size_t hash = line.find('#'); hash != std::string_view::npos)
                line = line.substr(0, hash);
            tokenize(line, &tok);
            if (tok.empty()) continue;
            std::string_view key = tok[0];
            if (key == "v" || key == "vn") {
                if (tok.size() < 4)
                    return error(line_no, std::string(key) + " needs three numbers");
                glm::vec3 p;
                for (int k = 0; k < 3; ++k)
                    if (!parse_float(tok[1 + k], &p[k]))
                        return error(line_no, "bad number '" + std::string(tok[1 + k]) + "'");
                if (key == "v" && tok.size() >= 5) {  // optional w (rational), rarely used
                    float w = 1.0f;
                    if (!parse_float(tok[4], &w) || w == 0.0f)
                        return error(line_no, "bad number '" + std::string(tok[4]) + "'");
                    p /= w;
                }
                (key == "v" ? v : vn).push_back(p);
            } else if (key == "vt") {
                if (tok.size() < 2) return error(line_no, "vt needs at least one number");
                glm::vec2 t(0.0f);
                for (size_t k = 0; k < 2 && k + 1 < tok.size(); ++k)
                    if (!parse_float(tok[1 + k], &t[int(k)]))
                        return error(line_no, "bad number '" + std::string(tok[1 + k]) + "'");
                vt.push_back(t);
            } else if (key == "f") {
                if (tok.size() < 4) return error(line_no, "a face needs at least three corners");
                poly.clear();
                for (size_t k = 1; k < tok.size(); ++k) {
                    std::string_view c = tok[k];
                    std::string_view f[3];
                    int nf = 0;
                    size_t s = 0;
                    for (;;) {
                        size_t slash = c.find('/', s);
                        if (nf == 3)
                            return error(line_no, "bad face corner '" + std::string(c) + "'");
                        f[nf++] =
                            c.substr(s, slash == std::string_view::npos ? c.size() - s : slash - s);
                        if (slash == std::string_view::npos) break;
                        s = slash + 1;
                    }
                    Corner cr;
                    Error err;
                    if (!resolve(f[0], v.size(), "vertex", line_no, &cr.v, &err)) return err;
                    if (nf >= 2 && !f[1].empty() &&
                        !resolve(f[1], vt.size(), "texture coordinate", line_no, &cr.vt, &err))
                        return err;
                    if (nf >= 3 && !f[2].empty() &&
                        !resolve(f[2], vn.size(), "normal", line_no, &cr.vn, &err))
                        return err;
                    poly.push_back(cr);
                }
                for (size_t k = 1; k + 1 < poly.size(); ++k) {
                    corners.push_back(poly[0]);
                    corners.push_back(poly[k]);
                    corners.push_back(poly[k + 1]);
                }
            }
            // Everything else (o, g, s, usemtl, mtllib, l, p, ...) carries no geometry we keep.
        }
        if (corners.empty()) return make_error(path_.string() + ": no faces");

        Mesh mesh;
        mesh.name = path_.stem().string();
        Primitive& prim = mesh.primitives.emplace_back();

        bool any_vt = false, all_vn = true;
        for (const Corner& c : corners) {
            any_vt |= c.vt >= 0;
            all_vn &= c.vn >= 0;
        }

        std::unordered_map<Corner, uint32_t, CornerHash> index_of;
        index_of.reserve(corners.size());
        std::vector<int> position_of;  // output vertex -> OBJ position index
        prim.indices.reserve(corners.size());
        for (const Corner& c : corners) {
            auto [it, inserted] = index_of.try_emplace(c, uint32_t(prim.positions.size()));
            if (inserted) {
                prim.positions.push_back(v[c.v]);
                position_of.push_back(c.v);
                if (any_vt) {
                    glm::vec2 t = c.vt >= 0 ? vt[c.vt] : glm::vec2(0.0f);
                    prim.uv0.push_back(glm::vec2(t.x, 1.0f - t.y));
                }
                glm::vec3 n = c.vn >= 0 ? vn[c.vn] : glm::vec3(0.0f);
                float len = glm::length(n);
                prim.normals.push_back(len > 0.0f ? n / len : glm::vec3(0.0f));
            }
            prim.indices.push_back(it->second);
        }

        if (!all_vn) {
            // Area-weighted: the unnormalised cross product is twice the face area times its
            // normal.
            std::vector<glm::vec3> acc(v.size(), glm::vec3(0.0f));
            for (size_t t = 0; t < corners.size(); t += 3) {
                const glm::vec3& a = v[corners[t].v];
                glm::vec3 n = glm::cross(v[corners[t + 1].v] - a, v[corners[t + 2].v] - a);
                for (int k = 0; k < 3; ++k) acc[corners[t + k].v] += n;
            }
            for (size_t i = 0; i < corners.size(); ++i) {
                const Corner& c = corners[i];
                if (c.vn >= 0) continue;
                glm::vec3 n = acc[c.v];
                float len = glm::length(n);
                prim.normals[prim.indices[i]] = len > 0.0f ? n / len : glm::vec3(0.0f, 1.0f, 0.0f);
            }
        }
        return mesh;
    }

  private:
    std::filesystem::path path_;
};

}  // namespace

Result<Mesh> load_obj(const std::filesystem::path& path) {
    Result<std::string> bytes = read_file(path);
    if (!bytes) return bytes.error();
    return Parser(path).run(*bytes);
}

}  // namespace hmdnode
