// Unidirectional path tracing of diffuse irradiance (J. T. Kajiya, "The rendering equation",
// SIGGRAPH 1986), with next-event estimation and multiple importance sampling by the balance
// heuristic (E. Veach, L. J. Guibas, "Optimally combining sampling techniques for Monte Carlo
// rendering", SIGGRAPH 1995, sec. 3), cosine-weighted hemisphere sampling (Malley's method),
// triangle area sampling (G. Turk, "Generating random points in triangles", Graphics Gems, Academic
// Press 1990 / Shirley's square-root mapping), Russian roulette (J. Arvo, D. Kirk, "Particle
// transport and image synthesis", SIGGRAPH 1990) and the branchless orthonormal basis of T. Duff et
// al., "Building an orthonormal basis, revisited", Journal of Computer Graphics Techniques 6(1),
// 2017. Full citations: docs/references.md.
//
// Departures: Lambertian only (the baker stores irradiance; the renderer multiplies by albedo);
// one light sample per vertex: the emissive triangles are one "light" chosen by power, punctual
// lights are all evaluated (they are delta lights: no MIS); back faces of single-sided materials
// absorb, unless a face turned towards the ray lies on the same spot (within the ray offset: two
// rooms back to back on one wall plane), which then wins (one more query per back-face hit).
// Shadow rays are deferred and traced as one Embree stream per batch of paths (a texel's paths,
// a vertex sample's): same sums, same random numbers as tracing each where it is cast.
// Cost per sample: O(bounces x (2 + punctual lights)) rays of O(log T) each; memory
// O(T) for the per-triangle data (corners, uv0, material, emitter CDF), and per thread O(batch
// x bounces x (2 + punctual lights)) for the deferred shadow rays.
#include "hmdnode/bake/path_tracer.hpp"

#include <pmmintrin.h>
#include <xmmintrin.h>

#include <algorithm>
#include <atomic>
#include <cassert>
#include <chrono>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>
#include <thread>

#include "embree_scene.hpp"
#include "lightmap_passes.hpp"
#include "world_lights.hpp"

namespace hmdnode {
namespace {

constexpr float kPiF = std::numbers::pi_v<float>;

float srgb_to_linear(float c) {
    return c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f);
}

glm::vec3 cosine_sample(const glm::vec3& n, Pcg32& rng) {
    const float u1 = rng.uniform(), u2 = rng.uniform();
    const float r = std::sqrt(u1), phi = 2.0f * kPiF * u2;
    glm::vec3 t, b;
    detail::tangent_frame(n, t, b);
    const float z = std::sqrt(std::max(0.0f, 1.0f - u1));
    return glm::normalize(t * (r * std::cos(phi)) + b * (r * std::sin(phi)) + n * z);
}

float max3(const glm::vec3& v) {
    return std::max(v.x, std::max(v.y, v.z));
}

struct LinearTexture {
    int w = 0, h = 0;
    std::vector<glm::vec3> rgb;  // linear
    glm::vec3 sample(glm::vec2 uv) const {
        assert(w > 0 && h > 0 && rgb.size() == size_t(w) * size_t(h));
        // Bilinear with repeat wrapping (glTF default sampler), texel centres at +0.5.
        float x = uv.x * w - 0.5f, y = uv.y * h - 0.5f;
        if (!std::isfinite(x) || !std::isfinite(y)) return rgb[0];
        float fx = std::floor(x), fy = std::floor(y);
        float ax = x - fx, ay = y - fy;
        auto at = [&](long ix, long iy) {
            ix %= w;
            iy %= h;
            if (ix < 0) ix += w;
            if (iy < 0) iy += h;
            return rgb[size_t(iy) * w + ix];
        };
        long ix = long(fx), iy = long(fy);
        return (1 - ay) * ((1 - ax) * at(ix, iy) + ax * at(ix + 1, iy)) +
               ay * ((1 - ax) * at(ix, iy + 1) + ax * at(ix + 1, iy + 1));
    }
};

struct TriMaterial {
    glm::vec3 albedo{0.8f};
    glm::vec3 emission{0.0f};
    int texture = -1;  // index into Impl::textures
    bool double_sided = false;
};

}  // namespace

void set_ftz_daz() {
    _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON);
    _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);
}

int resolve_threads(int threads) {
    if (threads > 0) return threads;
    unsigned hc = std::thread::hardware_concurrency();
    return hc > 0 ? int(hc) : 1;
}

