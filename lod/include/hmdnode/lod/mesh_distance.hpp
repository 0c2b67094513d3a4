// Distance between two triangle meshes: symmetric Hausdorff (a lower and an upper bound), mean and
// RMS surface distance (with the mean's standard error) from area-weighted surface samples, exact
// nearest-point queries on a BVH (the Metro method, Cignoni, Rocchini & Scopigno 1998) and a
// best-first refinement that bounds the Hausdorff distance from above (distance to a surface is
// 1-Lipschitz), with a query only for the vertices that could hold the maximum. Implementation:
// lod/src/simplify/mesh_distance.cpp; the bounds: docs/lod-generation.md.
//
// Thread: any; the measurement uses `threads` threads (default one: the caller's) and returns when
// they are done.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>

#include <glm/glm.hpp>

#include "hmdnode/core/scene.hpp"

namespace hmdnode {

struct MeshDistanceOptions {
    // Area samples per direction, spread over the sampled mesh's triangles in proportion to their
    // area (a triangle smaller than total_area / samples may get none); 0 = an eighth of the
    // sampled mesh's triangle count, at least 1024. Every vertex is bounded too, and queried
    // where its bound could hold the maximum (so the maximum over the vertices is exact).
    size_t samples = 0;
    // Extra points per direction measured to tighten the Hausdorff bracket (best-first
    // subdivision of the triangles whose upper bound is largest; each point a local walk, and a
    // nearest-point query where the walk could not settle it); 0 = max(768, T / 16), T the larger
    // triangle count of the two meshes.
    size_t refine_queries = 0;
    // Seed of the stratified jitter, so that runs are reproducible.
    uint32_t seed = 1;
    // Bound every triangle (and refined piece) whose corners lie nearest to different triangles
    // by the prism bound (mesh_distance.cpp, prism_bound()): the distance along its normal to the
    // triangles of the other mesh over it. The upper bound then closes on the sampled maximum on
    // smooth meshes (the bunny at 50 %: 0.0403..0.0403 % of the diagonal against 0.0316..0.7850 %
    // without), at 1.6 to 3.7 times the measurement's time; creases and open borders across a
    // triangle leave it the default bounds (docs/lod-generation.md, "Error metric").
    bool prism_bounds = false;
    // Threads: with 2 or more the two directions run at once (each with the same figures as
    // alone), each direction's sample queries on half of them (the vertex bounds and the
    // refinement on its own thread); 0 = std::thread::hardware_concurrency(). 1 and 2 give the
    // same figures bit for bit; 3 or more can move the upper bound in its last digits
    // (ties between nearest triangles resolved by the query order).
    unsigned threads = 1;
};

// One direction: samples on mesh `from`, distance to the nearest point of the surface `to`.
struct OneSidedDistance {
    double max = 0.0;  // the largest sampled distance: a lower bound of the one-sided Hausdorff
    double max_upper =
        0.0;            // an upper bound of the one-sided Hausdorff distance (exact, Lipschitz)
    double mean = 0.0;  // area-weighted mean of the samples
    double mean_stderr = 0.0;  // the mean's standard error, as for independent samples
    double rms = 0.0;          // area-weighted root mean square
    size_t samples = 0;        // area samples (the vertices and refinement queries not counted)
    size_t queries = 0;        // every nearest-point query made, vertices and refinement included
};

struct MeshDistance {
    OneSidedDistance forward;      // a -> b
    OneSidedDistance backward;     // b -> a
    double hausdorff = 0.0;        // max(forward.max, backward.max): at most the true one
    double hausdorff_upper = 0.0;  // max(forward.max_upper, backward.max_upper): at least it
    double mean = 0.0;             // max(forward.mean, backward.mean)
    double mean_stderr = 0.0;      // the standard error of the side `mean` comes from
    double rms = 0.0;              // max(forward.rms, backward.rms)
    double diagonal = 0.0;         // bounding-box diagonal of mesh a (for the % figures)
    double cpu_ms = 0.0;  // CPU time of measure() on every thread it used (the caller's included)

    // The figures as a percentage of `diagonal` (0 when the diagonal is 0).
    double pct(double v) const { return diagonal > 0 ? 100.0 * v / diagonal : 0.0; }
    double hausdorff_pct() const { return pct(hausdorff); }
    double hausdorff_upper_pct() const { return pct(hausdorff_upper); }
    double mean_pct() const { return pct(mean); }
    double mean_stderr_pct() const { return pct(mean_stderr); }
    double rms_pct() const { return pct(rms); }
};

// A triangle soup view: `indices` has 3 entries per triangle, each < positions.size().
struct TriangleMeshView {
    std::span<const glm::vec3> positions;
    std::span<const uint32_t> indices;
};

inline TriangleMeshView view_of(const Primitive& p) {
    return {p.positions, p.indices};
}

// A reference mesh prepared once (a copy, its BVH and its samples) and measured against any
// number of meshes: what a LOD chain needs, level 0 against each level.
class MeshDistanceReference {
  public:
    MeshDistanceReference(TriangleMeshView a, const MeshDistanceOptions& options = {});
    ~MeshDistanceReference();
    MeshDistanceReference(MeshDistanceReference&&) noexcept;
    MeshDistanceReference& operator=(MeshDistanceReference&&) noexcept;

    // The reference (a) against b, both directions; the same figures as measure_mesh_distance.
    MeshDistance measure(TriangleMeshView b) const;

  private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

// Measures both directions. The distances are in the meshes' units (both meshes must be in the
// same space). A mesh without triangles of non-zero area gives 0 samples for its direction (its
// figures stay 0). Requires every index in range.
MeshDistance measure_mesh_distance(TriangleMeshView a, TriangleMeshView b,
                                   const MeshDistanceOptions& options = {});

// Convenience: the same on primitives (positions and indices only).
inline MeshDistance measure_mesh_distance(const Primitive& a, const Primitive& b,
                                          const MeshDistanceOptions& options = {}) {
    return measure_mesh_distance(view_of(a), view_of(b), options);
}

// Bounding-box diagonal of the referenced positions of a mesh (0 when empty).
double bounding_box_diagonal(TriangleMeshView mesh);

// The covering radius of a triangle by its corners: the largest distance from a point of the
// triangle to its nearest corner (the circumradius when no angle is obtuse). 0 for a point.
double corner_covering_radius(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c);

}  // namespace hmdnode
