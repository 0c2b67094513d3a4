// Attribute transfer from a base mesh to its simplified levels by filtering over the level
// vertex's footprint -- the prefiltering view of LOD appearance (Cohen, Olano and Manocha,
// "Appearance-Preserving Simplification", SIGGRAPH 1998: a coarse level should show the base's
// attributes averaged over the surface it stands for), with a vertex's footprint taken as half
// the mean length of its edges and a tent weight.
//
// Cost: O(B + L * k) for B base vertices, L level vertices and k base vertices per footprint (a
// uniform grid over the base with cells of the median footprint radius); a level vertex with no
// base vertex in its footprint (rare: a footprint holds several base vertices) searches all B.
// carry_vertex_light (what simplify() runs on every level): the same, plus O(B + L) for normals
// made for the filter where the base or the level has none.
#include "hmdnode/lod/attribute_transfer.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <unordered_map>

namespace hmdnode {
namespace {

struct Grid {
    float cell = 1.0f;
    glm::vec3 origin{0.0f};
    std::unordered_map<uint64_t, std::vector<uint32_t>> cells;

    static uint64_t key(int x, int y, int z) {
        auto u = [](int v) { return uint64_t(uint32_t(v) & 0x1fffffu); };
        return u(x) | (u(y) << 21) | (u(z) << 42);
    }
    glm::ivec3 cell_of(const glm::vec3& p) const {
        return glm::ivec3(glm::floor((p - origin) / cell));
    }
};

}  // namespace

Status carry_vertex_light(const Primitive& base, Primitive& level) {
    if (base.light.empty() || level.light.size() == level.positions.size()) return {};
    Result<std::vector<glm::vec3>> light = make_error("");
    if (base.normals.size() == base.positions.size() &&
        level.normals.size() == level.positions.size()) {
        light = transfer_vertex_light(base, level);
    } else {
        Primitive b, l;  // positions, indices and light only, with normals made for the filter
        b.positions = base.positions, b.indices = base.indices, b.light = base.light;
        // note: a vertex of no area gets no normal, so the filter takes the nearest base vertex.
        if (base.normals.size() == base.positions.size())
            b.normals = base.normals;
        else
            compute_vertex_normals(b, glm::vec3(0.0f));
        l.positions = level.positions, l.indices = level.indices;
        if (level.normals.size() == level.positions.size())
            l.normals = level.normals;
        else
            compute_vertex_normals(l, glm::vec3(0.0f));
        light = transfer_vertex_light(b, l);
    }
    if (!light.ok()) return light.error();
    level.light = std::move(light).value();
    return {};
}

Result<std::vector<glm::vec3>> transfer_vertex_light(const Primitive& base,
                                                     const Primitive& level) {
    const size_t nb = base.positions.size(), nl = level.positions.size();
    if (base.light.size() != nb || nb == 0)
        return make_error("attribute transfer: the base mesh has no per-vertex light");
    if (base.normals.size() != nb)
        return make_error("attribute transfer: the base mesh has no normals");
    if (level.normals.size() != nl)
        return make_error("attribute transfer: the level has no normals");
    std::vector<glm::vec3> out(nl, glm::vec3(0.0f));
    if (nl == 0) return out;

    // Base vertex areas: a third of each adjacent triangle's area.
    std::vector<float> area(nb, 0.0f);
    for (size_t t = 0; t + 2 < base.indices.size(); t += 3) {
        const uint32_t a = base.indices[t], b = base.indices[t + 1], c = base.indices[t + 2];
        const float s = 0.5f *
                        glm::length(glm::cross(base.positions[b] - base.positions[a],
                                               base.positions[c] - base.positions[a])) /
                        3.0f;
        area[a] += s;
        area[b] += s;
        area[c] += s;
    }
    // Level footprints: half the mean length of each vertex's edges.
    std::vector<float> edge_sum(nl, 0.0f);
    std::vector<uint32_t> edge_count(nl, 0);
    for (size_t t = 0; t + 2 < level.indices.size(); t += 3)
        for (int e = 0; e < 3; ++e) {
            const uint32_t a = level.indices[t + size_t(e)],
                           b = level.indices[t + size_t((e + 1) % 3)];
            const float len = glm::length(level.positions[a] - level.positions[b]);
            edge_sum[a] += len;
            edge_sum[b] += len;
            edge_count[a] += 1;
            edge_count[b] += 1;
        }
    std::vector<float> radius(nl, 0.0f);
    std::vector<float> sorted;
    for (size_t v = 0; v < nl; ++v)
        if (edge_count[v]) {
            radius[v] = 0.5f * edge_sum[v] / float(edge_count[v]);
            sorted.push_back(radius[v]);
        }
    if (sorted.empty()) {
        sorted.push_back(1e-3f);
    }
    std::nth_element(sorted.begin(), sorted.begin() + ptrdiff_t(sorted.size() / 2), sorted.end());
    Grid grid;
    grid.cell = std::max(sorted[sorted.size() / 2], 1e-6f);
    grid.origin = base.positions[0];
    for (const glm::vec3& p : base.positions) grid.origin = glm::min(grid.origin, p);
    for (uint32_t i = 0; i < nb; ++i) {
        const glm::ivec3 c = grid.cell_of(base.positions[i]);
        grid.cells[Grid::key(c.x, c.y, c.z)].push_back(i);
    }

    for (size_t v = 0; v < nl; ++v) {
        const glm::vec3 p = level.positions[v], n = level.normals[v];
        const float r = radius[v] > 0.0f ? radius[v] : grid.cell;
        const glm::ivec3 lo = grid.cell_of(p - glm::vec3(r)), hi = grid.cell_of(p + glm::vec3(r));
        glm::dvec3 sum(0.0);
        double wsum = 0.0;
        if (int64_t(hi.x - lo.x + 1) * (hi.y - lo.y + 1) * (hi.z - lo.z + 1) <= 4096)
            for (int x = lo.x; x <= hi.x; ++x)
                for (int y = lo.y; y <= hi.y; ++y)
                    for (int z = lo.z; z <= hi.z; ++z) {
                        auto it = grid.cells.find(Grid::key(x, y, z));
                        if (it == grid.cells.end()) continue;
                        for (uint32_t i : it->second) {
                            if (glm::dot(base.normals[i], n) <= 0.0f) continue;
                            const float d = glm::length(base.positions[i] - p);
                            if (d >= r) continue;
                            const double w = double(area[i]) * double(1.0f - d / r);
                            sum += w * glm::dvec3(base.light[i]);
                            wsum += w;
                        }
                    }
        if (wsum > 0.0) {
            out[v] = glm::vec3(sum / wsum);
            continue;
        }
        // No base vertex in the footprint: the nearest one facing the same way (else any).
        float best = std::numeric_limits<float>::max(), best_any = best;
        uint32_t pick = 0, pick_any = 0;
        for (uint32_t i = 0; i < nb; ++i) {
            const float d = glm::length(base.positions[i] - p);
            if (d < best_any) best_any = d, pick_any = i;
            if (d < best && glm::dot(base.normals[i], n) > 0.0f) best = d, pick = i;
        }
        out[v] = base.light[best < std::numeric_limits<float>::max() ? pick : pick_any];
    }
    return out;
}

}  // namespace hmdnode
