// Input mesh checks and repairs for the LOD generator: the usual mesh-cleaning pass of tools such
// as MeshLab's "remove duplicate/degenerate faces, unreferenced vertices" and the greedy
// manifold-extraction of Guéziec, Taubin, Lazarus & Horn ("Cutting and stitching: converting sets
// of polygons to manifold surfaces", IEEE TVCG 2001, section 3), reduced to its cheapest form:
// faces are taken in input order and a face that would make an edge non-manifold (a third face)
// or mis-oriented (a directed edge used twice) is flipped when that cures it, dropped otherwise.
// Departure from the paper: no vertex splitting and no re-stitching of the cut edges (dropping a
// face opens a small hole rather than cutting the surface), which keeps the pass O(F) and is
// enough for the edge-collapse engine, which needs at most two consistently oriented faces per
// edge.
//
// Cost: O(V + F) expected time (open-addressing hash tables on positions, faces and directed
// edges, sized up front: no allocation per entry), O(V + F) memory.
#include "hmdnode/lod/mesh_repair.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <type_traits>
#include <vector>

#include "hmdnode/core/str_cat.hpp"
#include "position_set.hpp"

namespace hmdnode {
namespace {

// Positions as simplify() welds them: bit for bit, -0 as +0 (position_set.hpp). A bitwise
// compare alone would keep -0 and +0 apart here while the engine welds them into one, and an edge
// this pass sees as two could then reach the engine as one edge with three faces.
using PositionKey = lod_detail::PositionSet::Key;
struct PositionHash {
    size_t operator()(const PositionKey& b) const {
        uint64_t h = b[0] * 0x9E3779B97F4A7C15ull;
        h ^= (h >> 29) + b[1] * 0xBF58476D1CE4E5B9ull;
        h ^= (h >> 31) + b[2] * 0x94D049BB133111EBull;
        return size_t(h ^ (h >> 32));
    }
};

struct TripleHash {
    size_t operator()(const std::array<uint32_t, 3>& t) const {
        uint64_t h = t[0] * 0x9E3779B97F4A7C15ull;
        h = (h ^ (h >> 29)) + t[1] * 0xBF58476D1CE4E5B9ull;
        h = (h ^ (h >> 31)) + t[2] * 0x94D049BB133111EBull;
        return size_t(h ^ (h >> 32));
    }
};

uint64_t edge_key(uint32_t a, uint32_t b) {
    return (uint64_t(a) << 32) | b;
}

struct EdgeHash {
    size_t operator()(uint64_t x) const {  // splitmix64's finaliser
        x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
        x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
        return size_t(x ^ (x >> 31));
    }
};

// A hash map with linear probing in one array of keys and one of values, at most half full (its
// capacity set from the most entries it will hold), without erasure; `empty` is a key that never
// occurs. It replaces std::unordered_map here: a million-face mesh put 4 M nodes through the
// allocator, the pass's main cost.
template <class Key, class Value, class Hash>
class FlatMap {
  public:
    FlatMap(size_t most, const Key& empty) : empty_(empty) {
        size_t capacity = 16;
        while (capacity < 2 * most) capacity <<= 1;
        mask_ = capacity - 1;
        keys_.assign(capacity, empty);
        values_.resize(capacity);
    }
    // The value of `key`, inserted as `value` when absent (second: whether it was).
    std::pair<Value*, bool> emplace(const Key& key, const Value& value) {
        for (size_t i = Hash{}(key)&mask_;; i = (i + 1) & mask_) {
            if (same(keys_[i], key)) return {&values_[i], false};
            if (same(keys_[i], empty_)) {
                keys_[i] = key, values_[i] = value;
                return {&values_[i], true};
            }
        }
    }
    const Value* find(const Key& key) const {
        for (size_t i = Hash{}(key)&mask_;; i = (i + 1) & mask_) {
            if (same(keys_[i], key)) return &values_[i];
            if (same(keys_[i], empty_)) return nullptr;
        }
    }

