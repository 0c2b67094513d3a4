// A bounding volume hierarchy over world-space triangles for the direct-light baker's shadow rays
// (direct_bake.hpp); the path tracer traces through Embree instead.
//
// Threads: build on one thread; a built TriangleBvh is immutable, its queries may run on any
// number of threads at once.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

namespace hmdnode {

struct RayHit {
    float t = 0.0f;            // distance along the (unit or not) direction, in direction lengths
    uint32_t triangle = 0;     // index into the corners given to the constructor, 3 per triangle
    float u = 0.0f, v = 0.0f;  // barycentrics of corners 1 and 2
};

class TriangleBvh {
  public:
    TriangleBvh() = default;
    // corners: 3 per triangle. Degenerate triangles are kept (they are never hit).
    explicit TriangleBvh(std::vector<glm::vec3> corners);

    // True when some triangle (either side) is hit at t_min < t < t_max along origin + t * dir.
    bool occluded(const glm::vec3& origin, const glm::vec3& dir, float t_min, float t_max) const;
    // The nearest hit in (t_min, t_max), either side; false when none.
    bool intersect(const glm::vec3& origin, const glm::vec3& dir, float t_min, float t_max,
                   RayHit* out_hit) const;

    size_t triangle_count() const { return corners_.size() / 3; }
    size_t node_count() const { return nodes_.size(); }

  private:
    struct Node {
        glm::vec3 lo, hi;
        uint32_t first = 0;  // leaf: first entry of order_; inner: index of the left child
        uint32_t count = 0;  // leaf: triangles; inner: 0 (right child = first + 1)
    };
    template <bool AnyHit>
    bool traverse(const glm::vec3& origin, const glm::vec3& dir, float t_min, float t_max,
                  RayHit* out_hit) const;

    std::vector<glm::vec3> corners_;  // reordered so that leaves hold contiguous triangles
    std::vector<uint32_t> original_;  // triangle index in the constructor's order
    std::vector<Node> nodes_;
};

}  // namespace hmdnode