void parallel_for(size_t count, int threads, size_t chunk,
                  const std::function<void(size_t i, int thread)>& fn) {
    assert(fn && threads >= 0);
    threads = resolve_threads(threads);
    chunk = std::max<size_t>(1, chunk);
    std::atomic<size_t> next{0};
    auto worker = [&](int thread) {
        set_ftz_daz();
        for (;;) {
            size_t begin = next.fetch_add(chunk);
            if (begin >= count) break;
            size_t end = std::min(count, begin + chunk);
            assert(begin < end && end <= count);  // each index once: chunks taken in order
            for (size_t i = begin; i < end; ++i) fn(i, thread);
        }
    };
    if (threads == 1) {
        worker(0);
        return;
    }
    std::vector<std::thread> pool;
    for (int t = 1; t < threads; ++t) pool.emplace_back(worker, t);
    worker(0);
    for (std::thread& t : pool) t.join();
}

struct PathTracer::Impl {
    PathTracerOptions options;
    detail::EmbreeScene embree;
    std::vector<glm::vec3> corners;  // 3 per triangle, world
    std::vector<glm::vec3> normals;  // 1 per triangle, unit face normal
    std::vector<float> areas;
    std::vector<glm::vec2> uv0;      // 3 per triangle (zero when absent)
    std::vector<uint32_t> material;  // per triangle, index into mats
    std::vector<TriMaterial> mats;
    std::vector<LinearTexture> textures;
    std::vector<detail::WorldLight> lights;
    // Emitters: triangles with emission, chosen with probability ~ luminance x area.
    std::vector<uint32_t> emitters;
    std::vector<float> emitter_cdf;       // inclusive, last = 1
    std::vector<float> emitter_pdf_area;  // per triangle: P(choose) / area (0: not an emitter)
    glm::vec3 lo{0.0f}, hi{0.0f};
    float offset_scale = 1e-4f;
    std::vector<std::string> warnings;

    glm::vec3 albedo(uint32_t tri, float u, float v) const {
        assert(tri < material.size() && material[tri] < mats.size());
        const TriMaterial& m = mats[material[tri]];
        if (m.texture < 0) return m.albedo;
        assert(size_t(m.texture) < textures.size() && 3 * size_t(tri) + 2 < uv0.size());
        glm::vec2 uv = (1 - u - v) * uv0[3 * tri] + u * uv0[3 * tri + 1] + v * uv0[3 * tri + 2];
        return m.albedo * textures[m.texture].sample(uv);
    }

    float offset(const glm::vec3& p) const {
        return offset_scale *
               (1.0f + std::max(std::abs(p.x), std::max(std::abs(p.y), std::abs(p.z))));
    }

    std::optional<TraceHit> intersect(const glm::vec3& o, const glm::vec3& d, float tn,
                                      float tf) const {
        return finish(embree.intersect(o, d, tn, tf), o, d, tn, tf);
    }

    // Embree's nearest hit h of the ray (o, d, [tn, tf]) as a TraceHit.
    std::optional<TraceHit> finish(std::optional<detail::EmbreeHit> h, const glm::vec3& o,
                                   const glm::vec3& d, float tn, float tf) const {
        if (!h) return std::nullopt;
        // Embree's hit lies within the ray's interval, on one of our triangles.
        assert(h->prim < normals.size() && h->t >= tn && h->t <= tf);
        bool swapped = false;
        if (glm::dot(normals[h->prim], d) >= 0.0f && !mats[material[h->prim]].double_sided) {
            // A back face that absorbs. Where another surface lies on it (two rooms sharing a
            // wall plane, back to back) Embree returns either; the one facing the ray wins, so a
            // room's wall does not go black where the next room's wall touches it.
            const float eps = offset(o + d * h->t);
            std::optional<detail::EmbreeHit> other = embree.intersect_skipping(
                o, d, std::max(tn, h->t - eps), std::min(tf, h->t + eps), h->prim);
            if (other && (glm::dot(normals[other->prim], d) < 0.0f ||
                          mats[material[other->prim]].double_sided)) {
                h = other;
                swapped = true;
            }
        }
        TraceHit out;
        out.back_face_there = swapped;
        out.t = h->t;
        out.triangle = h->prim;
        out.u = h->u;
        out.v = h->v;
        out.face_normal = normals[h->prim];
        out.front = glm::dot(out.face_normal, d) < 0.0f;
        out.double_sided = mats[material[h->prim]].double_sided;
        return out;
    }

