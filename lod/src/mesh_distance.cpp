// Surface-to-surface distance by the Metro method (Cignoni, Rocchini & Scopigno, "Metro: measuring
// error on simplified surfaces", CGF 1998, section 3): sample one surface densely, area-weighted,
// and take each sample's exact distance to the nearest point of the other surface; the maximum
// over the samples is the one-sided Hausdorff distance, the area-weighted average the mean error.
//
// Sampling: triangle i gets N * area_i / total_area samples, rounded on the running sum
// (at least one when its area is non-zero), placed by a randomly rotated R2
// low-discrepancy sequence (Roberts 2018) folded into the triangle, so the samples are stratified
// and reproducible for a seed. Each sample weighs area_i / samples_i. Departure from Metro: the
// vertices of the sampled mesh are measured as well, with weight 0 (they count for the maximum
// only): the maximum of a piecewise-linear distance sits at vertices more often than not, so
// this makes the Hausdorff figure exact for many closed-form cases at no real cost.
//
// Nearest point: Embree 3 BVH over the target triangles, rtcPointQuery with a closest-point-on-
// triangle callback (Ericson, Real-Time Collision Detection, 5.1.5) that shrinks the query radius.
// Cost: O(T log T) to build the BVH, about O(log T) per query; time O((N + V) log T / threads),
// memory O(N + T). If Embree cannot make a device the queries fall back to a brute-force loop
// (O(N T)), which is only fit for small meshes.
#include "hmdnode/lod/mesh_distance.hpp"

#include <embree3/rtcore.h>

#include <algorithm>
#include <atomic>
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
    float weight;  // area represented; 0 for vertex samples
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

std::vector<Sample> sample_surface(const TriangleMeshView& m, size_t n, uint32_t seed) {
    const size_t tris = m.indices.size() / 3;
    std::vector<double> areas(tris);
    double total = 0.0;
    for (size_t t = 0; t < tris; ++t) total += areas[t] = triangle_area(m, t);
    std::vector<Sample> out;
    if (!(total > 0.0)) return out;
    out.reserve(n + tris + m.positions.size());
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
            out.push_back({glm::vec3(a + u * (b - a) + v * (c - a)), w});
        }
    }
    // Referenced vertices, weight 0.
    std::vector<char> used(m.positions.size(), 0);
    for (uint32_t i : m.indices) used[i] = 1;
    for (size_t i = 0; i < used.size(); ++i)
        if (used[i]) out.push_back({m.positions[i], 0.0f});
    return out;
}

struct QueryState {
    const TriangleMeshView* mesh;
    dvec3 p;
    double best2;
};

bool point_query_callback(RTCPointQueryFunctionArguments* args) {
    auto* q = static_cast<QueryState*>(args->userPtr);
    const size_t t = args->primID;
    const dvec3 c = closest_on_triangle(q->p, vertex(*q->mesh, t, 0), vertex(*q->mesh, t, 1),
                                        vertex(*q->mesh, t, 2));
    const double d2 = glm::dot(c - q->p, c - q->p);
    if (d2 < q->best2) {
        q->best2 = d2;
        // note: Embree's radius is float; round up so the true nearest triangle is never culled.
        args->query->radius = std::nextafter(float(std::sqrt(d2)), INFINITY);
        return true;
    }
    return false;
}

