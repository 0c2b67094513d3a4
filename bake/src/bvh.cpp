// Triangle BVH: top-down build splitting each node at the median centroid along the longest axis
// of the centroid bounds (nth_element), leaves of at most 4 triangles; stack traversal nearest
// child first with slab tests; Moller & Trumbore ray-triangle test ("Fast, minimum storage
// ray/triangle intersection", JGT 1997), both sides, with a 1e-5 barycentric tolerance.
//
// Cost: build O(T log T) time, memory 2T nodes (32 bytes each) + the reordered corners;
// queries O(log T) expected for well-spread triangles, no allocation.
#include "hmdnode/bake/bvh.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>
#include <numeric>

namespace hmdnode {
namespace {

constexpr uint32_t kLeafSize = 4;
constexpr int kStackSize = 64;
constexpr float kBaryEps = 1e-5f;

// Slab test; returns the entry distance or +inf when missed.
inline float hit_box(const glm::vec3& lo, const glm::vec3& hi, const glm::vec3& origin,
                     const glm::vec3& inv_dir, float t_min, float t_max) {
    glm::vec3 t0 = (lo - origin) * inv_dir;
    glm::vec3 t1 = (hi - origin) * inv_dir;
    glm::vec3 tn = glm::min(t0, t1), tf = glm::max(t0, t1);
    // note: NaN from 0 * inf (origin on a slab plane, axis-parallel ray) is dropped by std::max/min
    // argument order: the running bound comes first.
    float enter = std::max(std::max(std::max(t_min, tn.x), tn.y), tn.z);
    float exit = std::min(std::min(std::min(t_max, tf.x), tf.y), tf.z);
    return enter <= exit ? enter : std::numeric_limits<float>::infinity();
}

inline bool hit_triangle(const glm::vec3& origin, const glm::vec3& dir, const glm::vec3& a,
                         const glm::vec3& b, const glm::vec3& c, float t_min, float t_max,
                         float* out_t, float* out_u, float* out_v) {
    glm::vec3 e1 = b - a, e2 = c - a;
    glm::vec3 p = glm::cross(dir, e2);
    float det = glm::dot(e1, p);
    if (det == 0.0f || !std::isfinite(det)) return false;
    float inv = 1.0f / det;
    glm::vec3 s = origin - a;
    float u = glm::dot(s, p) * inv;
    // note: barycentrics get a small tolerance so rays through a shared edge or corner cannot slip
    // between the triangles on float rounding (light leaks through box edges otherwise).
    if (u < -kBaryEps || u > 1.0f + kBaryEps) return false;
    glm::vec3 q = glm::cross(s, e1);
    float v = glm::dot(dir, q) * inv;
    if (v < -kBaryEps || u + v > 1.0f + kBaryEps) return false;
    float t = glm::dot(e2, q) * inv;
    if (!(t > t_min && t < t_max)) return false;
    *out_t = t;
    *out_u = u;
    *out_v = v;
    return true;
}

}  // namespace

TriangleBvh::TriangleBvh(std::vector<glm::vec3> corners) {
    assert(corners.size() % 3 == 0);
    const uint32_t tris = uint32_t(corners.size() / 3);
    if (tris == 0) return;

    std::vector<glm::vec3> centroid(tris);
    for (uint32_t t = 0; t < tris; ++t)
        centroid[t] = (corners[3 * t] + corners[3 * t + 1] + corners[3 * t + 2]) / 3.0f;
    std::vector<uint32_t> order(tris);
    std::iota(order.begin(), order.end(), 0u);

    nodes_.reserve(2 * size_t(tris));
    nodes_.push_back(Node{});
    struct Task {
        uint32_t node, begin, end;
    };
    std::vector<Task> tasks{{0, 0, tris}};
    while (!tasks.empty()) {
        Task task = tasks.back();
        tasks.pop_back();
        glm::vec3 lo(std::numeric_limits<float>::max()), hi(-std::numeric_limits<float>::max());
        glm::vec3 clo = lo, chi = hi;
        for (uint32_t i = task.begin; i < task.end; ++i) {
            uint32_t t = order[i];
            for (int k = 0; k < 3; ++k) {
                lo = glm::min(lo, corners[3 * t + k]);
                hi = glm::max(hi, corners[3 * t + k]);
            }
            clo = glm::min(clo, centroid[t]);
            chi = glm::max(chi, centroid[t]);
        }
        // note: padded so the slab test cannot cull a ray grazing a triangle on the box boundary
        // (the barycentric tolerance above reaches slightly outside the triangle, too).
        glm::vec3 pad = 2e-5f * (hi - lo) + 1e-6f * glm::max(glm::abs(lo), glm::abs(hi)) + 1e-7f;
        nodes_[task.node].lo = lo - pad;
        nodes_[task.node].hi = hi + pad;
        uint32_t n = task.end - task.begin;
        glm::vec3 extent = chi - clo;
        if (n <= kLeafSize || std::max({extent.x, extent.y, extent.z}) <= 0.0f) {
            nodes_[task.node].first = task.begin;
            nodes_[task.node].count = n;
            continue;
        }
        int axis =
            extent.x >= extent.y && extent.x >= extent.z ? 0 : (extent.y >= extent.z ? 1 : 2);
        uint32_t mid = task.begin + n / 2;
        std::nth_element(order.begin() + task.begin, order.begin() + mid, order.begin() + task.end,
                         [&](uint32_t a, uint32_t b) {
                             if (centroid[a][axis] != centroid[b][axis])
                                 return centroid[a][axis] < centroid[b][axis];
                             return a < b;  // note: deterministic across standard libraries
                         });
        uint32_t left = uint32_t(nodes_.size());
        nodes_.push_back(Node{});
        nodes_.push_back(Node{});
        nodes_[task.node].first = left;
        nodes_[task.node].count = 0;
        tasks.push_back({left + 1, mid, task.end});
        tasks.push_back({left, task.begin, mid});
    }

    corners_.resize(corners.size());
    original_ = order;
    for (uint32_t i = 0; i < tris; ++i)
        for (int k = 0; k < 3; ++k) corners_[3 * i + k] = corners[3 * order[i] + k];
}

template <bool AnyHit>
bool TriangleBvh::traverse(const glm::vec3& origin, const glm::vec3& dir, float t_min, float t_max,
                           RayHit* out_hit) const {
    if (nodes_.empty()) return false;
    const glm::vec3 inv_dir = 1.0f / dir;  // note: +-inf for axis-parallel rays is intended
    uint32_t stack[kStackSize];
    int top = 0;
    if (!std::isfinite(hit_box(nodes_[0].lo, nodes_[0].hi, origin, inv_dir, t_min, t_max)))
        return false;
    stack[top++] = 0;
    bool found = false;
    float best = t_max;
    while (top > 0) {
        const Node& node = nodes_[stack[--top]];
        if (node.count > 0) {
            for (uint32_t i = node.first; i < node.first + node.count; ++i) {
                float t, u, v;
                if (!hit_triangle(origin, dir, corners_[3 * i], corners_[3 * i + 1],
                                  corners_[3 * i + 2], t_min, best, &t, &u, &v))
                    continue;
                if (AnyHit) return true;
                found = true;
                best = t;
                out_hit->t = t;
                out_hit->triangle = original_[i];
                out_hit->u = u;
                out_hit->v = v;
            }
            continue;
        }
        uint32_t l = node.first, r = node.first + 1;
        float tl = hit_box(nodes_[l].lo, nodes_[l].hi, origin, inv_dir, t_min, best);
        float tr = hit_box(nodes_[r].lo, nodes_[r].hi, origin, inv_dir, t_min, best);
        if (tl > tr) {
            std::swap(tl, tr);
            std::swap(l, r);
        }
        // Push the farther child first so the nearer one is popped next.
        if (std::isfinite(tr)) {
            assert(top < kStackSize);
            stack[top++] = r;
        }
        if (std::isfinite(tl)) {
            assert(top < kStackSize);
            stack[top++] = l;
        }
    }
    return found;
}

bool TriangleBvh::occluded(const glm::vec3& origin, const glm::vec3& dir, float t_min,
                           float t_max) const {
    return traverse<true>(origin, dir, t_min, t_max, nullptr);
}

bool TriangleBvh::intersect(const glm::vec3& origin, const glm::vec3& dir, float t_min, float t_max,
                            RayHit* out_hit) const {
    assert(out_hit);
    return traverse<false>(origin, dir, t_min, t_max, out_hit);
}

}  // namespace hmdnode