    // intersect() for a batch of rays: one Embree stream, then the same back-face rule per ray.
    void intersect_batch(size_t count, const TraceQuery* rays, std::optional<TraceHit>* out) const {
        assert(count == 0 || (rays != nullptr && out != nullptr));
        thread_local std::vector<RTCRayHit> rh;
        rh.resize(count);
        for (size_t i = 0; i < count; ++i)
            rh[i].ray = detail::EmbreeScene::make_ray(rays[i].origin, rays[i].dir, rays[i].t_near,
                                                      rays[i].t_far);
        embree.intersect_stream(rh.data(), count);
        for (size_t i = 0; i < count; ++i) {
            std::optional<detail::EmbreeHit> h;
            if (rh[i].hit.geomID != RTC_INVALID_GEOMETRY_ID)
                h = detail::EmbreeHit{rh[i].ray.tfar, rh[i].hit.primID, rh[i].hit.u, rh[i].hit.v};
            out[i] = finish(h, rays[i].origin, rays[i].dir, rays[i].t_near, rays[i].t_far);
        }
    }

    // Shadow rays are deferred to the end of a batch of paths (trace_batch): each path logs what
    // it would add and under which shadow ray, the batch's shadow rays go to Embree as one stream,
    // and the sums are then replayed in the order of the one-ray-at-a-time code, so the floats
    // are the same as if each shadow ray had been traced where it was cast. Whether a shadow ray
    // is blocked changes no random number and no branch of the path, only what is added.
    struct Deferred {
        enum Op : uint8_t { Group, Light, Emit, EndGroup, Add, EndPath };
        struct Item {
            glm::vec3 value;
            int32_t ray;  // shadow ray gating `value` (Light, Emit; -1: none, Emit adds 0)
            Op op;
            uint8_t target;  // 0: the direct sum, 1: the indirect one (Group, Add)
            bool first;      // Group: the path's first (its value starts the direct sum)
        };
        std::vector<Item> items;
        std::vector<RTCRay> rays;
        void clear() {
            items.clear();
            rays.clear();
        }
        int32_t shadow(const glm::vec3& o, const glm::vec3& d, float tn, float tf) {
            rays.push_back(detail::EmbreeScene::make_ray(o, d, tn, tf));
            return int32_t(rays.size() - 1);
        }
        void push(Op op, const glm::vec3& v = glm::vec3(0.0f), int32_t ray = -1, uint8_t target = 0,
                  bool first = false) {
            items.push_back(Item{v, ray, op, target, first});
        }
        bool blocked(int32_t ray) const {
            assert(ray < int32_t(rays.size()));  // a shadow ray this batch logged
            return ray < 0 || rays[size_t(ray)].tfar < 0.0f;
        }
    };

    // Punctual lights at p with normal n, shadowed (the formula in world_lights.hpp): one
    // deferred shadow ray and Light item per light that faces p.
    void punctual(const glm::vec3& p, const glm::vec3& n, uint64_t* rays, Deferred& q) const {
        const glm::vec3 origin = p + n * offset(p);
        for (const detail::WorldLight& l : lights) {
            glm::vec3 to_light;
            float falloff, t_max;
            if (l.type == Light::Type::Directional) {
                to_light = -l.direction;
                falloff = 1.0f;
                t_max = std::numeric_limits<float>::infinity();
            } else {
                glm::vec3 d = l.position - p;
                float dist = glm::length(d);
                if (dist <= 0.0f) continue;
                to_light = d / dist;
                falloff = 1.0f / (dist * dist);
                if (l.range > 0.0f) {
                    float q4 = dist / l.range;
                    falloff *= std::clamp(1.0f - q4 * q4 * q4 * q4, 0.0f, 1.0f);
                }
                if (l.type == Light::Type::Spot) {
                    float a =
                        std::clamp(glm::dot(l.direction, -to_light) * l.cone_scale + l.cone_offset,
                                   0.0f, 1.0f);
                    falloff *= a * a;
                }
                glm::vec3 d2 = l.position - origin;
                t_max = glm::length(d2);
                to_light = d2 / t_max;
            }
            float cos_theta = glm::dot(n, to_light);
            if (cos_theta <= 0.0f || falloff <= 0.0f) continue;
            if (rays) ++*rays;
            q.push(Deferred::Light, l.intensity_rgb * (cos_theta * falloff),
                   q.shadow(origin, to_light, 0.0f, t_max));
        }
    }

