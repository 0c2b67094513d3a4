// Uniform-grid vertex clustering.
//
// Paper: J. Rossignac, P. Borrel, "Multi-resolution 3D approximations for rendering complex
// scenes", Modeling in Computer Graphics, Springer 1993, pp. 455-465.
//
// Method: overlay a grid of cubic cells, merge all vertices of a cell into one representative,
// re-index the triangles and drop those that collapsed (two or three corners in one cell). The
// paper weights vertices by importance (edge length, curvature) to pick the representative; we
// take the input vertex nearest the unweighted mean, which keeps the result on the input surface.
// Topology is not preserved (holes close, thin parts merge) and the error is bounded by the cell
// size, not controlled per region: good enough for distant levels, a baseline for QEM/Melax.
//
// Cost: O(V + T) expected time (hash maps on cell and triangle keys); temporary memory
// O(V + T): one cluster id per vertex, per-cluster sums, a set of kept triangles.
#include "hmdnode/lod/vertex_clustering.hpp"

#include <array>
#include <cassert>
#include <cmath>
#include <cstdint>
#include <limits>
#include <unordered_map>
#include <unordered_set>
#include <vector>

namespace hmdnode {
namespace {

struct CellKey {
    int64_t x, y, z;
    bool operator==(const CellKey&) const = default;
};
struct CellHash {
    size_t operator()(const CellKey& k) const {
        uint64_t h = uint64_t(k.x) * 0x9E3779B97F4A7C15ull;
        h ^= uint64_t(k.y) * 0xC2B2AE3D27D4EB4Full + (h << 6) + (h >> 2);
        h ^= uint64_t(k.z) * 0x165667B19E3779F9ull + (h << 6) + (h >> 2);
        return size_t(h ^ (h >> 29));
    }
};

using Tri = std::array<uint32_t, 3>;
struct TriHash {
    size_t operator()(const Tri& t) const {
        uint64_t h = uint64_t(t[0]) * 0x9E3779B97F4A7C15ull;
        h ^= uint64_t(t[1]) * 0xC2B2AE3D27D4EB4Full + (h << 6) + (h >> 2);
        h ^= uint64_t(t[2]) * 0x165667B19E3779F9ull + (h << 6) + (h >> 2);
        return size_t(h ^ (h >> 29));
    }
};

// Same cyclic order (so the same orientation), smallest id first.
Tri canonical(uint32_t a, uint32_t b, uint32_t c) {
    if (b < a && b < c) return {b, c, a};
    if (c < a && c < b) return {c, a, b};
    return {a, b, c};
}

}  // namespace

Primitive cluster_vertices(const Primitive& in, float cell_size, float* out_max_displacement_m) {
    assert(cell_size > 0.0f);
    const size_t n = in.positions.size();
    Primitive out;
    out.material = in.material;
    if (out_max_displacement_m) *out_max_displacement_m = 0.0f;
    if (n == 0) return out;

    glm::vec3 lo(std::numeric_limits<float>::max());
    for (const glm::vec3& p : in.positions) lo = glm::min(lo, p);

    // 1. Vertex -> cluster.
    std::unordered_map<CellKey, uint32_t, CellHash> cluster_of_cell;
    cluster_of_cell.reserve(n);
    std::vector<uint32_t> cluster(n);
    std::vector<glm::dvec3> sum;
    std::vector<uint32_t> count;
    for (size_t i = 0; i < n; ++i) {
        glm::vec3 g = glm::floor((in.positions[i] - lo) / cell_size);
        CellKey key{int64_t(g.x), int64_t(g.y), int64_t(g.z)};
        auto [it, inserted] = cluster_of_cell.try_emplace(key, uint32_t(sum.size()));
        if (inserted) {
            sum.emplace_back(0.0);
            count.push_back(0);
        }
        cluster[i] = it->second;
        sum[it->second] += glm::dvec3(in.positions[i]);
        ++count[it->second];
    }
    const size_t clusters = sum.size();

    // 2. Representative: the member nearest the mean (ties: lowest index).
    std::vector<uint32_t> rep(clusters, UINT32_MAX);
    std::vector<double> rep_d2(clusters, std::numeric_limits<double>::max());
    for (size_t i = 0; i < n; ++i) {
        uint32_t c = cluster[i];
        glm::dvec3 d = glm::dvec3(in.positions[i]) - sum[c] / double(count[c]);
        double d2 = glm::dot(d, d);
        if (d2 < rep_d2[c]) {
            rep_d2[c] = d2;
            rep[c] = uint32_t(i);
        }
    }
    float max_disp = 0.0f;
    for (size_t i = 0; i < n; ++i)
        max_disp =
            std::max(max_disp, glm::distance(in.positions[i], in.positions[rep[cluster[i]]]));
    if (out_max_displacement_m) *out_max_displacement_m = max_disp;

    // 3. Triangles on clusters: drop collapsed, zero-area and repeated ones.
    std::unordered_set<Tri, TriHash> seen;
    seen.reserve(in.indices.size() / 3);
    std::vector<uint32_t> out_index(clusters, UINT32_MAX);
    std::vector<uint32_t> emitted;  // output vertex -> cluster
    for (size_t t = 0; t + 2 < in.indices.size(); t += 3) {
        assert(in.indices[t] < n && in.indices[t + 1] < n && in.indices[t + 2] < n);
        uint32_t a = cluster[in.indices[t]], b = cluster[in.indices[t + 1]],
                 c = cluster[in.indices[t + 2]];
        if (a == b || b == c || a == c) continue;
        const glm::vec3& pa = in.positions[rep[a]];
        glm::vec3 e1 = in.positions[rep[b]] - pa, e2 = in.positions[rep[c]] - pa;
        // note: scale-free sliver test, |e1 x e2| = |e1| |e2| sin(angle).
        if (!(glm::length(glm::cross(e1, e2)) > 1e-6f * glm::length(e1) * glm::length(e2)))
            continue;
        if (!seen.insert(canonical(a, b, c)).second) continue;
        for (uint32_t k : {a, b, c}) {
            if (out_index[k] == UINT32_MAX) {
                out_index[k] = uint32_t(emitted.size());
                emitted.push_back(k);
            }
            out.indices.push_back(out_index[k]);
        }
    }

    // 4. Vertex attributes.
    const size_t m = emitted.size();
    out.positions.resize(m);
    for (size_t j = 0; j < m; ++j) out.positions[j] = in.positions[rep[emitted[j]]];
    if (!in.uv0.empty()) {
        out.uv0.resize(m);
        for (size_t j = 0; j < m; ++j) out.uv0[j] = in.uv0[rep[emitted[j]]];
    }
    if (!in.uv1.empty()) {
        out.uv1.resize(m);
        for (size_t j = 0; j < m; ++j) out.uv1[j] = in.uv1[rep[emitted[j]]];
    }
    // The mean over each cluster, summed in `Acc` (colours in float, light in double as before).
    auto cluster_mean = [&]<typename Acc, typename T>(const std::vector<T>& values,
                                                      std::vector<T>& mean) {
        if (values.empty()) return;
        std::vector<Acc> acc(clusters, Acc(0));
        for (size_t i = 0; i < n; ++i) acc[cluster[i]] += Acc(values[i]);
        mean.resize(m);
        for (size_t j = 0; j < m; ++j)
            mean[j] = T(acc[emitted[j]] / typename Acc::value_type(count[emitted[j]]));
    };
    cluster_mean.operator()<glm::vec4>(in.colors, out.colors);
    cluster_mean.operator()<glm::dvec3>(in.light, out.light);
    if (!in.normals.empty()) {
        out.normals.assign(m, glm::vec3(0.0f));
        for (size_t t = 0; t < out.indices.size(); t += 3) {
            const glm::vec3& a = out.positions[out.indices[t]];
            glm::vec3 fn = glm::cross(out.positions[out.indices[t + 1]] - a,
                                      out.positions[out.indices[t + 2]] - a);
            for (int k = 0; k < 3; ++k) out.normals[out.indices[t + k]] += fn;
        }
        std::vector<glm::vec3> avg;  // fallback, built only when needed
        for (size_t j = 0; j < m; ++j) {
            float len = glm::length(out.normals[j]);
            if (len > 0.0f) {
                out.normals[j] /= len;
                continue;
            }
            if (avg.empty()) {
                avg.assign(clusters, glm::vec3(0.0f));
                for (size_t i = 0; i < n; ++i) avg[cluster[i]] += in.normals[i];
            }
            glm::vec3 a = avg[emitted[j]];
            float al = glm::length(a);
            out.normals[j] = al > 0.0f ? a / al : glm::vec3(0.0f, 1.0f, 0.0f);
        }
    }
    return out;
}

ClusteredLevel cluster_to_triangle_count(const Primitive& in, size_t target_triangles,
                                         int iterations) {
    assert(target_triangles > 0);
    glm::vec3 lo(std::numeric_limits<float>::max()), hi(-std::numeric_limits<float>::max());
    for (const glm::vec3& p : in.positions) {
        lo = glm::min(lo, p);
        hi = glm::max(hi, p);
    }
    ClusteredLevel best;
    if (in.positions.empty()) return best;
    double diag = std::max(double(glm::length(hi - lo)), 1e-12);

    double log_lo = std::log(diag * 1e-4), log_hi = std::log(diag);
    size_t best_gap = std::numeric_limits<size_t>::max();
    for (int it = 0; it < iterations; ++it) {
        double log_mid = 0.5 * (log_lo + log_hi);
        float cell = float(std::exp(log_mid));
        float disp = 0.0f;
        Primitive p = cluster_vertices(in, cell, &disp);
        size_t tris = p.triangle_count();
        size_t gap = tris > target_triangles ? tris - target_triangles : target_triangles - tris;
        // note: an empty result never wins over a non-empty one, however close its count: for a
        // target of a few triangles on a small object, 0 triangles was nearer than the 4 or 12 of
        // the coarsest grid that keeps any, and the object vanished from the level.
        const bool better = best.primitive.indices.empty() ? (tris > 0 || gap < best_gap)
                                                           : (tris > 0 && gap < best_gap);
        if (better) {
            best_gap = gap;
            best.primitive = std::move(p);
            best.cell_size = cell;
            best.max_displacement_m = disp;
        }
        if (gap * 200 <= target_triangles) break;  // within 0.5 %
        if (tris > target_triangles)
            log_lo = log_mid;
        else
            log_hi = log_mid;
    }
    // Every grid tried collapsed the object (cells of 1e-4 diagonals still merge its vertices, or
    // the iterations ran out before a non-empty grid): the input itself, the finest valid mesh.
    if (best.primitive.indices.empty()) {
        best.primitive = in;
        best.cell_size = 0.0f;
        best.max_displacement_m = 0.0f;
    }
    return best;
}

}  // namespace hmdnode
