// Surface-to-surface distance by the Metro method (Cignoni, Rocchini & Scopigno, "Metro: measuring
// error on simplified surfaces", CGF 1998, section 3): sample one surface, area-weighted, and take
// each sample's exact distance to the nearest point of the other surface; the maximum over the
// points measured is a lower bound of the one-sided Hausdorff distance, the area-weighted average
// the mean error.
//
// Sampling: N samples spread over the triangles in proportion to their area, rounded on the
// running sum (a small triangle may get none: systematic sampling in triangle order), placed in
// each triangle by a randomly rotated R2 low-discrepancy sequence (M. Roberts, "The unreasonable
// effectiveness of quasirandom sequences", web article, 2018), so the samples are stratified and
// reproducible for a seed. Each sample weighs total_area / N. The mean's standard error is the
// weighted mean's, sqrt(sum w_i^2 (d_i - mean)^2) / sum w_i, as if the samples were independent;
// stratification only makes the true error smaller. N defaults to an eighth of the sampled mesh's
// triangle count (at least 1024).
//
// Upper bound of the Hausdorff distance (branch and bound, as in Tang, Lee & Kim, "Interactive
// Hausdorff distance computation for general polygonal models", SIGGRAPH 2009, with the bound of
// the Lipschitz argument), without a query per vertex:
// - every vertex v gets an upper bound u(v) = dist(v, tau) of its distance, tau a triangle of the
//   other mesh: the nearest triangle of a sample on a triangle around it (propagated across
//   triangles without samples), improved by a local walk towards v's projection (descend():
//   across the edges it lies beyond, else to the nearest triangle around tau's corners;
//   point-triangle distances, no search). Only where u(v) exceeds the largest distance
//   measured so far is v queried exactly, largest u first: a vertex with u(v) <= that maximum
//   cannot hold the maximum, so the maximum over the vertices is still exact;
// - a triangle's bound is the smaller of max_k u(p_k) + r (d is 1-Lipschitz and every point is
//   within r of a corner, r the corner covering radius) and max_k dist(p_k, tau) for a triangle
//   tau of the other mesh (the distance to one triangle is convex: largest at a corner), tau its
//   samples' and its corners' triangles;
// - every triangle enters a max-heap with its cheap bound; the top is first tightened (the convex
//   bounds), then split 1:4 at its edge midpoints (each child's r half its parent's; each
//   midpoint's distance bounded by a walk from its edge's corners' triangles, and queried where
//   the walk did not end over a triangle or leaves it above the largest distance measured), until
//   the top is the largest distance measured (the Hausdorff distance is then exact) or the
//   refinement's budget of midpoints is spent; the top is the bound. The midpoints count for the
//   lower bound too (exactly: one that could raise it is queried);
// - with MeshDistanceOptions::prism_bounds, a triangle whose corners lie nearest to different
//   triangles and whose convex bounds leave it above the largest distance measured is bounded by
//   the prism bound where that is smaller (prism_bound(): the distance along its normal
//   to the triangles of the other mesh over it, largest at a corner of their overlay), exact where
//   the other mesh is flat over it and close where it turns little; each tight bound's peak is
//   measured once, so the refinement closes the bracket without splitting the triangles down to
//   the size of the distance (which the Lipschitz bound needs).
//
// Nearest point: a BVH over the target's triangles (Morton order, split at the octree planes,
// float boxes; built in O(T) after a radix sort), depth first, nearer child first, from a hint
// triangle whose distance is the starting radius (the previous query's nearest: the queries run in
// the BVH's leaf order, in which each measured mesh is sampled and walked, so it is near), closest
// point on a triangle by C. Ericson, "Real-Time Collision Detection", Morgan Kaufmann 2005, 5.1.5,
// in double precision. Cost: O(T) per BVH (level 0's once per MeshDistanceReference), O(log T) per
// query typically; time O((N + Q + R) log T + T) with Q the vertices queried (few: the descent
// settles most) and R refinement queries, memory O(N + T + R); with prism bounds also O(k) per
// triangle, k the triangles of the other mesh over it (the edge table O(T) per mesh).
#include "hmdnode/lod/mesh_distance.hpp"

#include <algorithm>
#include <atomic>
#include <cassert>
#include <cmath>
#include <exception>
#include <limits>
#include <thread>
#include <vector>

#include "thread_cpu.hpp"

namespace hmdnode {
namespace {

using dvec3 = glm::dvec3;

// Closest point on triangle abc to p (Ericson 5.1.5), in double.
dvec3 closest_on_triangle(const dvec3& p, const dvec3& a, const dvec3& b, const dvec3& c) {
    const dvec3 ab = b - a, ac = c - a, ap = p - a;
    const double d1 = glm::dot(ab, ap), d2 = glm::dot(ac, ap);
    if (d1 <= 0.0 && d2 <= 0.0) return a;
    const dvec3 bp = p - b;
    const double d3 = glm::dot(ab, bp), d4 = glm::dot(ac, bp);
    if (d3 >= 0.0 && d4 <= d3) return b;
    const double vc = d1 * d4 - d3 * d2;
    if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) {
        const double v = d1 / (d1 - d3);
        return a + v * ab;
    }
    const dvec3 cp = p - c;
    const double d5 = glm::dot(ab, cp), d6 = glm::dot(ac, cp);
    if (d6 >= 0.0 && d5 <= d6) return c;
    const double vb = d5 * d2 - d1 * d6;
    if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) {
        const double w = d2 / (d2 - d6);
        return a + w * ac;
    }
    const double va = d3 * d6 - d5 * d4;
    if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0) {
        const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return b + w * (c - b);
    }
    const double sum = va + vb + vc;
    if (!(sum > 0.0)) {
        // note: degenerate triangle (zero area): nearest of its three edges.
        auto seg = [&](const dvec3& s0, const dvec3& s1) {
            const dvec3 d = s1 - s0;
            const double len2 = glm::dot(d, d);
            const double t = len2 > 0.0 ? std::clamp(glm::dot(p - s0, d) / len2, 0.0, 1.0) : 0.0;
            return s0 + t * d;
        };
        dvec3 best = seg(a, b);
        for (const dvec3& q : {seg(b, c), seg(c, a)})
            if (glm::dot(q - p, q - p) < glm::dot(best - p, best - p)) best = q;
        return best;
    }
    const double denom = 1.0 / sum;
    const double v = vb * denom, w = vc * denom;
    return a + ab * v + ac * w;
}

constexpr uint32_t kNone = std::numeric_limits<uint32_t>::max();

struct Sample {
    glm::vec3 p;
    float weight;  // area represented
};

