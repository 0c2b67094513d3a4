// FASS, "face angle spherical scanning": FAD vertex removal in flat regions, then SS clustering.
//
// Paper: H. Li, S. Kim, "Mesh Simplification Algorithms for Rendering Performance", International
// Journal of Engineering Research and Technology 13(6), 2020, pp. 1110-1119, sec. III.V.II (FASS):
// first every vertex whose face-normal angles are all below the angle threshold is removed (FAD),
// then the remaining vertices are clustered by spherical scanning (SS) with a radius threshold.
//
// Departures from the paper (beyond those of fad.cpp and ss.cpp, whose code this reuses):
// - Targets instead of (angle, radius): the angle threshold stays the paper's kAngleDeg; FAD
//   removes flat vertices in its order while their key is under it and the target is not reached,
//   then SS reaches the target with the radius its search finds. When FAD alone reaches the target,
//   SS does nothing.
//
// Cost: FAD's O(n log n) once per target plus SS's radius search (see ss.cpp); memory O(V + T) for
// a copy of the welded mesh per target.
#include <numbers>

#include "algorithms.hpp"
#include "openmesh_mesh.hpp"

namespace hmdnode::lod_detail {
namespace {

constexpr double kAngleDeg = 30.0;  // "angle < 30 deg", fig. 13 of the paper

}  // namespace

Result<std::vector<SimplifiedLevel>> simplify_fass(const Primitive& in,
                                                   std::span<const size_t> targets,
                                                   const SimplifyOptions& options) {
    const WeldedMesh base = weld_to_openmesh(in, options.locked_positions);
    CollapseRules rules;
    rules.lock_borders = options.lock_borders;
    SimplifyOptions quiet = options;
    quiet.progress = nullptr;
    std::vector<SimplifiedLevel> levels;
    for (size_t i = 0; i < targets.size(); ++i) {
        WeldedMesh m = base;
        const size_t target[1] = {targets[i]};
        std::vector<SimplifiedLevel> fad =
            run_greedy(m, target, fad_hooks(m, rules), quiet, kAngleDeg * std::numbers::pi / 180.0);
        if (m.alive_faces <= targets[i])
            levels.push_back(std::move(fad[0]));
        else
            levels.push_back(ss_to_target(m, targets[i], rules));
        if (options.progress) options.progress(double(i + 1) / double(targets.size()));
    }
    return levels;
}

}  // namespace hmdnode::lod_detail
