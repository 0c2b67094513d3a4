// "grid": uniform-grid vertex clustering behind simplify().
//
// Paper: J. Rossignac, P. Borrel, "Multi-resolution 3D approximations for rendering complex
// scenes", Modeling in Computer Graphics, Springer 1993; the method: see vertex_clustering.cpp.
// This entry only reaches each target with cluster_to_triangle_count (bisection on the cell size,
// closest non-empty count kept), one independent clustering per target, and reports the largest
// vertex displacement as the estimated error. Departure: the grid ignores connectivity, so closed
// input may come back non-manifold or with holes closed, and UV seams are not kept (the
// representative's UVs are used); lock_borders and locked_positions are ignored. Clustering can
// leave the same three corners twice with opposite orientations (a pinched sheet); the second of
// such a pair is dropped here so that no face repeats.
//
// Cost: O((V + T) log(1/eps)) per target (24 bisection steps at most); memory O(V + T).
#include <algorithm>
#include <array>
#include <set>

#include "algorithms.hpp"
#include "hmdnode/lod/vertex_clustering.hpp"

namespace hmdnode::lod_detail {
namespace {

void drop_repeated_faces(Primitive& p) {
    std::set<std::array<uint32_t, 3>> seen;
    size_t kept = 0;
    for (size_t t = 0; t + 2 < p.indices.size(); t += 3) {
        std::array<uint32_t, 3> key = {p.indices[t], p.indices[t + 1], p.indices[t + 2]};
        std::sort(key.begin(), key.end());
        if (!seen.insert(key).second) continue;
        for (int k = 0; k < 3; ++k) p.indices[kept++] = p.indices[t + k];
    }
    p.indices.resize(kept);
}

}  // namespace

Result<std::vector<SimplifiedLevel>> simplify_grid(const Primitive& in,
                                                   std::span<const size_t> targets,
                                                   const SimplifyOptions& options) {
    std::vector<SimplifiedLevel> levels;
    for (size_t i = 0; i < targets.size(); ++i) {
        ClusteredLevel c = cluster_to_triangle_count(in, targets[i]);
        drop_repeated_faces(c.primitive);
        levels.push_back({std::move(c.primitive), double(c.max_displacement_m)});
        if (options.progress) options.progress(double(i + 1) / double(targets.size()));
    }
    return levels;
}

}  // namespace hmdnode::lod_detail