uint64_t splitmix64(uint64_t& x) {
    uint64_t z = (x += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

double unit(uint64_t& state) {
    return double(splitmix64(state) >> 11) * (1.0 / 9007199254740992.0);
}

dvec3 vertex(const TriangleMeshView& m, size_t tri, int corner) {
    return dvec3(m.positions[m.indices[tri * 3 + corner]]);
}

double triangle_area(const TriangleMeshView& m, size_t t) {
    const dvec3 a = vertex(m, t, 0), b = vertex(m, t, 1), c = vertex(m, t, 2);
    return 0.5 * glm::length(glm::cross(b - a, c - a));
}

// The sampled side of a direction: area samples in triangle order and the referenced vertices.
struct SampleSet {
    std::vector<Sample> samples;
    std::vector<uint32_t> vertices;  // referenced, in first-use order
    std::vector<float> radii;        // per triangle, its corner covering radius (rounded up)
    std::vector<uint32_t> first;     // triangle t's samples: [first[t], first[t + 1])
};

SampleSet sample_surface(const TriangleMeshView& m, size_t n, uint32_t seed) {
    SampleSet out;
    const size_t tris = m.indices.size() / 3;
    // In the order the triangles first use them: consecutive queries are near each other.
    std::vector<char> used(m.positions.size(), 0);
    for (uint32_t i : m.indices)
        if (!used[i]) used[i] = 1, out.vertices.push_back(i);
    out.radii.resize(tris);
    for (size_t t = 0; t < tris; ++t)
        out.radii[t] = std::nextafter(
            float(corner_covering_radius(vertex(m, t, 0), vertex(m, t, 1), vertex(m, t, 2))),
            INFINITY);
    std::vector<double> areas(tris);
    double total = 0.0;
    for (size_t t = 0; t < tris; ++t) total += areas[t] = triangle_area(m, t);
    out.first.assign(tris + 1, 0);
    if (!(total > 0.0)) return out;
    out.samples.reserve(n + tris);
    // R2 sequence constants (1/g, 1/g^2 with g the plastic number).
    const double a1 = 0.7548776662466927, a2 = 0.5698402909980532;
    double cumulative = 0.0;
    size_t emitted_before = 0;
    for (size_t t = 0; t < tris; ++t) {
        out.first[t] = uint32_t(out.samples.size());
        if (!(areas[t] > 0.0)) continue;
        cumulative += areas[t];
        const size_t upto = size_t(std::llround(cumulative / total * double(n)));
        size_t k = upto > emitted_before ? upto - emitted_before : 0;
        emitted_before = std::max(emitted_before, upto);
        if (k == 0) continue;
        uint64_t state = (uint64_t(seed) << 32) ^ uint64_t(t) * 0xD1B54A32D192ED03ull;
        const double r0 = unit(state), s0 = unit(state);
        const dvec3 a = vertex(m, t, 0), b = vertex(m, t, 1), c = vertex(m, t, 2);
        const float w = float(total / double(n));  // each sample stands for an equal area
        for (size_t j = 0; j < k; ++j) {
            double u = std::fmod(r0 + a1 * double(j + 1), 1.0);
            double v = std::fmod(s0 + a2 * double(j + 1), 1.0);
            if (u + v > 1.0) u = 1.0 - u, v = 1.0 - v;
            out.samples.push_back({glm::vec3(a + u * (b - a) + v * (c - a)), w});
        }
    }
    out.first[tris] = uint32_t(out.samples.size());
    return out;
}

// An owned copy of a mesh with its BVH: nodes of float boxes (they hold the float corners exactly,
// so a box's distance, taken in double, never exceeds a triangle's in it) over the triangles in
// the Morton order of their centroids, each node splitting its range in half, leaves of at most 4
// triangles (O(T) to build after a radix sort); the triangles are stored in that order.
struct Surface {
    std::vector<glm::vec3> positions;
    std::vector<uint32_t> indices;
    // Per triangle in leaf order, for the queries: its corners and its unit normal (zero when
    // degenerate), so a candidate whose plane is farther than the best distance found is dropped
    // with one dot product.
    struct Packed {
        dvec3 a, b, c, n;
    };
    std::vector<Packed> packed;
    // count == 0: an inner node, children at first and first + 1; else triangles [first, +count).
    struct Node {
        glm::vec3 lo;
        uint32_t first;
        glm::vec3 hi;
        uint32_t count;
    };
    std::vector<Node> nodes;
    // The triangles (in leaf order) around each vertex: fan[fan_start[v] .. fan_start[v + 1]); and
    // each triangle's vertices, corners[3 i + k]. For the local descent (descend()).
    std::vector<uint32_t> fan_start, fan, corners;
    // across[3 i + k]: the triangle across triangle i's edge from corner k to corner k + 1 when
    // exactly one other triangle has that edge and winds it the other way; else kNone (an open
    // border, a non-manifold or inconsistently wound edge). For the prism bound.
    std::vector<uint32_t> across;

    // `edges`: fill `across` (the prism bound's walks need it).
    Surface(TriangleMeshView m, bool edges)
        : positions(m.positions.begin(), m.positions.end()),
          indices(m.indices.begin(), m.indices.begin() + m.indices.size() / 3 * 3) {
        const size_t tris = indices.size() / 3;
        if (tris == 0) return;
        std::vector<uint32_t> code;
        const std::vector<uint32_t> order = morton_order(code);
        nodes.reserve(2 * (tris / 2 + 1));
        nodes.push_back({});
        // (node, begin, end) still to build: split where the highest bit of the Morton code that
        // differs in the range changes (a plane of the octree), in the middle where all codes are
        // equal, so the depth is at most 30 + log2(T); the boxes are filled in afterwards,
        // children before parents.
        struct Todo {
            uint32_t node, begin, end;
        };
        std::vector<Todo> todo{{0, 0, uint32_t(tris)}};
        while (!todo.empty()) {
            const Todo w = todo.back();
            todo.pop_back();
            Node& n = nodes[w.node];
            if (w.end - w.begin <= 4) {
                n.first = w.begin, n.count = w.end - w.begin;
                continue;
            }
            uint32_t mid = w.begin + (w.end - w.begin) / 2;
            if (const uint32_t x = code[w.begin] ^ code[w.end - 1]; x != 0) {
                const uint32_t bit = 1u << (31 - __builtin_clz(x));
                mid = uint32_t(std::partition_point(code.begin() + w.begin, code.begin() + w.end,
                                                    [&](uint32_t c) { return !(c & bit); }) -
                               code.begin());
            }
            n.first = uint32_t(nodes.size()), n.count = 0;
            todo.push_back({n.first, w.begin, mid});
            todo.push_back({n.first + 1, mid, w.end});
            nodes.push_back({}), nodes.push_back({});
        }
        packed.resize(tris);
        corners.resize(3 * tris);
        fan_start.assign(positions.size() + 1, 0);
        for (size_t i = 0; i < tris; ++i)
            for (int k = 0; k < 3; ++k) {
                corners[3 * i + k] = indices[3 * order[i] + k];
                ++fan_start[corners[3 * i + k] + 1];
            }
        for (size_t v = 0; v < positions.size(); ++v) fan_start[v + 1] += fan_start[v];
        fan.resize(3 * tris);
        {
            std::vector<uint32_t> at(fan_start.begin(), fan_start.end() - 1);
            for (size_t i = 0; i < 3 * tris; ++i) fan[at[corners[i]]++] = uint32_t(i / 3);
        }
        if (edges) across.assign(3 * tris, kNone);
        for (size_t i = 0; i < tris && edges; ++i)
            for (int k = 0; k < 3; ++k) {
                const uint32_t v0 = corners[3 * i + k], v1 = corners[3 * i + (k + 1) % 3];
                uint32_t other = kNone, sharing = 0;
                for (uint32_t f = fan_start[v0]; f < fan_start[v0 + 1]; ++f) {
                    const uint32_t j = fan[f];
                    if (j == i) continue;
                    for (int m = 0; m < 3; ++m) {
                        if (corners[3 * j + m] != v0) continue;
                        const uint32_t next = corners[3 * j + (m + 1) % 3],
                                       prev = corners[3 * j + (m + 2) % 3];
                        if (next == v1) sharing += 2;  // wound the same way: never crossed
                        if (prev == v1) ++sharing, other = j;
                    }
                }
                if (sharing == 1) across[3 * i + k] = other;
            }
        for (size_t i = 0; i < tris; ++i) {
            Packed& q = packed[i];
            const uint32_t t = order[i];
            q.a = vertex(view(), t, 0), q.b = vertex(view(), t, 1), q.c = vertex(view(), t, 2);
            const dvec3 n = glm::cross(q.b - q.a, q.c - q.a);
            const double len = glm::length(n);
            q.n = len > 0.0 ? n / len : dvec3(0.0);
        }
        for (size_t i = nodes.size(); i-- > 0;) {
            Node& n = nodes[i];
            if (n.count > 0) {
                n.lo = glm::vec3(INFINITY), n.hi = glm::vec3(-INFINITY);
                for (uint32_t k = n.first; k < n.first + n.count; ++k)
                    for (int c = 0; c < 3; ++c) {
                        const glm::vec3& v = positions[indices[3 * order[k] + c]];
                        n.lo = glm::min(n.lo, v), n.hi = glm::max(n.hi, v);
                    }
            } else {
                n.lo = glm::min(nodes[n.first].lo, nodes[n.first + 1].lo);
                n.hi = glm::max(nodes[n.first].hi, nodes[n.first + 1].hi);
            }
        }
        // The view (what a measurement from this surface samples and walks) in leaf order too:
        // neighbours follow each other, so consecutive queries read nearby parts of the other
        // mesh (on the bunny about a fifth of the measurement's time).
        indices = corners;
    }
    // The triangles sorted by the Morton code (10 bits an axis) of their centroids in the
    // centroids' bounding box: an LSD radix sort, 3 passes of 10 bits. `sorted` gets the codes
    // in that order.
    std::vector<uint32_t> morton_order(std::vector<uint32_t>& sorted) const {
        const size_t tris = indices.size() / 3;
        std::vector<glm::vec3> centre(tris);
        glm::vec3 lo(INFINITY), hi(-INFINITY);
        for (size_t t = 0; t < tris; ++t) {
            centre[t] = (positions[indices[3 * t]] + positions[indices[3 * t + 1]] +
                         positions[indices[3 * t + 2]]) *
                        (1.0f / 3.0f);
            lo = glm::min(lo, centre[t]), hi = glm::max(hi, centre[t]);
        }
        const glm::vec3 scale = 1023.0f / glm::max(hi - lo, glm::vec3(1e-30f));
        auto spread = [](uint32_t x) {  // 10 bits to every third bit
            x = (x | (x << 16)) & 0x030000FFu;
            x = (x | (x << 8)) & 0x0300F00Fu;
            x = (x | (x << 4)) & 0x030C30C3u;
            return (x | (x << 2)) & 0x09249249u;
        };
        std::vector<uint32_t> code(tris), order(tris), tmp(tris);
        for (size_t t = 0; t < tris; ++t) {
            const glm::vec3 q = glm::clamp((centre[t] - lo) * scale, 0.0f, 1023.0f);
            code[t] =
                spread(uint32_t(q.x)) | (spread(uint32_t(q.y)) << 1) | (spread(uint32_t(q.z)) << 2);
            order[t] = uint32_t(t);
        }
        for (int shift = 0; shift < 30; shift += 10) {
            std::vector<uint32_t> count(1025, 0);
            for (uint32_t t : order) ++count[((code[t] >> shift) & 1023) + 1];
            for (size_t i = 1; i < count.size(); ++i) count[i] += count[i - 1];
            for (uint32_t t : order) tmp[count[(code[t] >> shift) & 1023]++] = t;
            order.swap(tmp);
        }
        sorted.resize(tris);
        for (size_t i = 0; i < tris; ++i) sorted[i] = code[order[i]];
        return order;
    }
    TriangleMeshView view() const { return {positions, indices}; }
    size_t triangles() const { return indices.size() / 3; }
};

// Squared distance from p to a node's box.
[[gnu::always_inline]] inline double box_distance2(const Surface::Node& n, const dvec3& p) {
    const dvec3 d = glm::max(dvec3(n.lo) - p, glm::max(dvec3(0.0), p - dvec3(n.hi)));
    return glm::dot(d, d);
}

// Nearest-point queries on one surface, from one thread: each starts from a hint triangle (by
// default the last query's nearest), whose distance is the radius the tree is searched within;
// nearer children first, a box no nearer than the best distance found is skipped.
class Querier {
  public:
    explicit Querier(const Surface& s) : s_(s) {}
    size_t queries = 0;

    double distance(const dvec3& p) { return distance(p, hint_); }
    double distance(const dvec3& p, uint32_t hint) {
        ++queries;
        double best2 = std::numeric_limits<double>::infinity();
        uint32_t best = kNone;
        if (hint != kNone) best2 = to(hint, p, best2), best = hint;
        struct Entry {
            uint32_t node;
            double d2;
        };
        Entry stack[96];  // the depth is at most 30 + log2(T)
        int top = 0;
        stack[top++] = {0, box_distance2(s_.nodes[0], p)};
        while (top > 0) {
            const Entry e = stack[--top];
            if (e.d2 >= best2) continue;
            const Surface::Node& n = s_.nodes[e.node];
            if (n.count > 0) {
                for (uint32_t t = n.first; t < n.first + n.count; ++t) {
                    const double d2 = to(t, p, best2);
                    if (d2 < best2) best2 = d2, best = t;
                }
                continue;
            }
            const double d0 = box_distance2(s_.nodes[n.first], p);
            const double d1 = box_distance2(s_.nodes[n.first + 1], p);
            const bool near0 = d0 <= d1;
            const Entry near{n.first + (near0 ? 0u : 1u), near0 ? d0 : d1};
            const Entry far{n.first + (near0 ? 1u : 0u), near0 ? d1 : d0};
            assert(top + 2 <= 96);
            if (far.d2 < best2) stack[top++] = far;
            if (near.d2 < best2) stack[top++] = near;
        }
        hint_ = best;
        return std::sqrt(best2);
    }
    // The nearest triangle of the last query (kNone when `to` has none).
    uint32_t nearest() const { return hint_; }

  private:
    // Squared distance from p to triangle t, or `best2` when its plane alone is already farther.
    double to(uint32_t t, const dvec3& p, double best2) const {
        const Surface::Packed& q = s_.packed[t];
        const double h = glm::dot(p - q.a, q.n);
        if (h * h >= best2) return best2;
        const dvec3 c = closest_on_triangle(p, q.a, q.b, q.c);
        return glm::dot(c - p, c - p);
    }
    const Surface& s_;
    uint32_t hint_ = kNone;
};

using lod_detail::thread_cpu_ms;

// fn(begin, end, querier, worker) over [0, n) in chunks on `threads` threads (the caller's one
// among them); returns the queries made, adds the CPU time of the threads it started to
// `helper_cpu_ms`.
template <class F>
size_t parallel_queries(size_t n, const Surface& to, unsigned threads, double& helper_cpu_ms,
                        F&& fn) {
    const size_t chunk = 1024;
    const unsigned workers =
        std::max(1u, std::min<unsigned>(threads, unsigned((n + chunk - 1) / chunk)));
    std::atomic<size_t> next{0};
    std::vector<size_t> made(workers, 0);
    std::vector<double> cpu(workers, 0.0);
    auto work = [&](unsigned w) {
        const double c0 = w > 0 ? thread_cpu_ms() : 0.0;
        Querier q(to);
        for (;;) {
            const size_t begin = next.fetch_add(chunk);
            if (begin >= n) break;
            fn(begin, std::min(n, begin + chunk), q, w);
        }
        made[w] = q.queries;
        if (w > 0) cpu[w] = thread_cpu_ms() - c0;
    };
    std::vector<std::thread> pool;
    for (unsigned w = 1; w < workers; ++w) pool.emplace_back(work, w);
    work(0);
    for (std::thread& t : pool) t.join();
    size_t total = 0;
    for (size_t m : made) total += m;
    for (double c : cpu) helper_cpu_ms += c;
    return total;
}

// A piece of a sampled triangle in the refinement: its corners, upper bounds d_k of their
// distances with the triangles t_k of `to` they are measured to (d_k = dist(p_k, t_k): exact when
// t_k is the nearest), the corner covering radius r, and its bound `upper`, the smaller of
//   max d_k + r                    (1-Lipschitz: every point is within r of a corner),
//   min_j max_k dist(p_k, T_j)     (T_j any triangle of `to`, here the t_k: the distance to one
//                                  triangle is convex, so on the cell it is largest at a corner),
// and the bound it had before (a cell inherits its parent's, and a triangle its samples').
struct Cell {
    dvec3 p[3];
    double d[3];
    uint32_t t[3];
    double r;
    double upper;
    // Where the prism bound (prism_bound()) is largest, when it set `upper` and that point was
    // not measured yet.
    dvec3 peak{0.0};
    bool probe = false;
};

double distance_to(const Surface& s, const dvec3& p, uint32_t t) {
    const Surface::Packed& q = s.packed[t];
    const dvec3 c = closest_on_triangle(p, q.a, q.b, q.c);
    return glm::length(c - p);
}

// The edges of triangle t whose lines have p's projection onto t's plane outside (bit k: the edge
// from corner k to corner k + 1); 0 when the projection lies inside t (its nearest point of t is
// then the foot of the perpendicular).
unsigned outside_edges(const Surface& s, const dvec3& p, uint32_t t) {
    const Surface::Packed& q = s.packed[t];
    return unsigned(glm::dot(glm::cross(q.b - q.a, p - q.a), q.n) < 0.0) |
           unsigned(glm::dot(glm::cross(q.c - q.b, p - q.b), q.n) < 0.0) << 1 |
           unsigned(glm::dot(glm::cross(q.a - q.c, p - q.c), q.n) < 0.0) << 2;
}

// The triangle across triangle t's edge from corner k to corner k + 1 (the first other one
// around that corner that has the edge), or kNone.
uint32_t across_edge(const Surface& s, uint32_t t, int k) {
    const uint32_t v0 = s.corners[3 * size_t(t) + k], v1 = s.corners[3 * size_t(t) + (k + 1) % 3];
    for (uint32_t f = s.fan_start[v0]; f < s.fan_start[v0 + 1]; ++f) {
        const uint32_t j = s.fan[f];
        if (j != t && (s.corners[3 * size_t(j)] == v1 || s.corners[3 * size_t(j) + 1] == v1 ||
                       s.corners[3 * size_t(j) + 2] == v1))
            return j;
    }
    return kNone;
}

// Local descent from triangle `tau` at distance `e` from p, towards p's projection: stop on a
// triangle that p projects into (a local minimum of the distance in most cases, not where the
// surface folds towards p); else move across an edge that the projection lies beyond where the
// triangle there is nearer, and where none is, to the nearest triangle around the current one's
// corners (at most 8 moves). The result is still only an upper bound of p's distance, e and tau
// updated; true where it ended on a triangle that p projects into.
bool descend(const Surface& s, const dvec3& p, uint32_t& tau, double& e) {
    // The corners whose fans were scanned: a triangle there was no nearer than the distance
    // then, and the distance only falls, so each fan is scanned once.
    uint32_t scanned[24];
    int n_scanned = 0;
    for (int step = 0; step < 8; ++step) {
        const unsigned out = outside_edges(s, p, tau);
        if (out == 0) return true;
        uint32_t best = tau;
        for (int k = 0; k < 3; ++k) {
            if (!(out >> k & 1u)) continue;
            const uint32_t t = across_edge(s, tau, k);
            if (t == kNone) continue;
            const double d = distance_to(s, p, t);
            if (d < e) e = d, best = t;
        }
        for (int k = 0; k < 3 && best == tau; ++k) {
            const uint32_t v = s.corners[3 * size_t(tau) + k];
            if (std::find(scanned, scanned + n_scanned, v) != scanned + n_scanned) continue;
            scanned[n_scanned++] = v;
            for (uint32_t f = s.fan_start[v]; f < s.fan_start[v + 1]; ++f) {
                const uint32_t t = s.fan[f];
                if (t == tau) continue;
                const Surface::Packed& q = s.packed[t];
                const double h = glm::dot(p - q.a, q.n);
                if (h * h >= e * e) continue;  // its plane alone is farther
                const dvec3 c = closest_on_triangle(p, q.a, q.b, q.c);
                const double d2 = glm::dot(c - p, c - p);
                if (d2 < e * e) e = std::sqrt(d2), best = t;
            }
        }
        if (best == tau) return false;
        tau = best;
    }
    return outside_edges(s, p, tau) == 0;
}

// The prism bound of a cell C (corners p_k): every point x of C is at most |t(x)| from `to`, t(x)
// the distance from x along C's unit normal n to the triangle of `to` that this line meets, for
// the triangles whose projections along n cover C's. Seen along n, the triangles of `to` over C
// form an arrangement; on each piece, C's part inside one triangle's prism, t is affine in x (the
// line meets that triangle's plane inside the triangle), so its largest |t| is at a corner of the
// piece (C clipped by the projected triangle, Sutherland-Hodgman). The triangles are found by a
// walk from `seed` to the one under C's centroid and a search across every edge whose projection
// touches C (C grown by a relative 1e-9, so nothing is missed by rounding); the projections cover
// C when every triangle reached faces along n (positively wound seen along n: neighbours then lie
// on opposite sides of their shared edge) and no touched edge is an open border, non-manifold or
// inconsistently wound (across[] has no triangle there). Otherwise, or past kMaxPatch triangles,
// the bound does not apply (infinity). It is exact where `to` is flat over C and close to the true
// one where the faces turn little (|t| exceeds the distance by 1 / cos of their angle to n); it
// does not shrink with C's size as the Lipschitz bound does, so a smooth surface needs no
// subdivision. Cost: O(k) for the k triangles over C (a few dozen operations each).
double prism_bound(const Cell& c, const Surface& to, uint32_t seed, dvec3& peak) {
    constexpr int kMaxPatch = 48;
    const double inf = std::numeric_limits<double>::infinity();
    if (seed == kNone) return inf;
    const dvec3 e01 = c.p[1] - c.p[0], e02 = c.p[2] - c.p[0];
    dvec3 n = glm::cross(e01, e02);
    const double nl = glm::length(n), l01 = glm::length(e01);
    if (!(nl > 0.0) || !(l01 > 0.0)) return inf;
    n /= nl;
    const dvec3 u = e01 / l01, v = glm::cross(n, u);
    struct P2 {
        double x, y;
    };
    auto project = [&](const dvec3& x) {
        return P2{glm::dot(x - c.p[0], u), glm::dot(x - c.p[0], v)};
    };
    // C in its own plane, counter-clockwise seen along n.
    const P2 cell[3] = {{0.0, 0.0}, {l01, 0.0}, project(c.p[2])};
    const double size = std::max({l01, glm::length(e02), glm::length(c.p[2] - c.p[1])});
    const double grow = 1e-9 * size;
    auto cross2 = [](P2 a, P2 b, P2 w) {
        return (b.x - a.x) * (w.y - a.y) - (b.y - a.y) * (w.x - a.x);
    };
    // The lengths of C's edges (the signed distances to their lines are cross2 / length).
    double cell_len[3];
    for (int k = 0; k < 3; ++k) {
        const P2 a = cell[k], b = cell[(k + 1) % 3];
        cell_len[k] = std::sqrt((b.x - a.x) * (b.x - a.x) + (b.y - a.y) * (b.y - a.y));
    }
    // Whether segment ab meets C grown by `grow` (clipped against C's three edge lines).
    // note: a contact at one of C's corners alone needs no crossing: the triangles beyond such an
    // edge lie outside C's angle there, and those inside it are reached across the edges that
    // enter C (this keeps the walk off the whole fan of a vertex that C's corner sits on).
    const double corner_tol2 = (1e-6 * size) * (1e-6 * size);
    auto at_corner = [&](P2 w) {
        for (const P2& k : cell)
            if ((w.x - k.x) * (w.x - k.x) + (w.y - k.y) * (w.y - k.y) <= corner_tol2) return true;
        return false;
    };
    auto touches = [&](P2 a, P2 b) {
        double t0 = 0.0, t1 = 1.0;
        for (int k = 0; k < 3; ++k) {
            const P2 e0 = cell[k], e1 = cell[(k + 1) % 3];
            const double sa = cross2(e0, e1, a) + grow * cell_len[k];
            const double sb = cross2(e0, e1, b) + grow * cell_len[k];
            if (sa < 0.0 && sb < 0.0) return false;
            if (sa < 0.0)
                t0 = std::max(t0, sa / (sa - sb));
            else if (sb < 0.0)
                t1 = std::min(t1, sa / (sa - sb));
            if (t0 > t1) return false;
        }
        const P2 w0{a.x + t0 * (b.x - a.x), a.y + t0 * (b.y - a.y)};
        const P2 w1{a.x + t1 * (b.x - a.x), a.y + t1 * (b.y - a.y)};
        if ((w1.x - w0.x) * (w1.x - w0.x) + (w1.y - w0.y) * (w1.y - w0.y) > corner_tol2)
            return true;
        return !at_corner(w0) || !at_corner(w1);
    };
    // A triangle of `to` seen along n, or false when it does not face along n.
    struct Seen {
        P2 q[3];
        double facing;  // n . its unit normal
    };
    auto see = [&](uint32_t t, Seen& out) {
        const Surface::Packed& q = to.packed[t];
        out.facing = glm::dot(n, q.n);
        if (!(out.facing > 1e-3)) return false;
        out.q[0] = project(q.a), out.q[1] = project(q.b), out.q[2] = project(q.c);
        return cross2(out.q[0], out.q[1], out.q[2]) > 0.0;
    };
    // Walk from the seed to the triangle under C's centroid: across an edge whose line has the
    // centroid outside (a visibility walk; the step limit ends a cycle).
    const P2 centre{(cell[0].x + cell[1].x + cell[2].x) / 3.0,
                    (cell[0].y + cell[1].y + cell[2].y) / 3.0};
    uint32_t start = seed;
    Seen seen;
    for (int step = 0;; ++step) {
        if (step == 64 || !see(start, seen)) return inf;
        int out_edge = -1;
        for (int k = 0; k < 3 && out_edge < 0; ++k)
            if (cross2(seen.q[k], seen.q[(k + 1) % 3], centre) < 0.0) out_edge = k;
        if (out_edge < 0) break;
        start = to.across[3 * size_t(start) + out_edge];
        if (start == kNone) return inf;
    }
    uint32_t patch[kMaxPatch];
    int count = 0, next = 0;
    patch[count++] = start;
    double bound = 0.0;
    while (next < count) {
        const uint32_t t = patch[next++];
        if (!see(t, seen)) return inf;
        const Surface::Packed& q = to.packed[t];
        // C clipped by the triangle's three edge lines.
        P2 poly[9], tmp[9];
        int m = 3;
        for (int k = 0; k < 3; ++k) poly[k] = cell[k];
        for (int k = 0; k < 3 && m > 0; ++k) {
            const P2 a = seen.q[k], b = seen.q[(k + 1) % 3];
            int o = 0;
            for (int i = 0; i < m; ++i) {
                const P2 x = poly[i], y = poly[(i + 1) % m];
                const double sx = cross2(a, b, x), sy = cross2(a, b, y);
                if (sx >= 0.0) tmp[o++] = x;
                if ((sx >= 0.0) != (sy >= 0.0)) {
                    const double f = sx / (sx - sy);
                    tmp[o++] = {x.x + f * (y.x - x.x), x.y + f * (y.y - x.y)};
                }
            }
            m = o;
            for (int i = 0; i < m; ++i) poly[i] = tmp[i];
        }
        for (int i = 0; i < m; ++i) {
            const dvec3 x = c.p[0] + u * poly[i].x + v * poly[i].y;
            const double h = std::abs(glm::dot(q.a - x, q.n)) / seen.facing;
            if (h > bound) bound = h, peak = x;
        }
        for (int k = 0; k < 3; ++k) {
            if (!touches(seen.q[k], seen.q[(k + 1) % 3])) continue;
            const uint32_t nb = to.across[3 * size_t(t) + k];
            if (nb == kNone) return inf;
            if (std::find(patch, patch + count, nb) != patch + count) continue;
            if (count == kMaxPatch) return inf;
            patch[count++] = nb;
        }
    }
    // note: rounding in the clip moves a piece's corners by about 1e-16 of C's size; the slope of
    // t is at most 1 / facing.
    return bound * (1.0 + 1e-12) + 1e-9 * size;
}

// The refinement lets a cell go once its bound is within this relative margin of the largest
// distance measured (the margin stays in the bound it reports).
constexpr double kSettle = 1e-4;

// Tightens c.upper (set by the caller: a bound it already has, or infinity): the Lipschitz bound,
// then the convex bounds of the corners' triangles; with `prism`, where the corners were measured
// to more than one triangle and those bounds leave the cell above `lower`, the prism bound where
// it is smaller.
void bound_cell(Cell& c, const Surface& to, double lower, bool prism) {
    c.upper = std::min(c.upper, std::max({c.d[0], c.d[1], c.d[2]}) + c.r);
    if (c.upper <= lower) return;  // settled already
    const bool one = c.t[0] != kNone && c.t[0] == c.t[1] && c.t[1] == c.t[2];
    for (int j = 0; j < 3; ++j) {
        const uint32_t t = c.t[j];
        if (t == kNone || (j > 0 && t == c.t[0]) || (j > 1 && t == c.t[1])) continue;
        double m = c.d[j];
        for (int k = 0; k < 3 && m < c.upper; ++k)
            if (k != j) m = std::max(m, c.t[k] == t ? c.d[k] : distance_to(to, c.p[k], t));
        if (m < c.upper) c.upper = m, c.probe = false;
    }
    if (!prism || one || c.upper <= lower) return;
    for (int j = 0; j < 3; ++j)
        if (c.t[j] != kNone) {
            dvec3 peak;
            const double b = prism_bound(c, to, c.t[j], peak);
            if (b < c.upper) c.upper = b, c.peak = peak, c.probe = true;
            break;
        }
}

// What the refinement starts from: per vertex of `from` an upper bound of its distance, vd[v] =
// dist(v, vt[v]) (exact where it was queried), and per triangle the convex bound from its
// samples' nearest triangles (infinity when it has none).
struct VertexBounds {
    std::vector<double> vd;
    std::vector<uint32_t> vt;
    std::vector<double> convex;
};

// The upper bound of the one-sided Hausdorff distance from `from` to `to`, best first: every
// triangle enters a max-heap with its cheap bound (its samples' convex bound, the Lipschitz bound
// of its corners' bounds); an entry at the top is first tightened (bound_cell: point-triangle
// distances, no query), and a tight one at the top is split 1:4 (3 midpoints), while `budget`
// (points measured) lasts; what is left at the top is the bound. Raises `lower` with the
// midpoints measured. With `prism` every triangle is tightened first, in order (bound_cell with
// its prism bound), a tight entry whose prism bound's peak was not measured yet has it measured
// (1 point) before it is split, and a cell within a relative kSettle of `lower` is let go.
double hausdorff_upper_bound(const TriangleMeshView& from, const std::vector<float>& radii,
                             const VertexBounds& vb, const Surface& to, Querier& q, size_t budget,
                             bool prism, double& lower) {
    const size_t tris = from.indices.size() / 3;
    if (tris == 0) return lower;
    auto cell_of = [&](size_t t) {
        Cell c;
        for (int k = 0; k < 3; ++k) {
            const uint32_t v = from.indices[t * 3 + k];
            c.p[k] = vertex(from, t, k);
            c.d[k] = vb.vd[v];
            c.t[k] = vb.vt[v];
        }
        c.r = radii[t];
        c.upper = std::min(vb.convex[t], std::max({c.d[0], c.d[1], c.d[2]}) + c.r);
        return c;
    };
    // id < tris: triangle id (its cell made again by cell_of); else pieces[id - tris].
    struct Entry {
        double upper;
        uint32_t id;
        bool tight;
    };
    auto below = [](const Entry& x, const Entry& y) { return x.upper < y.upper; };
    std::vector<Cell> pieces;
    // A cell whose bound is within a relative kSettle of `lower` is let go; the largest such bound
    // stays part of the result.
    double band = 0.0;
    auto settled = [&](double u) {
        if (u <= lower) return true;
        if (!prism || u > lower * (1.0 + kSettle)) return false;
        band = std::max(band, u);
        return true;
    };
    // The distance at x, exact wherever it could raise `lower`: a walk (descend()) from the nearer
    // of the triangles t0 and t1, and a query where that leaves it above `lower` (a point whose
    // walk ends at or below it cannot raise it) or the walk did not end over a triangle (it was
    // still far: a large cell over a fine mesh); `t` the triangle it ended on.
    auto measure = [&](const dvec3& x, uint32_t t0, uint32_t t1, uint32_t& t) {
        double e = std::numeric_limits<double>::infinity();
        t = kNone;
        for (uint32_t s : {t0, t1})
            if (s != kNone && s != t)
                if (const double d = distance_to(to, x, s); d < e) e = d, t = s;
        const bool over = t != kNone && descend(to, x, t, e);
        if (e > lower || !over) {
            e = q.distance(x, t);
            t = q.nearest();
            lower = std::max(lower, e);
        }
        return e;
    };
    std::vector<Entry> heap;
    auto push_piece = [&](const Cell& c) {
        heap.push_back({c.upper, uint32_t(tris + pieces.size()), true});
        pieces.push_back(c);
        std::push_heap(heap.begin(), heap.end(), below);
    };
    // note: every triangle is tightened in order first (neighbours follow each other, and so do
    // the parts of `to` their bounds read), the heap orders what is left; per triangle its
    // prism bound's peak (Cell::peak, probe), the rest made again by cell_of.
    std::vector<dvec3> peaks(prism ? tris : 0);
    std::vector<char> probes(prism ? tris : 0, 0);
    for (size_t t = 0; t < tris; ++t) {
        Cell c = cell_of(t);
        if (c.upper <= lower) continue;
        if (!prism) {  // tightened when it comes to the top
            heap.push_back({c.upper, uint32_t(t), false});
            continue;
        }
        bound_cell(c, to, lower, prism);
        if (settled(c.upper)) continue;
        heap.push_back({c.upper, uint32_t(t), true});
        peaks[t] = c.peak, probes[t] = c.probe;
    }
    std::make_heap(heap.begin(), heap.end(), below);
    size_t spent = 0;
    while (!heap.empty() && !settled(heap.front().upper)) {
        std::pop_heap(heap.begin(), heap.end(), below);
        const Entry e = heap.back();
        heap.pop_back();
        Cell c = e.id < tris ? cell_of(e.id) : pieces[e.id - tris];
        c.upper = e.upper;
        if (e.id < tris && prism) c.peak = peaks[e.id], c.probe = probes[e.id];
        if (!e.tight) {
            bound_cell(c, to, lower, prism);
            if (settled(c.upper)) continue;
            // note: only a triangle comes untightened (with prism bounds all are tightened first),
            // made again by cell_of, its bound in the entry.
            heap.push_back({c.upper, e.id, true});
            std::push_heap(heap.begin(), heap.end(), below);
            continue;
        }
        if (spent + (c.probe ? 1 : 3) > budget) {  // out of queries: it stays as it is
            heap.push_back(e);
            std::push_heap(heap.begin(), heap.end(), below);
            break;
        }
        if (c.probe) {
            // The point where its prism bound is largest: measured, that bound is often closed.
            uint32_t t;
            measure(c.peak, c.t[0], c.t[1], t);
            ++spent;
            if (e.id < tris)
                probes[e.id] = 0;
            else
                pieces[e.id - tris].probe = false;
            if (!settled(c.upper)) {
                heap.push_back(e);
                std::push_heap(heap.begin(), heap.end(), below);
            }
            continue;
        }
        const dvec3 m[3] = {0.5 * (c.p[0] + c.p[1]), 0.5 * (c.p[1] + c.p[2]),
                            0.5 * (c.p[2] + c.p[0])};
        double dm[3];
        uint32_t tm[3];
        for (int k = 0; k < 3; ++k) dm[k] = measure(m[k], c.t[k], c.t[(k + 1) % 3], tm[k]);
        spent += 3;
        const double r = 0.5 * c.r;  // the children are similar to the parent, half its size
        const double u = c.upper;    // each child lies in its parent
        Cell children[4] = {
            {{c.p[0], m[0], m[2]}, {c.d[0], dm[0], dm[2]}, {c.t[0], tm[0], tm[2]}, r, u},
            {{m[0], c.p[1], m[1]}, {dm[0], c.d[1], dm[1]}, {tm[0], c.t[1], tm[1]}, r, u},
            {{m[2], m[1], c.p[2]}, {dm[2], dm[1], c.d[2]}, {tm[2], tm[1], c.t[2]}, r, u},
            {{m[0], m[1], m[2]}, {dm[0], dm[1], dm[2]}, {tm[0], tm[1], tm[2]}, r, u}};
        for (Cell& child : children) {
            bound_cell(child, to, lower, prism);
            if (!settled(child.upper)) push_piece(child);
        }
    }
    // note: untightened entries below the top are bounded by it.
    return std::max({lower, band, heap.empty() ? 0.0 : heap.front().upper});
}

// The vertex bounds from the samples' nearest triangles `nearest` (each triangle's samples'
// distinct ones: 3 point-triangle distances each, no query), then an exact query for each vertex
// whose bound exceeds the largest distance measured (`lower`, raised by them), largest bound
// first: a vertex whose bound is at most `lower` cannot hold the maximum.
VertexBounds bound_vertices(const TriangleMeshView& from, const SampleSet& set,
                            const std::vector<uint32_t>& nearest, const Surface& to, Querier& q,
                            double& lower) {
    const size_t tris = from.indices.size() / 3;
    VertexBounds vb;
    vb.vd.assign(from.positions.size(), std::numeric_limits<double>::infinity());
    vb.vt.assign(from.positions.size(), kNone);
    vb.convex.assign(tris, std::numeric_limits<double>::infinity());
    auto try_candidate = [&](size_t t, uint32_t tau) {
        double m = 0.0;
        for (int k = 0; k < 3; ++k) {
            const uint32_t v = from.indices[t * 3 + k];
            const double e = distance_to(to, vertex(from, t, k), tau);
            if (e < vb.vd[v]) vb.vd[v] = e, vb.vt[v] = tau;
            m = std::max(m, e);
        }
        vb.convex[t] = std::min(vb.convex[t], m);
    };
    std::vector<char> open_tri(tris, 1);  // no candidate of its own yet
    for (size_t t = 0; t < tris; ++t) {
        const uint32_t begin = set.first.empty() ? 0 : set.first[t];
        const uint32_t end = set.first.empty() ? 0 : set.first[t + 1];
        for (uint32_t i = begin; i < end; ++i) {
            const uint32_t tau = nearest[i];
            if (tau == kNone || (i > begin && tau == nearest[i - 1])) continue;
            try_candidate(t, tau);
            open_tri[t] = 0;
        }
    }
    // A vertex without a candidate takes one from a corner of a triangle around it (one
    // distance each), sweeping forwards and backwards until none is left or nothing changes.
    for (bool changed = true; changed;) {
        changed = false;
        for (int sweep = 0; sweep < 2; ++sweep)
            for (size_t i = 0; i < tris; ++i) {
                const size_t t = sweep == 0 ? i : tris - 1 - i;
                if (!open_tri[t]) continue;
                uint32_t tau = kNone;
                bool missing = false;
                for (int k = 0; k < 3; ++k) {
                    const uint32_t c = vb.vt[from.indices[t * 3 + k]];
                    if (c == kNone)
                        missing = true;
                    else if (tau == kNone)
                        tau = c;
                }
                if (tau == kNone) continue;
                open_tri[t] = 0, changed = true;
                if (!missing) continue;
                for (int k = 0; k < 3; ++k) {
                    const uint32_t v = from.indices[t * 3 + k];
                    if (vb.vt[v] != kNone) continue;
                    vb.vd[v] = distance_to(to, vertex(from, t, k), tau);
                    vb.vt[v] = tau;
                }
            }
    }
    // Each vertex whose bound exceeds `lower`, in first-use order (neighbours follow each other):
    // the triangle its predecessor ended on as one more candidate, then the local descent.
    uint32_t previous = kNone;
    for (uint32_t v : set.vertices) {
        if (vb.vd[v] <= lower) continue;
        const dvec3 p(from.positions[v]);
        if (previous != kNone && previous != vb.vt[v])
            if (const double e = distance_to(to, p, previous); e < vb.vd[v])
                vb.vd[v] = e, vb.vt[v] = previous;
        if (vb.vt[v] != kNone) descend(to, p, vb.vt[v], vb.vd[v]), previous = vb.vt[v];
    }
    // Then an exact query for those still above `lower`, largest bound first.
    std::vector<std::pair<double, uint32_t>> open;
    for (uint32_t v : set.vertices)
        if (vb.vd[v] > lower) open.push_back({vb.vd[v], v});
    std::sort(open.begin(), open.end(), [](const auto& x, const auto& y) {
        return x.first > y.first || (x.first == y.first && x.second < y.second);
    });
    for (const auto& [bound, v] : open) {
        if (bound <= lower) break;
        vb.vd[v] = q.distance(dvec3(from.positions[v]), vb.vt[v]);
        vb.vt[v] = q.nearest();
        lower = std::max(lower, vb.vd[v]);
    }
    return vb;
}

// Distances from the samples of `from` to the surface `to`, and the bracket of the Hausdorff
// distance from its vertices and triangles.
OneSidedDistance measure_one_side(const TriangleMeshView& from, const SampleSet& set,
                                  const Surface& to, unsigned threads, size_t refine_budget,
                                  bool prism, double& helper_cpu_ms) {
    OneSidedDistance out;
    out.samples = set.samples.size();
    if (to.triangles() == 0 || set.vertices.empty()) return out;

    // The area samples: max, mean, rms and the sums of the standard error; and each one's nearest
    // triangle.
    struct Partial {
        double max = 0.0, w = 0.0, wd = 0.0, wdd = 0.0, w2 = 0.0, w2d = 0.0, w2dd = 0.0;
    };
    const unsigned workers = std::max(1u, threads);
    std::vector<Partial> partial(workers);
    std::vector<uint32_t> nearest(set.samples.size(), kNone);
    out.queries += parallel_queries(set.samples.size(), to, workers, helper_cpu_ms,
                                    [&](size_t begin, size_t end, Querier& q, unsigned w) {
                                        Partial& acc = partial[w];
                                        for (size_t i = begin; i < end; ++i) {
                                            const Sample& s = set.samples[i];
                                            const double d = q.distance(dvec3(s.p));
                                            nearest[i] = q.nearest();
                                            const double wt = s.weight;
                                            acc.max = std::max(acc.max, d);
                                            acc.w += wt;
                                            acc.wd += wt * d;
                                            acc.wdd += wt * d * d;
                                            acc.w2 += wt * wt;
                                            acc.w2d += wt * wt * d;
                                            acc.w2dd += wt * wt * d * d;
                                        }
                                    });
    Partial total;
    for (const Partial& p : partial) {
        total.max = std::max(total.max, p.max);
        total.w += p.w, total.wd += p.wd, total.wdd += p.wdd;
        total.w2 += p.w2, total.w2d += p.w2d, total.w2dd += p.w2dd;
    }
    double lower = total.max;
    Querier q(to);
    const VertexBounds vb = bound_vertices(from, set, nearest, to, q, lower);
    out.max_upper = hausdorff_upper_bound(from, set.radii, vb, to, q, refine_budget, prism, lower);
    out.queries += q.queries;
    out.max = lower;
    if (total.w > 0.0) {
        const double m = total.wd / total.w;
        out.mean = m;
        out.rms = std::sqrt(total.wdd / total.w);
        const double var = total.w2dd - 2.0 * m * total.w2d + m * m * total.w2;
        out.mean_stderr = std::sqrt(std::max(0.0, var)) / total.w;
    }
    return out;
}

// The defaults of MeshDistanceOptions for a sampled mesh of `triangles` triangles.
size_t samples_for(size_t triangles, const MeshDistanceOptions& o) {
    return o.samples ? o.samples : std::max<size_t>(1024, triangles / 8);
}
size_t refine_for(size_t triangles, const MeshDistanceOptions& o) {
    return o.refine_queries ? o.refine_queries : std::max<size_t>(768, triangles / 16);
}

unsigned thread_count(const MeshDistanceOptions& o) {
    return o.threads ? o.threads : std::max(1u, std::thread::hardware_concurrency());
}

}  // namespace

double bounding_box_diagonal(TriangleMeshView mesh) {
    if (mesh.indices.empty()) return 0.0;
    dvec3 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
    for (uint32_t i : mesh.indices) {
        lo = glm::min(lo, dvec3(mesh.positions[i]));
        hi = glm::max(hi, dvec3(mesh.positions[i]));
    }
    return glm::length(hi - lo);
}

double corner_covering_radius(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c) {
    // Sides: lc the longest, opposite corner C; la, lb the others.
    double s[3] = {glm::length(b - c), glm::length(c - a), glm::length(a - b)};
    std::sort(s, s + 3);
    const double la = s[0], lb = s[1], lc = s[2];
    if (!(lc > 0.0)) return 0.0;
    const double area = 0.5 * glm::length(glm::cross(b - a, c - a));
    if (la * la + lb * lb >= lc * lc && area > 0.0) return la * lb * lc / (4.0 * area);
    // Obtuse (or flat): the farthest points lie on the longest side, where the perpendicular
    // bisectors of the two others cross it: lb / (2 cos A) and la / (2 cos B).
    const double ea = lb * lb + lc * lc - la * la, eb = la * la + lc * lc - lb * lb;
    double r = 0.0;
    if (ea > 0.0) r = std::max(r, lb * lb * lc / ea);
    if (eb > 0.0) r = std::max(r, la * la * lc / eb);
    return r > 0.0 ? std::min(r, lc) : 0.5 * lc;
}

struct MeshDistanceReference::Impl {
    Surface a;
    SampleSet samples;  // on a
    MeshDistanceOptions options;
    size_t n = 0;  // samples per direction
    double diagonal = 0.0;
    Impl(TriangleMeshView m, const MeshDistanceOptions& o) : a(m, o.prism_bounds), options(o) {
        samples = sample_surface(a.view(), samples_for(a.triangles(), o), o.seed);
        diagonal = bounding_box_diagonal(a.view());
    }
};

MeshDistanceReference::MeshDistanceReference(TriangleMeshView a, const MeshDistanceOptions& o) {
#ifndef NDEBUG
    for (uint32_t i : a.indices) assert(i < a.positions.size());
#endif
    impl_ = std::make_unique<Impl>(a, o);
}
MeshDistanceReference::~MeshDistanceReference() = default;
MeshDistanceReference::MeshDistanceReference(MeshDistanceReference&&) noexcept = default;
MeshDistanceReference& MeshDistanceReference::operator=(MeshDistanceReference&&) noexcept = default;

MeshDistance MeshDistanceReference::measure(TriangleMeshView b_view) const {
#ifndef NDEBUG
    for (uint32_t i : b_view.indices) assert(i < b_view.positions.size());
#endif
    const Impl& r = *impl_;
    const double c0 = thread_cpu_ms();
    double helper_cpu_ms[2] = {0.0, 0.0}, back_cpu_ms = 0.0;  // not on this thread
    const unsigned threads = thread_count(r.options);
    const Surface b(b_view, r.options.prism_bounds);
    MeshDistance out;
    out.diagonal = r.diagonal;
    // With two threads or more the directions run at once, each its sample queries on half of
    // them; each direction computes what it computes alone, so two threads give the one
    // thread's figures bit for bit.
    const unsigned back_threads = std::max(1u, threads / 2);
    auto forward = [&](unsigned t) {
        out.forward =
            measure_one_side(r.a.view(), r.samples, b, t, refine_for(r.a.triangles(), r.options),
                             r.options.prism_bounds, helper_cpu_ms[0]);
    };
    auto backward = [&] {
        out.backward = measure_one_side(
            b.view(),
            sample_surface(b.view(), samples_for(b.triangles(), r.options), r.options.seed + 1),
            r.a, back_threads, refine_for(std::max(r.a.triangles(), b.triangles()), r.options),
            r.options.prism_bounds, helper_cpu_ms[1]);
    };
    if (threads < 2) {
        forward(threads);
        backward();
    } else {
        std::exception_ptr failed_back, failed_forward;
        std::thread back([&] {
            const double b0 = thread_cpu_ms();
            try {
                backward();
            } catch (...) {
                failed_back = std::current_exception();
            }
            back_cpu_ms = thread_cpu_ms() - b0;
        });
        try {
            forward(threads - back_threads);
        } catch (...) {
            failed_forward = std::current_exception();
        }
        back.join();
        if (failed_forward) std::rethrow_exception(failed_forward);
        if (failed_back) std::rethrow_exception(failed_back);
    }
    out.hausdorff = std::max(out.forward.max, out.backward.max);
    out.hausdorff_upper = std::max(out.forward.max_upper, out.backward.max_upper);
    const bool fwd = out.forward.mean >= out.backward.mean;
    out.mean = fwd ? out.forward.mean : out.backward.mean;
    out.mean_stderr = fwd ? out.forward.mean_stderr : out.backward.mean_stderr;
    out.rms = std::max(out.forward.rms, out.backward.rms);
    out.cpu_ms = thread_cpu_ms() - c0 + helper_cpu_ms[0] + helper_cpu_ms[1] + back_cpu_ms;
    return out;
}

MeshDistance measure_mesh_distance(TriangleMeshView a, TriangleMeshView b,
                                   const MeshDistanceOptions& options) {
    return MeshDistanceReference(a, options).measure(b);
}

}  // namespace hmdnode