// Distances from every sample to the surface `to`, with `threads` workers.
OneSidedDistance measure_one_side(const std::vector<Sample>& samples, const TriangleMeshView& to,
                                  unsigned threads) {
    OneSidedDistance out;
    out.samples = 0;
    for (const Sample& s : samples) out.samples += s.weight > 0.0f ? 1 : 0;
    const size_t tris = to.indices.size() / 3;
    if (samples.empty() || tris == 0) return out;

    RTCDevice device = rtcNewDevice("threads=1");
    RTCScene scene = nullptr;
    if (device) {
        scene = rtcNewScene(device);
        rtcSetSceneBuildQuality(scene, RTC_BUILD_QUALITY_MEDIUM);
        RTCGeometry geom = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
        auto* vb = static_cast<float*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0,
                                                               RTC_FORMAT_FLOAT3, 3 * sizeof(float),
                                                               to.positions.size()));
        auto* ib = static_cast<uint32_t*>(rtcSetNewGeometryBuffer(
            geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(uint32_t), tris));
        if (vb && ib) {
            for (size_t i = 0; i < to.positions.size(); ++i) {
                vb[3 * i + 0] = to.positions[i].x;
                vb[3 * i + 1] = to.positions[i].y;
                vb[3 * i + 2] = to.positions[i].z;
            }
            std::copy(to.indices.begin(), to.indices.begin() + tris * 3, ib);
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

    auto distance_of = [&](const glm::vec3& p) {
        QueryState st{&to, dvec3(p), std::numeric_limits<double>::infinity()};
        if (scene) {
            RTCPointQuery query;
            query.x = p.x;
            query.y = p.y;
            query.z = p.z;
            query.time = 0.0f;
            query.radius = std::numeric_limits<float>::infinity();
            RTCPointQueryContext context;
            rtcInitPointQueryContext(&context);
            rtcPointQuery(scene, &query, &context, point_query_callback, &st);
        }
        if (!std::isfinite(st.best2)) {  // no device, or a query Embree could not place
            for (size_t t = 0; t < tris; ++t) {
                const dvec3 c =
                    closest_on_triangle(st.p, vertex(to, t, 0), vertex(to, t, 1), vertex(to, t, 2));
                st.best2 = std::min(st.best2, glm::dot(c - st.p, c - st.p));
            }
        }
        return std::sqrt(st.best2);
    };

    struct Partial {
        double max = 0.0, sum = 0.0, sum2 = 0.0, weight = 0.0;
    };
    const unsigned workers = std::max(1u, std::min<unsigned>(threads, unsigned(samples.size())));
    std::vector<Partial> partial(workers);
    const size_t chunk = 1024;
    std::atomic<size_t> next{0};
    auto work = [&](unsigned w) {
        Partial& acc = partial[w];
        for (;;) {
            const size_t begin = next.fetch_add(chunk);
            if (begin >= samples.size()) break;
            const size_t end = std::min(samples.size(), begin + chunk);
            for (size_t i = begin; i < end; ++i) {
                const double d = distance_of(samples[i].p);
                const double wt = samples[i].weight;
                acc.max = std::max(acc.max, d);
                acc.sum += wt * d;
                acc.sum2 += wt * d * d;
                acc.weight += wt;
            }
        }
    };
    std::vector<std::thread> pool;
    for (unsigned w = 1; w < workers; ++w) pool.emplace_back(work, w);
    work(0);
    for (std::thread& t : pool) t.join();

    Partial total;
    for (const Partial& p : partial) {
        total.max = std::max(total.max, p.max);
        total.sum += p.sum;
        total.sum2 += p.sum2;
        total.weight += p.weight;
    }
    out.max = total.max;
    if (total.weight > 0.0) {
        out.mean = total.sum / total.weight;
        out.rms = std::sqrt(total.sum2 / total.weight);
    }
    if (scene) rtcReleaseScene(scene);
    if (device) rtcReleaseDevice(device);
    return out;
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

MeshDistance measure_mesh_distance(TriangleMeshView a, TriangleMeshView b,
                                   const MeshDistanceOptions& options) {
#ifndef NDEBUG
    for (uint32_t i : a.indices) assert(i < a.positions.size());
    for (uint32_t i : b.indices) assert(i < b.positions.size());
#endif
    const unsigned threads =
        options.threads ? options.threads : std::max(1u, std::thread::hardware_concurrency());
    MeshDistance out;
    out.diagonal = bounding_box_diagonal(a);
    out.forward = measure_one_side(sample_surface(a, options.samples, options.seed), b, threads);
    out.backward =
        measure_one_side(sample_surface(b, options.samples, options.seed + 1), a, threads);
    out.hausdorff = std::max(out.forward.max, out.backward.max);
    out.mean = std::max(out.forward.mean, out.backward.mean);
    out.rms = std::max(out.forward.rms, out.backward.rms);
    return out;
}

}  // namespace hmdnode
