// Surface-to-surface distance by the Metro method (Cignoni, Rocchini & Scopigno, "Metro: measuring
// error on simplified surfaces", CGF 1998, section 3): sample one surface densely, area-weighted,
// and take each sample's exact distance to the nearest point of the other surface; the maximum
// over the samples is a lower bound of the one-sided Hausdorff distance, the area-weighted average
// the mean error.
//
// Sampling: triangle i gets N * area_i / total_area samples, rounded on the running sum (at least
// one when its area is non-zero), placed by a randomly rotated R2 low-discrepancy sequence
// (M. Roberts, "The unreasonable effectiveness of quasirandom sequences", web article, 2018) folded
// into the triangle, so the samples are stratified and reproducible for a seed. Each sample weighs
// area_i / samples_i. The mean's standard error is the weighted mean's,
// sqrt(sum w_i^2 (d_i - mean)^2) / sum w_i, as if the samples were independent; stratification only
// makes the true error smaller. N defaults to an eighth of the sampled mesh's triangle count (at
// least 1024).
//
// Upper bound of the Hausdorff distance (branch and bound, as in Tang, Lee & Kim, "Interactive
// Hausdorff distance computation for general polygonal models", SIGGRAPH 2009, with the bound of
// the Lipschitz argument): the distance to a surface is 1-Lipschitz, so on a triangle whose
// corners are at distances d_0..d_2 and whose points are all within r of a corner (r the corner
// covering radius: the circumradius, or less for an obtuse triangle), every point is at most
// max d_k + r away. Every vertex of the sampled mesh is measured, which bounds every triangle;
// the triangles with the largest bounds are split 1:4 at their edge midpoints (3 queries, each
// child's r is half its parent's) best first, until the largest bound is the largest sampled
// distance (the Hausdorff distance is then exact) or the refinement's query budget is spent.
// The midpoints count for the maximum (the lower bound) too.
//
// Nearest point: Embree 3 BVH over the target triangles, rtcPointQuery with a
// closest-point-on-triangle callback (C. Ericson, "Real-Time Collision Detection", Morgan Kaufmann
// 2005, 5.1.5) that shrinks the query radius; each query starts with the radius of its
// predecessor's nearest triangle (the samples are in triangle order, so that is near), which prunes
// most of the tree from the start.
// Cost: O(T log T) to build a BVH (level 0's once per MeshDistanceReference), O(log T) per query
// typically; time O((N + V + R) log T) with R refinement queries, memory O(N + T + R).
// If Embree cannot make a device the queries fall back to a brute-force loop (O(N T)), which is
// only fit for small meshes.
#include "hmdnode/lod/mesh_distance.hpp"

#include <embree3/rtcore.h>

#include <algorithm>
#include <atomic>
#include <cassert>
#include <cmath>
#include <limits>
#include <thread>
#include <vector>

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
    if (!(total > 0.0)) return out;
    out.samples.reserve(n + tris);
    // R2 sequence constants (1/g, 1/g^2 with g the plastic number).
    const double a1 = 0.7548776662466927, a2 = 0.5698402909980532;
    double cumulative = 0.0;
    size_t emitted_before = 0;
    for (size_t t = 0; t < tris; ++t) {
        if (!(areas[t] > 0.0)) continue;
        cumulative += areas[t];
        const size_t upto = size_t(std::llround(cumulative / total * double(n)));
        size_t k = upto > emitted_before ? upto - emitted_before : 0;
        emitted_before = std::max(emitted_before, upto);
        k = std::max<size_t>(k, 1);
        uint64_t state = (uint64_t(seed) << 32) ^ uint64_t(t) * 0xD1B54A32D192ED03ull;
        const double r0 = unit(state), s0 = unit(state);
        const dvec3 a = vertex(m, t, 0), b = vertex(m, t, 1), c = vertex(m, t, 2);
        const float w = float(areas[t] / double(k));
        for (size_t j = 0; j < k; ++j) {
            double u = std::fmod(r0 + a1 * double(j + 1), 1.0);
            double v = std::fmod(s0 + a2 * double(j + 1), 1.0);
            if (u + v > 1.0) u = 1.0 - u, v = 1.0 - v;
            out.samples.push_back({glm::vec3(a + u * (b - a) + v * (c - a)), w});
        }
    }
    return out;
}

// An owned copy of a mesh with its BVH (or none: brute force).
struct Surface {
    std::vector<glm::vec3> positions;
    std::vector<uint32_t> indices;
    // Per triangle, for the queries: its corners and its unit normal (zero when degenerate), so a
    // candidate whose plane is farther than the best distance found is dropped with one dot
    // product.
    struct Packed {
        dvec3 a, b, c, n;
    };
    std::vector<Packed> packed;
    RTCDevice device = nullptr;
    RTCScene scene = nullptr;

