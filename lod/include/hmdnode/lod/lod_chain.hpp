// LOD chains for a whole scene: every mesh simplified with one of simplify()'s algorithms, each
// level's error measured (symmetric Hausdorff distance to level 0, mesh_distance.hpp) and the
// levels stored as MSFT_lod alternates of the mesh's nodes, ready for save_glb and the runtime
// selector. Implementation: lod/src/simplify/lod_chain.cpp; the tool is `hmdnode lod`
// (docs/lod-generation.md).
//
// Thread: any; runs on the calling thread except the distance measurement (workers only when
// options.distance.threads asks for them) and what simplify() runs on a helper thread where
// options.simplify.threads asks for one (simplify.hpp). Memory: one SimplifyScratch for all the
// simplify() calls of a run unless options.simplify.scratch names the caller's, freed at the end.
#pragma once

#include <cstddef>
#include <functional>
#include <string>
#include <vector>

#include "hmdnode/core/result.hpp"
#include "hmdnode/core/scene.hpp"
#include "hmdnode/lod/mesh_distance.hpp"
#include "hmdnode/lod/progressive_mesh.hpp"
#include "hmdnode/lod/simplify.hpp"

namespace hmdnode {

// What levels to make, per mesh. Exactly one of ratios, triangles, max_error_m, max_error_pct
// (and optionally step with ratios or triangles, or alone).
struct LodTargets {
    // Fractions of level 0's triangle count, strictly decreasing, each in (0, 1).
    std::vector<double> ratios;
    // Triangle counts, strictly decreasing; counts not below a mesh's own count are skipped for
    // that mesh (said in the report).
    std::vector<size_t> triangles;
    // One level: the coarsest whose measured Hausdorff error is at most this, in metres of the
    // mesh's space (or in % of its bounding-box diagonal). Found by bisection on the triangle
    // count; the error need not be monotonic in the count, so it is the coarsest level found.
    // The level found is measured again with LodChainOptions::distance (the figure reported) and,
    // while that is above the bound, replaced by one with more triangles: the level written
    // always holds the bound with its reported error.
    double max_error_m = -1.0;
    double max_error_pct = -1.0;
    // A level every `step` triangles (T - step, T - 2 step, ...) down to the smallest target of
    // ratios/triangles, or down to one triangle without them. Edge-collapse algorithms only.
    size_t step = 0;
};

struct LodChainOptions {
    std::string algorithm = "qem";
    LodTargets targets;
    SimplifyOptions simplify;  // lock_borders, seed (its progress is replaced)
    MeshDistanceOptions distance;
    // Samples per direction while bisecting for max_error (the final level gets `distance`).
    size_t search_samples = 50'000;
    // MSFT_screencoverage of level k: the screen-height fraction below which level k+1's error
    // projects under this fraction of the screen: min(1, diameter * tolerance / error_{k+1}).
    double screen_tolerance = 1e-3;
    // At most this many levels per mesh (guards --step).
    size_t max_levels = 256;
    // Also the progressive mesh of every simplified primitive (LodChainReport::progressive), taken
    // from the simplify() run that made its levels (no second run). Edge-collapse algorithms only.
    bool progressive = false;
    // Overall fraction done, 0..1, on the calling thread.
    std::function<void(double)> progress;
};

struct LodLevelReport {
    int mesh = -1;  // index in the output scene
    std::string mesh_name;
    int level = 0;  // 0 = the original
    size_t triangles = 0;
    size_t target = 0;           // the requested triangle count (0 for level 0)
    double hausdorff_m = 0.0;    // symmetric, to level 0, mesh space
    double hausdorff_pct = 0.0;  // % of level 0's bounding-box diagonal
    double mean_m = 0.0;         // max of the two one-sided mean distances
    double mean_pct = 0.0;
    // The sampling error (mesh_distance.hpp): the true Hausdorff distance lies in
    // [hausdorff_m, hausdorff_upper_m]; the mean's standard error.
    double hausdorff_upper_m = 0.0;
    double hausdorff_upper_pct = 0.0;
    double mean_stderr_m = 0.0;
    double mean_stderr_pct = 0.0;
    double estimated_error = -1.0;  // the algorithm's own estimate, when it has one
    double simplify_ms = 0.0;       // the simplify() call that made it (one call, all levels,
                                    // for edge-collapse algorithms)
    double measure_ms = 0.0;
    double measure_cpu_ms = 0.0;  // the calling thread's CPU time of it (the machine may be shared)
};

// The progressive mesh of one primitive of a mesh given a chain, based at the primitive's part of
// the mesh's last (smallest) level: refine() gives back each level's primitive exactly.
struct PrimitiveProgressiveMesh {
    int mesh = -1;  // index in the input scene
    std::string mesh_name;
    size_t primitive = 0;
    size_t primitives = 0;  // the mesh's primitive count
    ProgressiveMesh pm;
};

struct LodChainReport {
    std::vector<LodLevelReport> levels;  // per mesh, level 0 first
    std::vector<std::string> notes;      // skipped targets, unreachable errors, ...
    size_t meshes = 0;                   // meshes given chains
    size_t nodes = 0;                    // nodes given chains
    // With LodChainOptions::progressive: per mesh in the order of `levels`, its primitives in
    // order; a mesh without a level or a primitive left as it is has none (said in `notes`).
    std::vector<PrimitiveProgressiveMesh> progressive;
};

// For every node with a mesh that is not itself an MSFT_lod alternate: replaces any chain it has
// with a new one. Each distinct mesh is simplified once (all primitives, each to its share of the
// target, with the positions primitives share locked so that material boundaries stay closed); the
// new levels are new meshes "<name>_lod<k>" on new non-root nodes with the node's transform, listed
// in the node's lod_ids with screen_coverage, each level's node carrying its measured Hausdorff
// error in geometric_error_m (level 0 gets 0). A level with no fewer triangles than the level
// before it is dropped (with a note); a primitive an algorithm leaves without a triangle keeps its
// previous level (with a note naming mesh and primitive). Every level has the vertex attributes
// its input has, _LIGHT_0 included (simplify.hpp). Old alternate nodes and meshes no node uses any
// more are removed (node and mesh indices are renumbered). On an error the scene is unchanged.
// Errors: unknown algorithm, bad targets, --step or progressive with a non-edge-collapse algorithm,
// a simplify() failure (naming the mesh and primitive).
Result<LodChainReport> generate_lod_chains(Scene& scene, const LodChainOptions& options);

// The positions (bit for bit, +0 == -0) that more than one primitive of `mesh` uses: its material
// boundaries. generate_lod_chains locks them (SimplifyOptions::locked_positions).
std::vector<glm::vec3> material_boundary_positions(const Mesh& mesh);

// The targets primitive `primitive` of `mesh` is simplified to for the mesh-wide `targets`
// (strictly decreasing): its share of each, in proportion to its triangle count, at least 1, kept
// while below its count and its previous share. which[k] (when given) is the index in the result
// of the level that serves targets[k], or -1 where the primitive stays as it is.
// generate_lod_chains simplifies each primitive so.
std::vector<size_t> primitive_targets(const Mesh& mesh, size_t primitive,
                                      const std::vector<size_t>& targets,
                                      std::vector<int>* which = nullptr);

// Checks `targets` (one kind given, ranges, strictly decreasing): empty message when fine.
std::string check_lod_targets(const LodTargets& targets);

}  // namespace hmdnode
