// Progressive meshes: recording (build_progressive_mesh, through the collapse engine) and
// refinement (refine, rebase_progressive_mesh). The .hmpm file: progressive_mesh_file.cpp.
//
// Paper: H. Hoppe, "Progressive meshes", SIGGRAPH 1996: a mesh is stored as a coarse base mesh
// M0 and the sequence of vertex splits vsplit_0 .. vsplit_{n-1} that undo, in reverse order, the
// edge collapses that simplified it; applying a prefix gives every intermediate mesh.
//
// Departures: Hoppe's vsplit names a vertex, two neighbours (the faces to open) and the new
// attributes, and rebuilds the faces from the connectivity. Ours lists the faces it brings back
// and the corners that go back to the split vertex explicitly (wedge ids), which costs a few more
// bytes per split but needs no connectivity at load time and reproduces the engine's snapshots
// bit for bit, seams and all. The collapse may have moved the kept vertex (QEM's optimal point):
// the split restores its position and the attributes of its wedges. Out of this file's scope:
// Hoppe's geomorphs and view-dependent selective refinement (the reader refines the whole mesh
// to a triangle count).
//
// Cost: the engine's (collapse_engine.cpp) plus O(total record size).
#include "hmdnode/lod/progressive_mesh.hpp"

#include <cmath>
#include <cstring>
#include <string>

#include "collapse_engine.hpp"
#include "scratch.hpp"

namespace hmdnode {

Result<ProgressiveMeshBuild> build_progressive_mesh(const Primitive& in, std::string_view algorithm,
                                                    std::span<const size_t> target_triangles,
                                                    const SimplifyOptions& options) {
    if (Status s = lod_detail::check_simplify_arguments(in, algorithm, target_triangles); !s) {
        return s.error();
    }
    const lod_detail::ScratchScope scope(options.scratch);
    std::unique_ptr<lod_detail::CollapseCost> cost = lod_detail::make_collapse_cost(algorithm);
    if (!cost) {
        return make_error("algorithm '" + std::string(algorithm) +
                          "' is not an edge collapse: no progressive mesh");
    }
    ProgressiveMeshBuild build;
    Result<std::vector<SimplifiedLevel>> levels =
        lod_detail::run_edge_collapse(in, target_triangles, options, *cost, &build.mesh);
    if (!levels) return levels.error();
    build.levels = std::move(levels).value();
    if (Status s = lod_detail::carry_light_to_levels(in, build.levels); !s) return s.error();
    return build;
}

}  // namespace hmdnode