    explicit Surface(TriangleMeshView m)
        : positions(m.positions.begin(), m.positions.end()),
          indices(m.indices.begin(), m.indices.begin() + m.indices.size() / 3 * 3) {
        const size_t tris = indices.size() / 3;
        packed.resize(tris);
        for (size_t t = 0; t < tris; ++t) {
            Packed& q = packed[t];
            q.a = vertex(view(), t, 0), q.b = vertex(view(), t, 1), q.c = vertex(view(), t, 2);
            const dvec3 n = glm::cross(q.b - q.a, q.c - q.a);
            const double len = glm::length(n);
            q.n = len > 0.0 ? n / len : dvec3(0.0);
        }
        if (tris == 0) return;
        device = rtcNewDevice("threads=1");
        if (!device) return;
        scene = rtcNewScene(device);
        rtcSetSceneBuildQuality(scene, RTC_BUILD_QUALITY_LOW);
        RTCGeometry geom = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
        auto* vb = static_cast<float*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0,
                                                               RTC_FORMAT_FLOAT3, 3 * sizeof(float),
                                                               positions.size()));
        auto* ib = static_cast<uint32_t*>(rtcSetNewGeometryBuffer(
            geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(uint32_t), tris));
        if (vb && ib) {
            for (size_t i = 0; i < positions.size(); ++i) {
                vb[3 * i + 0] = positions[i].x;
                vb[3 * i + 1] = positions[i].y;
                vb[3 * i + 2] = positions[i].z;
            }
            std::copy(indices.begin(), indices.end(), ib);
            rtcCommitGeometry(geom);
            rtcAttachGeometry(scene, geom);
            rtcReleaseGeometry(geom);
            rtcCommitScene(scene);
        } else {
            rtcReleaseGeometry(geom);
            rtcReleaseScene(scene);
            scene = nullptr;
        }
    }
    ~Surface() {
        if (scene) rtcReleaseScene(scene);
        if (device) rtcReleaseDevice(device);
    }
    Surface(const Surface&) = delete;
    Surface& operator=(const Surface&) = delete;
    TriangleMeshView view() const { return {positions, indices}; }
    size_t triangles() const { return indices.size() / 3; }
};

constexpr uint32_t kNone = std::numeric_limits<uint32_t>::max();

struct QueryState {
    const Surface* surface;
    dvec3 p;
    double best2;
    uint32_t best;
    // Squared distance to triangle t, or `best2` when its plane alone is already farther.
    double to(size_t t) const {
        const Surface::Packed& q = surface->packed[t];
        const double h = glm::dot(p - q.a, q.n);
        if (h * h >= best2) return best2;
        const dvec3 c = closest_on_triangle(p, q.a, q.b, q.c);
        return glm::dot(c - p, c - p);
    }
};

float query_radius(double d2) {
    // note: Embree's radius and query point are float; inflate so that the true nearest triangle
    // is never culled by rounding.
    return std::nextafter(float(std::sqrt(d2) * (1.0 + 1e-6)), INFINITY);
}

bool point_query_callback(RTCPointQueryFunctionArguments* args) {
    auto* q = static_cast<QueryState*>(args->userPtr);
    const size_t t = args->primID;
    const double d2 = q->to(t);
    if (d2 < q->best2) {
        q->best2 = d2;
        q->best = uint32_t(t);
        args->query->radius = query_radius(d2);
        return true;
    }
    return false;
}

// Nearest-point queries on one surface, from one thread: each starts from the last one's nearest
// triangle.
class Querier {
  public:
    explicit Querier(const Surface& s) : s_(s) {}
    size_t queries = 0;

    double distance(const dvec3& p) {
        ++queries;
        QueryState st{&s_, p, std::numeric_limits<double>::infinity(), kNone};
        if (hint_ != kNone) {
            st.best2 = st.to(hint_);
            st.best = hint_;
        }
        if (s_.scene) {
            RTCPointQuery query;
            query.x = float(p.x);
            query.y = float(p.y);
            query.z = float(p.z);
            query.time = 0.0f;
            query.radius = std::isfinite(st.best2) ? query_radius(st.best2)
                                                   : std::numeric_limits<float>::infinity();
            RTCPointQueryContext context;
            rtcInitPointQueryContext(&context);
            rtcPointQuery(s_.scene, &query, &context, point_query_callback, &st);
        } else {  // no device: every triangle
            for (size_t t = 0; t < s_.triangles(); ++t) {
                const double d2 = st.to(t);
                if (d2 < st.best2) st.best2 = d2, st.best = uint32_t(t);
            }
        }
        hint_ = st.best;
        return std::sqrt(st.best2);
    }
    // The nearest triangle of the last query (kNone when `to` has none).
    uint32_t nearest() const { return hint_; }

  private:
    const Surface& s_;
    uint32_t hint_ = kNone;
};

