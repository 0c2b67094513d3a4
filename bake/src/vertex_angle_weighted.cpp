// Per-vertex irradiance as I. Zs. Lazányi, "... virtual worlds for virtual reality applications",
// Central European Seminar on Computer Graphics (CESCG) 2003, Budapest University of Technology and
// Economics (the first words of the title are missing from our copy; docs/references.md), section
// 3.2, does it ("the color of each vertex was composed by using the color of the adjacent patches;
// each patch color was weighted with the angle belonging to the patch at the examined vertex"):
// every face is a patch whose value is the mean of the oracle at its n^2 sub-triangle centroids,
// and a vertex takes the corner-angle-weighted average of its incident faces. The same corner-angle
// weights as G. Thürmer, C. A. Wüthrich, "Computing vertex normals from polygonal facets", Journal
// of Graphics Tools 3(1), 1998, use for vertex normals.
//
// Cost: O(F n^2) oracle calls, O(V + F) memory.
// Departures: the paper's patches came from RenderX's tessellation; here the "patches" are the
// primitive's own faces (split them first with split_long_edges for finer patches). Weights are
// per vertex index, so vertices split at seams average only the faces that reference them.
#include <algorithm>
#include <cassert>
#include <cmath>

#include "hmdnode/bake/vertex_bake.hpp"
#include "vertex_sampling.hpp"

namespace hmdnode {

Result<std::vector<glm::vec3>> vertex_irradiance_angle_weighted(const Primitive& prim,
                                                                const glm::dmat4& world,
                                                                const IrradianceOracle& oracle,
                                                                int subdivisions) {
    using namespace vertex_detail;
    if (subdivisions < 1 || subdivisions > 64)
        return make_error("vertex bake: subdivisions must be in [1, 64]");
    auto placed = place(prim, world);
    if (!placed.ok()) return placed.error();
    const WorldPrimitive& w = *placed;
    const size_t nv = prim.positions.size();
    std::vector<glm::dvec3> sum(nv, glm::dvec3(0.0));
    std::vector<double> weight(nv, 0.0);
    std::vector<Sample> samples;
    for (size_t f = 0; f < prim.triangle_count(); ++f) {
        sample_triangle(w, prim, f, subdivisions, samples);
        glm::dvec3 face(0.0);
        for (const Sample& s : samples) face += eval(oracle, s);
        assert(!samples.empty());
        face /= double(samples.size());
        for (int k = 0; k < 3; ++k) {
            const uint32_t v = prim.indices[3 * f + size_t(k)];
            assert(v < nv);
            const glm::dvec3 a = w.p[prim.indices[3 * f + size_t((k + 1) % 3)]] - w.p[v];
            const glm::dvec3 b = w.p[prim.indices[3 * f + size_t((k + 2) % 3)]] - w.p[v];
            const double la = glm::length(a), lb = glm::length(b);
            if (!(la > 0.0) || !(lb > 0.0)) continue;
            const double angle = std::acos(std::clamp(glm::dot(a, b) / (la * lb), -1.0, 1.0));
            sum[v] += angle * face;
            weight[v] += angle;
        }
    }
    std::vector<glm::vec3> out(nv);
    for (size_t v = 0; v < nv; ++v)
        out[v] = glm::vec3(weight[v] > 0.0 ? sum[v] / weight[v] : at_vertex(w, oracle, v));
    return out;
}

}  // namespace hmdnode
