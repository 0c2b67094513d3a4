// A CPU path tracer on Embree 3 for baking diffuse global illumination (docs/baking.md).
//
// Scene: every object of flatten_objects() at its level 0, in world space, one Embree triangle
// geometry; per triangle its material's Lambertian albedo (base colour factor x base-colour
// texture at uv0, bilinear, sRGB -> linear) and emission (emissive_factor, front side only unless
// the material is double-sided). Lights: KHR_lights_punctual (point, spot, directional, with
// the spec's range window max(0, min(1, 1 - (r / range)^4)) and spot cone falloff), emissive
// triangles, a constant sky radiance for rays that escape.
//
// Estimators (one sample each; average many):
//   irradiance(p, n):  E = integral of L_in cos over the hemisphere of n, with next-event
//     estimation of punctual lights and emissive triangles (area sampling proportional to power)
//     combined with the cosine-sampled continuation by the balance heuristic (MIS), so an emitter
//     is never counted twice; sky only through escaping rays. `bounces` reflections at most
//     between a light and p (0: direct light only; negative, the default: no limit, Russian
//     roulette alone ends the path), Russian roulette after rr_min_bounces (unbiased).
//   radiance(o, d):  the radiance arriving at o from direction -d (camera rays): emission of the
//     first hit + albedo / pi x irradiance there.
// A back face of a single-sided material absorbs (it is the inside of a closed object).
//
// Threads: build on one thread; a built PathTracer is immutable and its queries run on any number
// of threads at once. Callers give each thread / texel its own Pcg32, seeded from (seed, texel
// index), so results do not depend on the thread count.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>

#include <glm/glm.hpp>

#include "hmdnode/core/result.hpp"
#include "hmdnode/core/scene.hpp"

namespace hmdnode {

// PCG32 (M. E. O'Neill, "PCG: A family of simple fast space-efficient statistically good
// algorithms for random number generation", HMC-CS-2014-0905, Harvey Mudd College 2014,
// pcg32_random_r): 64-bit state, stream selected by `stream`.
class Pcg32 {
  public:
    Pcg32(uint64_t seed, uint64_t stream) : inc_((stream << 1u) | 1u) {
        next();
        state_ += seed;
        next();
    }
    uint32_t next() {
        uint64_t old = state_;
        state_ = old * 6364136223846793005ULL + inc_;
        uint32_t xorshifted = uint32_t(((old >> 18u) ^ old) >> 27u);
        uint32_t rot = uint32_t(old >> 59u);
        return (xorshifted >> rot) | (xorshifted << ((-rot) & 31));
    }
    // Uniform in [0, 1).
    float uniform() { return float(next() >> 8) * (1.0f / 16777216.0f); }

  private:
    uint64_t state_ = 0;
    uint64_t inc_;
};

struct PathTracerOptions {
    glm::vec3 sky_radiance{0.0f};  // radiance of rays that leave the scene (W/sr/m^2 units of E)
    int bounces = -1;  // reflections between a light and the point; < 0: until Russian roulette
    int rr_min_bounces = 3;  // Russian roulette on reflections after this many
};

struct TraceQuery {
    glm::vec3 origin{0.0f};
    glm::vec3 dir{0.0f};
    float t_near = 0.0f, t_far = 0.0f;
};

struct TraceHit {
    float t = 0.0f;
    uint32_t triangle = 0;
    float u = 0.0f, v = 0.0f;     // barycentrics of corners 1 and 2
    glm::vec3 face_normal{0.0f};  // unit, winding (front) side
    bool front = true;            // the ray arrived on the front side
    bool double_sided = false;    // the triangle's material is double-sided (no back face)
    // A face turned away from the ray lies on the same spot (touching solids: a wall's face on
    // the next wall's end, a slab on a wall's top); the facing one is returned.
    bool back_face_there = false;
};

// Sets flush-to-zero and denormals-are-zero on the calling thread (Embree's recommendation).
void set_ftz_daz();

// Runs fn(i, thread) for i in [0, count) on `threads` threads (0: all cores), FTZ/DAZ set on each,
// in chunks of `chunk` items taken in order from a shared counter.
void parallel_for(size_t count, int threads, size_t chunk,
                  const std::function<void(size_t i, int thread)>& fn);
int resolve_threads(int threads);

// Ray recording, for the throughput bench (bench/bake_replay_bench.cpp): between start and stop,
// every `every`-th ray that each thread casts through any PathTracer is kept (origin, direction,
// interval, kind), so the baker's own ray mix can be replayed through raw Embree. Off, it costs
// one relaxed atomic load per ray. Not reentrant: one recording at a time in the process.
enum class RayKind : uint8_t {
    Bounce,    // nearest hit, unbounded: path continuations and camera rays
    Short,     // nearest hit as a stream: the validity pass's rays (a texel's at once)
    Shadow,    // any hit (rtcOccluded1): punctual lights and emitter samples
    Coplanar,  // the second nearest-hit query past a back face on a shared wall plane
};
struct RecordedRay {
    glm::vec3 origin{0.0f};
    float t_near = 0.0f;
    glm::vec3 dir{0.0f};
    float t_far = 0.0f;
    RayKind kind = RayKind::Bounce;
};
void start_ray_recording(uint32_t every);
std::vector<RecordedRay> stop_ray_recording();  // the rays kept, every thread's

// How PathTracer::replay_rays casts: Single: rtcIntersect1 / rtcOccluded1 per ray (what the
// baker does); Packet8: shadow and short rays in packets of 8 (rtcOccluded8 / rtcIntersect8,
// consecutive rays of a kind), the rest single; Stream: shadow and short rays as streams of 64
// (rtcOccluded1M / rtcIntersect1M), the rest single.
enum class ReplayMode { Single, Packet8, Stream };
struct ReplayTiming {
    uint64_t rays = 0;
    uint64_t hits = 0;  // nearest hits found plus occluded shadow rays (a checksum)
    double wall_seconds = 0.0;
    double cpu_seconds = 0.0;  // the process's CPU time over the replay
};

class PathTracer {
  public:
    // Errors: a non-finite world position (mesh, primitive and vertex named), Embree failing.
    static Result<PathTracer> build(const Scene& scene, const PathTracerOptions& options);
    PathTracer(PathTracer&&) noexcept;
    PathTracer& operator=(PathTracer&&) noexcept;
    ~PathTracer();