// fn(begin, end, querier, worker) over [0, n) in chunks on `threads` threads (the caller's one
// among them); returns the queries made.
template <class F>
size_t parallel_queries(size_t n, const Surface& to, unsigned threads, F&& fn) {
    const size_t chunk = 1024;
    const unsigned workers =
        std::max(1u, std::min<unsigned>(threads, unsigned((n + chunk - 1) / chunk)));
    std::atomic<size_t> next{0};
    std::vector<size_t> made(workers, 0);
    auto work = [&](unsigned w) {
        Querier q(to);
        for (;;) {
            const size_t begin = next.fetch_add(chunk);
            if (begin >= n) break;
            fn(begin, std::min(n, begin + chunk), q, w);
        }
        made[w] = q.queries;
    };
    std::vector<std::thread> pool;
    for (unsigned w = 1; w < workers; ++w) pool.emplace_back(work, w);
    work(0);
    for (std::thread& t : pool) t.join();
    size_t total = 0;
    for (size_t m : made) total += m;
    return total;
}

// A piece of a sampled triangle in the refinement: its corners, their distances and nearest
// triangles of `to`, the corner covering radius r, and its bound `upper`, the smaller of
//   max d_k + r                    (1-Lipschitz: every point is within r of a corner), and
//   min_j max_k dist(p_k, T_j)     (T_j a corner's nearest triangle: the distance to one triangle
//                                  is convex, so on the cell it is largest at a corner).
struct Cell {
    dvec3 p[3];
    double d[3];
    uint32_t t[3];
    double r;
    double upper;
};

double distance_to(const Surface& s, const dvec3& p, uint32_t t) {
    const Surface::Packed& q = s.packed[t];
    const dvec3 c = closest_on_triangle(p, q.a, q.b, q.c);
    return glm::length(c - p);
}

void bound_cell(Cell& c, const Surface& to, double lower) {
    c.upper = std::max({c.d[0], c.d[1], c.d[2]}) + c.r;
    if (c.upper <= lower) return;  // settled already
    for (int j = 0; j < 3; ++j) {
        const uint32_t t = c.t[j];
        if (t == kNone || (j > 0 && t == c.t[0]) || (j > 1 && t == c.t[1])) continue;
        double m = c.d[j];
        for (int k = 0; k < 3 && m < c.upper; ++k)
            if (k != j) m = std::max(m, c.t[k] == t ? c.d[k] : distance_to(to, c.p[k], t));
        c.upper = std::min(c.upper, m);
    }
}

// The upper bound of the one-sided Hausdorff distance from `from` (its vertex distances `vd` and
// nearest triangles `vt`) to `to`, refining the cells with the largest bounds with at most
// `budget` queries; raises `lower` with the midpoints measured.
double hausdorff_upper_bound(const TriangleMeshView& from, const std::vector<float>& radii,
                             const std::vector<double>& vd, const std::vector<uint32_t>& vt,
                             const Surface& to, Querier& q, size_t budget, double& lower) {
    const size_t tris = from.indices.size() / 3;
    if (tris == 0) return lower;
    auto cell_of = [&](size_t t) {
        Cell c;
        for (int k = 0; k < 3; ++k) {
            const uint32_t v = from.indices[t * 3 + k];
            c.p[k] = vertex(from, t, k);
            c.d[k] = vd[v];
            c.t[k] = vt[v];
        }
        c.r = radii[t];
        bound_cell(c, to, lower);
        return c;
    };
    std::vector<std::pair<double, uint32_t>> bounds;
    for (size_t t = 0; t < tris; ++t) {
        const Cell c = cell_of(t);
        if (c.upper > lower) bounds.push_back({c.upper, uint32_t(t)});
    }
    // Only the top budget / 3 triangles can be split; the rest keep their bound.
    const size_t keep = std::min(bounds.size(), budget / 3);
    auto larger = [](const auto& x, const auto& y) { return x.first > y.first; };
    std::nth_element(bounds.begin(), bounds.begin() + ptrdiff_t(keep), bounds.end(), larger);
    double rest = 0.0;
    for (size_t i = keep; i < bounds.size(); ++i) rest = std::max(rest, bounds[i].first);
    auto lower_cell = [](const Cell& x, const Cell& y) { return x.upper < y.upper; };
    std::vector<Cell> heap;
    heap.reserve(keep + budget);
    for (size_t i = 0; i < keep; ++i) heap.push_back(cell_of(bounds[i].second));
    std::make_heap(heap.begin(), heap.end(), lower_cell);
    size_t spent = 0;
    while (!heap.empty() && spent + 3 <= budget) {
        const Cell c = heap.front();
        if (c.upper <= std::max(lower, rest)) break;
        std::pop_heap(heap.begin(), heap.end(), lower_cell);
        heap.pop_back();
        const dvec3 m[3] = {0.5 * (c.p[0] + c.p[1]), 0.5 * (c.p[1] + c.p[2]),
                            0.5 * (c.p[2] + c.p[0])};
        double dm[3];
        uint32_t tm[3];
        for (int k = 0; k < 3; ++k) {
            dm[k] = q.distance(m[k]);
            tm[k] = q.nearest();
            lower = std::max(lower, dm[k]);
        }
        spent += 3;
        const double r = 0.5 * c.r;  // the children are similar to the parent, half its size
        Cell children[4] = {
            {{c.p[0], m[0], m[2]}, {c.d[0], dm[0], dm[2]}, {c.t[0], tm[0], tm[2]}, r, 0.0},
            {{m[0], c.p[1], m[1]}, {dm[0], c.d[1], dm[1]}, {tm[0], c.t[1], tm[1]}, r, 0.0},
            {{m[2], m[1], c.p[2]}, {dm[2], dm[1], c.d[2]}, {tm[2], tm[1], c.t[2]}, r, 0.0},
            {{m[0], m[1], m[2]}, {dm[0], dm[1], dm[2]}, {tm[0], tm[1], tm[2]}, r, 0.0}};
        for (Cell& child : children) {
            bound_cell(child, to, lower);
            if (child.upper <= lower) continue;  // settled
            heap.push_back(child);
            std::push_heap(heap.begin(), heap.end(), lower_cell);
        }
    }
    double upper = std::max(lower, rest);
    if (!heap.empty()) upper = std::max(upper, heap.front().upper);
    return upper;
}

