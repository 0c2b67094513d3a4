// Distance between two triangle meshes: symmetric Hausdorff, mean and RMS surface distance from
// dense area-weighted surface samples and exact nearest-point queries on a BVH (the Metro method,
// Cignoni, Rocchini & Scopigno 1998). Implementation: lod/src/mesh_distance.cpp.
//
// Thread: any; the measurement itself uses `threads` worker threads and returns when they are done.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

#include <glm/glm.hpp>

#include "hmdnode/core/scene.hpp"

namespace hmdnode {

struct MeshDistanceOptions {
    // Surface samples per direction, spread over the triangles in proportion to their area, at
    // least one per triangle of non-zero area; the vertices are measured too (for the maximum
    // only, weight 0). More samples: the maximum converges from below.
    size_t samples = 300'000;
    // Seed of the stratified jitter, so that runs are reproducible.
    uint32_t seed = 1;
    // Worker threads; 0 = std::thread::hardware_concurrency().
    unsigned threads = 0;
};

// One direction: samples on mesh `from`, distance to the nearest point of the surface `to`.
struct OneSidedDistance {
    double max = 0.0;   // the one-sided Hausdorff distance (of the samples)
    double mean = 0.0;  // area-weighted mean
    double rms = 0.0;   // area-weighted root mean square
    size_t samples = 0;
};

struct MeshDistance {
    OneSidedDistance forward;   // a -> b
    OneSidedDistance backward;  // b -> a
    double hausdorff = 0.0;     // max(forward.max, backward.max)
    double mean = 0.0;          // max(forward.mean, backward.mean)
    double rms = 0.0;           // max(forward.rms, backward.rms)
    double diagonal = 0.0;      // bounding-box diagonal of mesh a (for the % figures)

    // The figures as a percentage of `diagonal` (0 when the diagonal is 0).
    double hausdorff_pct() const { return diagonal > 0 ? 100.0 * hausdorff / diagonal : 0.0; }
    double mean_pct() const { return diagonal > 0 ? 100.0 * mean / diagonal : 0.0; }
    double rms_pct() const { return diagonal > 0 ? 100.0 * rms / diagonal : 0.0; }
};

// A triangle soup view: `indices` has 3 entries per triangle, each < positions.size().
struct TriangleMeshView {
    std::span<const glm::vec3> positions;
    std::span<const uint32_t> indices;
};

inline TriangleMeshView view_of(const Primitive& p) {
    return {p.positions, p.indices};
}

// Measures both directions with `options.samples` samples each. The distances are in the meshes'
// units (both meshes must be in the same space). A mesh without triangles of non-zero area gives
// 0 samples for its direction (its figures stay 0). Requires every index in range.
MeshDistance measure_mesh_distance(TriangleMeshView a, TriangleMeshView b,
                                   const MeshDistanceOptions& options = {});

// Convenience: the same on primitives (positions and indices only).
inline MeshDistance measure_mesh_distance(const Primitive& a, const Primitive& b,
                                          const MeshDistanceOptions& options = {}) {
    return measure_mesh_distance(view_of(a), view_of(b), options);
}

// Bounding-box diagonal of the referenced positions of a mesh (0 when empty).
double bounding_box_diagonal(TriangleMeshView mesh);

}  // namespace hmdnode