    // One-sample estimates; `rays` (optional) is incremented by the rays cast.
    glm::vec3 irradiance(const glm::vec3& p, const glm::vec3& n, Pcg32& rng,
                         uint64_t* rays = nullptr) const;
    glm::vec3 radiance(const glm::vec3& origin, const glm::vec3& dir, Pcg32& rng,
                       uint64_t* rays = nullptr) const;
    // The same estimate as irradiance() (same random numbers, same sum) in two parts: returns
    // the light that reached p straight from an emitter, a punctual light or the sky, and sets
    // `indirect` to the light that reflected at least once on its way (what firefly clamping and
    // the bake's second filter pass act on).
    glm::vec3 irradiance_split(const glm::vec3& p, const glm::vec3& n, Pcg32& rng,
                               glm::vec3& indirect, uint64_t* rays = nullptr) const;
    // `count` paths, path i from points[i] with normal normals[i], with one rng: the same
    // estimates, random numbers and sums as irradiance_split (indirect given) or irradiance
    // (indirect null: out[i] is the total) called for each in order, but the shadow rays of the
    // whole batch are traced together as one Embree stream (rtcOccluded1M).
    void irradiance_batch(size_t count, const glm::vec3* points, const glm::vec3* normals,
                          Pcg32& rng, glm::vec3* out, glm::vec3* indirect = nullptr,
                          uint64_t* rays = nullptr) const;
    // Direct light only (punctual lights + emitters by NEE + sky by one cosine sample).
    glm::vec3 direct_irradiance(const glm::vec3& p, const glm::vec3& n, Pcg32& rng,
                                uint64_t* rays = nullptr) const;

    std::optional<TraceHit> intersect(const glm::vec3& origin, const glm::vec3& dir, float t_near,
                                      float t_far) const;
    // intersect() for `count` rays at once, traced as one Embree stream (rtcIntersect1M); the
    // same back-face rule per ray.
    void intersect_batch(size_t count, const TraceQuery* rays, std::optional<TraceHit>* out) const;
    // Whether a face turned away from the ray lies at hit h of the ray (origin, dir) too, within
    // the ray offset (touching solids, where Embree returned the facing one): a second query
    // that skips h's triangle. Sets h.back_face_there; returns it.
    bool find_back_face_there(const glm::vec3& origin, const glm::vec3& dir, TraceHit& h) const;
    bool occluded(const glm::vec3& origin, const glm::vec3& dir, float t_near, float t_far) const;

    // Distance to lift a ray origin off a surface at p (scales with the scene's extent).
    float ray_offset(const glm::vec3& p) const;
    size_t triangle_count() const;
    size_t emissive_triangle_count() const;
    size_t punctual_light_count() const;
    bool has_light() const;  // some punctual light, emissive triangle or a non-zero sky
    // Area-weighted mean over the triangles of the largest albedo channel (base colour factor x
    // the texture's mean texel): the rho of the truncation estimate rho^(bounces + 1).
    float mean_albedo() const;
    const PathTracerOptions& options() const;
    glm::vec3 bounds_min() const;
    glm::vec3 bounds_max() const;
    // Warnings from the build (e.g. missing textures: base colour only).
    const std::vector<std::string>& warnings() const;

    // The limit for the benchmark: `count` rays with origins uniform in the scene bounds and
    // uniform directions, plain rtcIntersect1 on `threads` threads. Returns rays per second.
    double raw_rays_per_second(size_t count, int threads, uint64_t seed) const;
    // The recorded rays through raw Embree on this tracer's scene (build it from the same scene
    // as the bake that recorded them), on `threads` threads, in chunks of 4096 in order.
    ReplayTiming replay_rays(const std::vector<RecordedRay>& rays, int threads,
                             ReplayMode mode) const;

  private:
    struct Impl;
    explicit PathTracer(std::unique_ptr<Impl> impl);
    std::unique_ptr<Impl> impl_;
};

}  // namespace hmdnode