    // Solid-angle pdf of light sampling for direction arriving at emitter triangle `tri` at
    // distance t with cos_l at the emitter.
    float light_pdf(uint32_t tri, float t, float cos_l) const {
        if (emitter_pdf_area.empty() || cos_l <= 0.0f) return 0.0f;
        return emitter_pdf_area[tri] * t * t / cos_l;
    }

    // One emitter sample (MIS-weighted against cosine sampling) at p with normal n: one Emit item,
    // its shadow ray deferred.
    void emitter_sample(const glm::vec3& p, const glm::vec3& n, Pcg32& rng, uint64_t* rays,
                        Deferred& q) const {
        if (emitters.empty()) return q.push(Deferred::Emit);
        const float u = rng.uniform();
        size_t k = size_t(std::lower_bound(emitter_cdf.begin(), emitter_cdf.end(), u) -
                          emitter_cdf.begin());
        k = std::min(k, emitters.size() - 1);
        const uint32_t tri = emitters[k];
        assert(emitter_cdf.size() == emitters.size() && tri < emitter_pdf_area.size());
        float s = std::sqrt(rng.uniform()), r2 = rng.uniform();
        const glm::vec3& a = corners[3 * tri];
        const glm::vec3& b = corners[3 * tri + 1];
        const glm::vec3& c = corners[3 * tri + 2];
        const glm::vec3 qp = (1 - s) * a + s * (1 - r2) * b + s * r2 * c;
        const glm::vec3 origin = p + n * offset(p);
        glm::vec3 d = qp - origin;
        const float dist = glm::length(d);
        if (dist <= 0.0f) return q.push(Deferred::Emit);
        d /= dist;
        const float cos_s = glm::dot(n, d);
        if (cos_s <= 0.0f) return q.push(Deferred::Emit);
        const TriMaterial& m = mats[material[tri]];
        float cos_l = -glm::dot(normals[tri], d);
        if (m.double_sided) cos_l = std::abs(cos_l);
        if (cos_l <= 0.0f) return q.push(Deferred::Emit);
        const float pdf_l = emitter_pdf_area[tri] * dist * dist / cos_l;
        if (!(pdf_l > 0.0f)) return q.push(Deferred::Emit);
        if (rays) ++*rays;
        const float pdf_b = cos_s / kPiF;
        const float w = pdf_l / (pdf_l + pdf_b);
        q.push(Deferred::Emit, m.emission * (cos_s / pdf_l * w),
               q.shadow(origin, d, 0.0f, dist * (1.0f - 1e-4f) - offset(qp)));
    }

    // Next-event estimation at (p, n): punctual lights and one emitter sample, as one group.
    void direct_group(const glm::vec3& p, const glm::vec3& n, Pcg32& rng, uint64_t* rays,
                      Deferred& q, const glm::vec3& beta, uint8_t target, bool first) const {
        q.push(Deferred::Group, beta, -1, target, first);
        punctual(p, n, rays, q);
        emitter_sample(p, n, rng, rays, q);
        q.push(Deferred::EndGroup);
    }

    // Irradiance at (p, n) with up to `bounces` reflections, logged into q (its shadow rays
    // deferred). The part that reflected at least once (everything after the first hit's
    // emission) is logged with target 1, the rest with target 0.
    void irradiance(const glm::vec3& p, const glm::vec3& n, Pcg32& rng, uint64_t* rays, int bounces,
                    Deferred& q) const {
        direct_group(p, n, rng, rays, q, glm::vec3(1.0f), 0, true);
        uint8_t acc = 0;  // where contributions go: direct until the first reflection
        // Continuation: radiance along a cosine-sampled direction, times pi.
        glm::vec3 x = p, nx = n;
        glm::vec3 d = cosine_sample(nx, rng);
        float pdf_b = glm::dot(nx, d) / kPiF;
        glm::vec3 beta(kPiF);  // estimator weight: cos / pdf
        for (int k = 0;; ++k) {
            // The bounce limit ends the path before it reflects once more.
            assert(bounces < 0 || k <= bounces);
            if (rays) ++*rays;
            std::optional<TraceHit> h =
                intersect(x + nx * offset(x), d, 0.0f, std::numeric_limits<float>::infinity());
            if (!h) {
                q.push(Deferred::Add, beta * options.sky_radiance, -1, acc);
                break;
            }
            const TriMaterial& m = mats[material[h->triangle]];
            if (!h->front && !m.double_sided) break;  // inside a closed object: absorbed
            const glm::vec3 ns = h->front ? h->face_normal : -h->face_normal;
            if (m.emission.x > 0.0f || m.emission.y > 0.0f || m.emission.z > 0.0f) {
                const float pdf_l = light_pdf(h->triangle, h->t, glm::dot(ns, -d));
                const float w = pdf_b / (pdf_b + pdf_l);
                q.push(Deferred::Add, beta * m.emission * w, -1, acc);
            }
            if (bounces >= 0 && k + 1 > bounces) break;
            const glm::vec3 a = albedo(h->triangle, h->u, h->v);
            if (max3(a) <= 0.0f) break;
            x = x + nx * offset(x) + d * h->t;
            nx = ns;
            beta *= a / kPiF;
            acc = 1;
            direct_group(x, nx, rng, rays, q, beta, acc, false);
            beta *= kPiF;  // cosine sampling: f cos / pdf = albedo
            if (k + 1 >= options.rr_min_bounces) {
                const float qq = std::min(0.95f, max3(beta) / kPiF);
                if (rng.uniform() >= qq) break;
                beta /= qq;
            }
            d = cosine_sample(nx, rng);
            pdf_b = glm::dot(nx, d) / kPiF;
        }
        q.push(Deferred::EndPath);
    }