// Distances from every sample and vertex of `from` to the surface `to`.
OneSidedDistance measure_one_side(const TriangleMeshView& from, const SampleSet& set,
                                  const Surface& to, unsigned threads, size_t refine_budget) {
    OneSidedDistance out;
    out.samples = set.samples.size();
    if (to.triangles() == 0 || set.vertices.empty()) return out;

    // The area samples: max, mean, rms and the sums of the standard error.
    struct Partial {
        double max = 0.0, w = 0.0, wd = 0.0, wdd = 0.0, w2 = 0.0, w2d = 0.0, w2dd = 0.0;
    };
    const unsigned workers = std::max(1u, threads);
    std::vector<Partial> partial(workers);
    out.queries += parallel_queries(set.samples.size(), to, workers,
                                    [&](size_t begin, size_t end, Querier& q, unsigned w) {
                                        Partial& acc = partial[w];
                                        for (size_t i = begin; i < end; ++i) {
                                            const Sample& s = set.samples[i];
                                            const double d = q.distance(dvec3(s.p));
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
    // The vertices: for the maximum and, with the corner covering radii, its upper bound.
    std::vector<double> vd(from.positions.size(), 0.0);
    std::vector<uint32_t> vt(from.positions.size(), kNone);
    out.queries += parallel_queries(set.vertices.size(), to, workers,
                                    [&](size_t begin, size_t end, Querier& q, unsigned) {
                                        for (size_t i = begin; i < end; ++i) {
                                            const uint32_t v = set.vertices[i];
                                            vd[v] = q.distance(dvec3(from.positions[v]));
                                            vt[v] = q.nearest();
                                        }
                                    });
    double lower = total.max;
    for (uint32_t v : set.vertices) lower = std::max(lower, vd[v]);
    Querier q(to);
    out.max_upper = hausdorff_upper_bound(from, set.radii, vd, vt, to, q, refine_budget, lower);
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
    Impl(TriangleMeshView m, const MeshDistanceOptions& o) : a(m), options(o) {
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
    const unsigned threads = thread_count(r.options);
    const Surface b(b_view);
    MeshDistance out;
    out.diagonal = r.diagonal;
    out.forward =
        measure_one_side(r.a.view(), r.samples, b, threads, refine_for(r.a.triangles(), r.options));
    out.backward = measure_one_side(
        b.view(),
        sample_surface(b.view(), samples_for(b.triangles(), r.options), r.options.seed + 1), r.a,
        threads, refine_for(std::max(r.a.triangles(), b.triangles()), r.options));
    out.hausdorff = std::max(out.forward.max, out.backward.max);
    out.hausdorff_upper = std::max(out.forward.max_upper, out.backward.max_upper);
    const bool fwd = out.forward.mean >= out.backward.mean;
    out.mean = fwd ? out.forward.mean : out.backward.mean;
    out.mean_stderr = fwd ? out.forward.mean_stderr : out.backward.mean_stderr;
    out.rms = std::max(out.forward.rms, out.backward.rms);
    return out;
}

MeshDistance measure_mesh_distance(TriangleMeshView a, TriangleMeshView b,
                                   const MeshDistanceOptions& options) {
    return MeshDistanceReference(a, options).measure(b);
}

}  // namespace hmdnode