  private:
    // note: element by element; std::array's == became a call to memcmp per probe.
    static bool same(const Key& a, const Key& b) {
        if constexpr (std::is_same_v<Key, std::array<uint32_t, 3>>)
            return a[0] == b[0] && a[1] == b[1] && a[2] == b[2];
        else
            return a == b;
    }
    Key empty_;
    size_t mask_ = 0;
    std::vector<Key> keys_;
    std::vector<Value> values_;
};

template <class T>
std::vector<T> remap(const std::vector<T>& v, const std::vector<uint32_t>& kept) {
    if (v.empty()) return {};
    std::vector<T> out;
    out.reserve(kept.size());
    for (uint32_t i : kept) out.push_back(v[i]);
    return out;
}

}  // namespace

Result<Primitive> repair_primitive(const Primitive& in, std::string_view label,
                                   RepairReport& report) {
    const size_t n = in.positions.size();
    if (n == 0 || in.indices.empty()) return make_error(cat(label, ": empty mesh (no triangles)"));
    if (in.indices.size() % 3 != 0)
        return make_error(
            cat(label, ": ", in.indices.size(), " indices is not a whole number of triangles"));
    auto check_size = [&](size_t size, const char* what) -> Status {
        if (size != 0 && size != n)
            return make_error(cat(label, ": ", size, " ", what, " for ", n, " positions"));
        return {};
    };
    for (auto [size, what] : {std::pair{in.normals.size(), "normals"},
                              {in.uv0.size(), "TEXCOORD_0"},
                              {in.uv1.size(), "TEXCOORD_1"},
                              {in.colors.size(), "colours"},
                              {in.light.size(), "_LIGHT_0 values"}})
        if (Status s = check_size(size, what); !s.ok()) return s.error();
    for (size_t i = 0; i < in.indices.size(); ++i)
        if (in.indices[i] >= n)
            return make_error(cat(label, ": index ", i, " (triangle ", i / 3, ") is ",
                                  in.indices[i], ", out of range (", n, " vertices)"));
    for (size_t v = 0; v < n; ++v) {
        const glm::vec3& p = in.positions[v];
        if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
            return make_error(cat(label, ": vertex ", v, " has a non-finite position (", p.x, ", ",
                                  p.y, ", ", p.z, ")"));
    }

    // Weld bit-identical positions (-0 as +0).
    std::vector<uint32_t> weld(n);
    {
        // note: the empty key's bits are a NaN, and the positions are finite.
        FlatMap<PositionKey, uint32_t, PositionHash> first(n, {~0u, ~0u, ~0u});
        for (size_t v = 0; v < n; ++v)
            weld[v] =
                *first.emplace(lod_detail::PositionSet::key(in.positions[v]), uint32_t(v)).first;
    }

    const size_t faces = in.indices.size() / 3;
    size_t degenerate = 0, duplicate = 0, non_manifold = 0, reoriented = 0;
    std::vector<uint32_t> out_indices;
    out_indices.reserve(in.indices.size());
    // Sorted welded corners of the faces kept so far, and the uses of each directed welded edge
    // (its ends differ, so ~0 is never a key).
    FlatMap<std::array<uint32_t, 3>, char, TripleHash> face_seen(faces, {~0u, ~0u, ~0u});
    FlatMap<uint64_t, uint32_t, EdgeHash> directed(3 * faces, ~0ull);
    auto uses = [&](uint32_t a, uint32_t b) {
        const uint32_t* u = directed.find(edge_key(a, b));
        return u ? *u : 0u;
    };
    for (size_t f = 0; f < faces; ++f) {
        std::array<uint32_t, 3> c = {in.indices[3 * f], in.indices[3 * f + 1],
                                     in.indices[3 * f + 2]};
        std::array<uint32_t, 3> w = {weld[c[0]], weld[c[1]], weld[c[2]]};
        // 1. degenerate
        if (w[0] == w[1] || w[1] == w[2] || w[2] == w[0]) {
            ++degenerate;
            continue;
        }
        const glm::dvec3 a(in.positions[c[0]]), b(in.positions[c[1]]), d(in.positions[c[2]]);
        auto len2 = [](const glm::dvec3& v) { return glm::dot(v, v); };
        const double cross2 = len2(glm::cross(b - a, d - a));
        const double longest2 = std::max({len2(b - a), len2(d - b), len2(a - d)});
        if (cross2 <= 1e-24 * longest2 * longest2) {
            ++degenerate;
            continue;
        }
        // 2. duplicate
        std::array<uint32_t, 3> sorted = w;
        std::sort(sorted.begin(), sorted.end());
        if (!face_seen.emplace(sorted, 1).second) {
            ++duplicate;
            continue;
        }
        // 3. orientation / non-manifold edges
        bool manifold = true, consistent = true, flip_consistent = true;
        for (int e = 0; e < 3; ++e) {
            const uint32_t p = w[e], q = w[(e + 1) % 3];
            const uint32_t fwd = uses(p, q), back = uses(q, p);
            if (fwd + back >= 2) manifold = false;
            if (fwd) consistent = false;
            if (back) flip_consistent = false;
        }
        if (manifold && !consistent && flip_consistent) {
            std::swap(c[1], c[2]);
            std::swap(w[1], w[2]);
            ++reoriented;
        } else if (!manifold || !consistent) {
            ++non_manifold;
            continue;
        }
        for (int e = 0; e < 3; ++e) ++*directed.emplace(edge_key(w[e], w[(e + 1) % 3]), 0).first;
        out_indices.insert(out_indices.end(), c.begin(), c.end());
    }

    if (out_indices.empty())
        return make_error(cat(label, ": no triangle left after dropping ", degenerate,
                              " degenerate and ", non_manifold, " non-manifold faces"));

    // 4. unreferenced vertices
    std::vector<uint32_t> new_id(n, UINT32_MAX), kept;
    kept.reserve(n);
    for (uint32_t i : out_indices) new_id[i] = 0;  // mark the referenced ones
    for (size_t v = 0; v < n; ++v)
        if (new_id[v] != UINT32_MAX) {
            new_id[v] = uint32_t(kept.size());
            kept.push_back(uint32_t(v));
        }
    for (uint32_t& i : out_indices) i = new_id[i];
    const size_t unreferenced = n - kept.size();

    Primitive out;
    out.positions = remap(in.positions, kept);
    out.normals = remap(in.normals, kept);
    out.uv0 = remap(in.uv0, kept);
    out.uv1 = remap(in.uv1, kept);
    out.colors = remap(in.colors, kept);
    out.light = remap(in.light, kept);
    out.indices = std::move(out_indices);
    out.material = in.material;

    auto note = [&](size_t count, size_t& total, const char* what) {
        if (!count) return;
        total += count;
        report.messages.push_back(cat(label, ": ", what, " ", count));
    };
    note(degenerate, report.degenerate_faces,
         "dropped degenerate faces (zero area or repeated corner):");
    note(duplicate, report.duplicate_faces, "dropped duplicate faces:");
    note(non_manifold, report.non_manifold_faces,
         "dropped faces on non-manifold or inconsistently oriented edges:");
    note(reoriented, report.reoriented_faces, "flipped faces to match their neighbours:");
    note(unreferenced, report.unreferenced_vertices, "dropped unreferenced vertices:");
    return out;
}

Status repair_scene(Scene& scene, RepairReport& report) {
    RepairReport local;
    std::vector<std::vector<Primitive>> repaired(scene.meshes.size());
    for (size_t m = 0; m < scene.meshes.size(); ++m) {
        const Mesh& mesh = scene.meshes[m];
        if (mesh.primitives.empty())
            return make_error(cat("mesh ", m, " \"", mesh.name, "\": empty mesh (no primitives)"));
        for (size_t p = 0; p < mesh.primitives.size(); ++p) {
            Result<Primitive> r = repair_primitive(
                mesh.primitives[p], cat("mesh ", m, " \"", mesh.name, "\" primitive ", p), local);
            if (!r.ok()) return r.error();
            repaired[m].push_back(std::move(r).value());
        }
    }
    for (size_t m = 0; m < scene.meshes.size(); ++m)
        scene.meshes[m].primitives = std::move(repaired[m]);
    report.degenerate_faces += local.degenerate_faces;
    report.duplicate_faces += local.duplicate_faces;
    report.non_manifold_faces += local.non_manifold_faces;
    report.reoriented_faces += local.reoriented_faces;
    report.unreferenced_vertices += local.unreferenced_vertices;
    report.messages.insert(report.messages.end(), local.messages.begin(), local.messages.end());
    return {};
}

}  // namespace hmdnode