    // Traces the batch's shadow rays as one stream and replays each path's sums: out[i] (and
    // indirect[i] when given; else the indirect part is added to out[i] as it comes).
    void resolve(Deferred& q, glm::vec3* out, glm::vec3* indirect) const {
        embree.occluded_stream(q.rays.data(), q.rays.size());
        glm::vec3 e(0.0f), reflected(0.0f), group(0.0f), emit(0.0f), beta(0.0f);
        uint8_t target = 0;
        bool first = false;
        size_t path = 0;
        auto sum = [&](uint8_t t) -> glm::vec3& { return t != 0 && indirect ? reflected : e; };
        // The log nests: a path's groups (Group .. EndGroup: its lights and emitter sample) and
        // additions, then EndPath; a path's first item is its first group.
        [[maybe_unused]] bool in_group = false, path_started = false;
        for (const Deferred::Item& it : q.items) {
            assert((it.op == Deferred::Light || it.op == Deferred::Emit ||
                    it.op == Deferred::EndGroup) == in_group);
            assert(it.op != Deferred::Group || it.first == !path_started);
            switch (it.op) {
                case Deferred::Group:
                    in_group = path_started = true;
                    group = glm::vec3(0.0f);
                    emit = glm::vec3(0.0f);
                    beta = it.value;
                    target = it.target;
                    first = it.first;
                    break;
                case Deferred::Light:
                    if (!q.blocked(it.ray)) group += it.value;
                    break;
                case Deferred::Emit:
                    emit = q.blocked(it.ray) ? glm::vec3(0.0f) : it.value;
                    break;
                case Deferred::EndGroup:
                    in_group = false;
                    if (first)
                        e = group + emit;
                    else
                        sum(target) += beta * (group + emit);
                    break;
                case Deferred::Add:
                    sum(it.target) += it.value;
                    break;
                case Deferred::EndPath:
                    path_started = false;
                    out[path] = e;
                    if (indirect) indirect[path] = reflected;
                    e = reflected = glm::vec3(0.0f);
                    ++path;
                    break;
            }
        }
    }

    // Paths from count (point, normal) pairs, in order, with one rng: the shadow rays of all of
    // them traced as one stream.
    void trace_batch(size_t count, const glm::vec3* points, const glm::vec3* normals_in, Pcg32& rng,
                     int bounces, glm::vec3* out, glm::vec3* indirect, uint64_t* rays) const {
        assert(count == 0 || (points != nullptr && normals_in != nullptr && out != nullptr));
        thread_local Deferred q;
        q.clear();
        for (size_t i = 0; i < count; ++i)
            irradiance(points[i], normals_in[i], rng, rays, bounces, q);
        // One EndPath per path: resolve() writes out[0 .. count) and no further.
        assert(size_t(std::count_if(q.items.begin(), q.items.end(), [](const Deferred::Item& it) {
                   return it.op == Deferred::EndPath;
               })) == count);
        resolve(q, out, indirect);
    }

    glm::vec3 irradiance1(const glm::vec3& p, const glm::vec3& n, Pcg32& rng, uint64_t* rays,
                          int bounces, glm::vec3* indirect = nullptr) const {
        glm::vec3 e;
        trace_batch(1, &p, &n, rng, bounces, &e, indirect, rays);
        return e;
    }
};

PathTracer::PathTracer(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
PathTracer::PathTracer(PathTracer&&) noexcept = default;
PathTracer& PathTracer::operator=(PathTracer&&) noexcept = default;
PathTracer::~PathTracer() = default;

Result<PathTracer> PathTracer::build(const Scene& scene, const PathTracerOptions& options) {
    auto impl = std::make_unique<Impl>();
    impl->options = options;
    impl->options.bounces = options.bounces < 0 ? -1 : options.bounces;

    // Textures used as base colour: decoded to linear once.
    std::vector<int> tex_slot(scene.textures.size(), -1);
    for (const Material& sm : scene.materials) {
        TriMaterial m;
        m.albedo = glm::vec3(sm.base_color_factor);
        m.emission = glm::max(sm.emissive_factor, glm::vec3(0.0f));
        m.double_sided = sm.double_sided;
        const int t = sm.base_color_texture;
        if (t >= 0) {
            const Texture* tex = size_t(t) < scene.textures.size() ? &scene.textures[t] : nullptr;
            if (!tex || tex->width <= 0 || tex->height <= 0 ||
                tex->rgba8.size() < size_t(tex->width) * tex->height * 4) {
                impl->warnings.push_back("material '" + sm.name + "': base colour texture " +
                                         std::to_string(t) +
                                         " is missing or empty; using the base colour factor only");
            } else {
                if (tex_slot[t] < 0) {
                    tex_slot[t] = int(impl->textures.size());
                    LinearTexture lt;
                    lt.w = tex->width;
                    lt.h = tex->height;
                    lt.rgb.resize(size_t(lt.w) * lt.h);
                    for (size_t i = 0; i < lt.rgb.size(); ++i)
                        for (int c = 0; c < 3; ++c)
                            lt.rgb[i][c] = srgb_to_linear(tex->rgba8[4 * i + c] / 255.0f);
                    impl->textures.push_back(std::move(lt));
                }
                m.texture = tex_slot[t];
            }
        }
        impl->mats.push_back(m);
    }
    const uint32_t default_mat = uint32_t(impl->mats.size());
    impl->mats.push_back(TriMaterial{});  // glTF default material: white... use 0.8 grey

    impl->lights = detail::world_lights(scene);

    bool first = true;
    for (const SceneObject& obj : flatten_objects(scene)) {
        const Mesh& mesh = scene.meshes[obj.levels[0].mesh];
        for (size_t pi = 0; pi < mesh.primitives.size(); ++pi) {
            const Primitive& prim = mesh.primitives[pi];
            std::vector<glm::vec3> world(prim.positions.size());
            for (size_t i = 0; i < prim.positions.size(); ++i) {
                world[i] = glm::vec3(obj.world * glm::dvec4(glm::dvec3(prim.positions[i]), 1.0));
                if (!std::isfinite(world[i].x) || !std::isfinite(world[i].y) ||
                    !std::isfinite(world[i].z))
                    return make_error("mesh '" + mesh.name + "' primitive " + std::to_string(pi) +
                                      " vertex " + std::to_string(i) +
                                      " has a non-finite position");
                if (first) {
                    impl->lo = impl->hi = world[i];
                    first = false;
                }
                impl->lo = glm::min(impl->lo, world[i]);
                impl->hi = glm::max(impl->hi, world[i]);
            }
            const uint32_t mat =
                prim.material >= 0 && size_t(prim.material) < scene.materials.size()
                    ? uint32_t(prim.material)
                    : default_mat;
            const bool has_uv = prim.uv0.size() == prim.positions.size();
            for (size_t t = 0; t + 2 < prim.indices.size(); t += 3) {
                uint32_t ia = prim.indices[t], ib = prim.indices[t + 1], ic = prim.indices[t + 2];
                if (ia >= world.size() || ib >= world.size() || ic >= world.size()) continue;
                glm::vec3 cr = glm::cross(world[ib] - world[ia], world[ic] - world[ia]);
                float len = glm::length(cr);
                if (!(len > 0.0f)) continue;  // degenerate: never hit, never sampled
                impl->corners.insert(impl->corners.end(), {world[ia], world[ib], world[ic]});
                impl->normals.push_back(cr / len);
                impl->areas.push_back(0.5f * len);
                if (has_uv)
                    impl->uv0.insert(impl->uv0.end(), {prim.uv0[ia], prim.uv0[ib], prim.uv0[ic]});
                else
                    impl->uv0.insert(impl->uv0.end(), 3, glm::vec2(0.0f));
                impl->material.push_back(mat);
            }
        }
    }
    // One entry per kept triangle in every per-triangle array (3 for corners and uv0).
    assert(impl->corners.size() == 3 * impl->material.size() &&
           impl->uv0.size() == impl->corners.size() &&
           impl->normals.size() == impl->material.size() &&
           impl->areas.size() == impl->material.size());
    const glm::vec3 extent = impl->hi - impl->lo;
    impl->offset_scale = 2e-5f;
    (void)extent;

    // Emitter distribution by power (luminance x area).
    const size_t tris = impl->material.size();
    std::vector<double> power;
    for (size_t t = 0; t < tris; ++t) {
        assert(impl->material[t] < impl->mats.size());
        const glm::vec3& le = impl->mats[impl->material[t]].emission;
        double lum = 0.2126 * le.r + 0.7152 * le.g + 0.0722 * le.b;
        if (lum > 0.0) {
            impl->emitters.push_back(uint32_t(t));
            power.push_back(lum * impl->areas[t]);
        }
    }
    if (!impl->emitters.empty()) {
        double total = 0.0;
        for (double p : power) total += p;
        impl->emitter_pdf_area.assign(tris, 0.0f);
        double acc = 0.0;
        for (size_t k = 0; k < impl->emitters.size(); ++k) {
            acc += power[k];
            // The cdf rises (power > 0 per emitter), so lower_bound finds the sampled one.
            assert(impl->emitter_cdf.empty() || float(acc / total) >= impl->emitter_cdf.back());
            impl->emitter_cdf.push_back(float(acc / total));
            const uint32_t t = impl->emitters[k];
            impl->emitter_pdf_area[t] = float(power[k] / total / impl->areas[t]);
        }
        impl->emitter_cdf.back() = 1.0f;
    }

    if (Status st = impl->embree.build(impl->corners); !st) return st.error();
    return PathTracer(std::move(impl));
}

glm::vec3 PathTracer::irradiance(const glm::vec3& p, const glm::vec3& n, Pcg32& rng,
                                 uint64_t* rays) const {
    return impl_->irradiance1(p, n, rng, rays, impl_->options.bounces);
}

glm::vec3 PathTracer::irradiance_split(const glm::vec3& p, const glm::vec3& n, Pcg32& rng,
                                       glm::vec3& indirect, uint64_t* rays) const {
    return impl_->irradiance1(p, n, rng, rays, impl_->options.bounces, &indirect);
}

void PathTracer::irradiance_batch(size_t count, const glm::vec3* points, const glm::vec3* normals,
                                  Pcg32& rng, glm::vec3* out, glm::vec3* indirect,
                                  uint64_t* rays) const {
    impl_->trace_batch(count, points, normals, rng, impl_->options.bounces, out, indirect, rays);
}

glm::vec3 PathTracer::direct_irradiance(const glm::vec3& p, const glm::vec3& n, Pcg32& rng,
                                        uint64_t* rays) const {
    return impl_->irradiance1(p, n, rng, rays, 0);
}

glm::vec3 PathTracer::radiance(const glm::vec3& origin, const glm::vec3& dir, Pcg32& rng,
                               uint64_t* rays) const {
    if (rays) ++*rays;
    std::optional<TraceHit> h =
        impl_->intersect(origin, dir, 0.0f, std::numeric_limits<float>::infinity());
    if (!h) return impl_->options.sky_radiance;
    const TriMaterial& m = impl_->mats[impl_->material[h->triangle]];
    if (!h->front && !m.double_sided) return glm::vec3(0.0f);
    const glm::vec3 ns = h->front ? h->face_normal : -h->face_normal;
    const glm::vec3 x = origin + dir * h->t;
    const glm::vec3 a = impl_->albedo(h->triangle, h->u, h->v);
    glm::vec3 l = m.emission;
    if (max3(a) > 0.0f)
        l += a / kPiF * impl_->irradiance1(x, ns, rng, rays, impl_->options.bounces);
    return l;
}

std::optional<TraceHit> PathTracer::intersect(const glm::vec3& origin, const glm::vec3& dir,
                                              float t_near, float t_far) const {
    return impl_->intersect(origin, dir, t_near, t_far);
}

void PathTracer::intersect_batch(size_t count, const TraceQuery* rays,
                                 std::optional<TraceHit>* out) const {
    impl_->intersect_batch(count, rays, out);
}

bool PathTracer::find_back_face_there(const glm::vec3& origin, const glm::vec3& dir,
                                      TraceHit& h) const {
    if (h.back_face_there || (!h.front && !h.double_sided)) return h.back_face_there;
    const float eps = impl_->offset(origin + dir * h.t);
    std::optional<detail::EmbreeHit> other = impl_->embree.intersect_skipping(
        origin, dir, std::max(0.0f, h.t - eps), h.t + eps, h.triangle);
    h.back_face_there = other && glm::dot(impl_->normals[other->prim], dir) >= 0.0f &&
                        !impl_->mats[impl_->material[other->prim]].double_sided;
    return h.back_face_there;
}

bool PathTracer::occluded(const glm::vec3& origin, const glm::vec3& dir, float t_near,
                          float t_far) const {
    return impl_->embree.occluded(origin, dir, t_near, t_far);
}

float PathTracer::ray_offset(const glm::vec3& p) const {
    return impl_->offset(p);
}
size_t PathTracer::triangle_count() const {
    return impl_->material.size();
}
size_t PathTracer::emissive_triangle_count() const {
    return impl_->emitters.size();
}
size_t PathTracer::punctual_light_count() const {
    return impl_->lights.size();
}
bool PathTracer::has_light() const {
    return !impl_->lights.empty() || !impl_->emitters.empty() ||
           max3(impl_->options.sky_radiance) > 0.0f;
}
float PathTracer::mean_albedo() const {
    std::vector<glm::vec3> texture_mean(impl_->textures.size(), glm::vec3(1.0f));
    for (size_t i = 0; i < impl_->textures.size(); ++i) {
        const LinearTexture& t = impl_->textures[i];
        glm::dvec3 sum(0.0);
        for (const glm::vec3& c : t.rgb) sum += glm::dvec3(c);
        if (!t.rgb.empty()) texture_mean[i] = glm::vec3(sum / double(t.rgb.size()));
    }
    double weighted = 0.0, area = 0.0;
    for (size_t tri = 0; tri < impl_->areas.size(); ++tri) {
        const TriMaterial& m = impl_->mats[impl_->material[tri]];
        const glm::vec3 a = m.texture >= 0 ? m.albedo * texture_mean[size_t(m.texture)] : m.albedo;
        weighted += double(impl_->areas[tri]) * double(max3(a));
        area += double(impl_->areas[tri]);
    }
    return area > 0.0 ? float(weighted / area) : 0.0f;
}
const PathTracerOptions& PathTracer::options() const {
    return impl_->options;
}
glm::vec3 PathTracer::bounds_min() const {
    return impl_->lo;
}
glm::vec3 PathTracer::bounds_max() const {
    return impl_->hi;
}
const std::vector<std::string>& PathTracer::warnings() const {
    return impl_->warnings;
}

ReplayTiming PathTracer::replay_rays(const std::vector<RecordedRay>& rays, int threads,
                                     ReplayMode mode) const {
    return detail::replay(impl_->embree, rays, threads, mode);
}

double PathTracer::raw_rays_per_second(size_t count, int threads, uint64_t seed) const {
    const glm::vec3 lo = impl_->lo, ext = impl_->hi - impl_->lo;
    std::atomic<uint64_t> hits{0};
    const size_t chunk = 4096;
    const size_t chunks = (count + chunk - 1) / chunk;
    auto t0 = std::chrono::steady_clock::now();
    parallel_for(chunks, threads, 1, [&](size_t c, int) {
        Pcg32 rng(seed, c);
        uint64_t h = 0;
        const size_t end = std::min(count, (c + 1) * chunk);
        for (size_t i = c * chunk; i < end; ++i) {
            glm::vec3 o = lo + ext * glm::vec3(rng.uniform(), rng.uniform(), rng.uniform());
            float z = 1.0f - 2.0f * rng.uniform(), phi = 2.0f * kPiF * rng.uniform();
            float r = std::sqrt(std::max(0.0f, 1.0f - z * z));
            glm::vec3 d(r * std::cos(phi), r * std::sin(phi), z);
            if (impl_->embree.intersect(o, d, 0.0f, std::numeric_limits<float>::infinity())) ++h;
        }
        hits += h;
    });
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return s > 0.0 ? double(count) / s : 0.0;
}

}  // namespace hmdnode
