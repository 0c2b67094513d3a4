// The bake pipeline (bake.hpp): the order of the passes and their bookkeeping; each pass is its own
// file (uv_atlas, texel_raster, texel_validity, path_tracer, atrous_denoise, dilate, seam_blend,
// lightmap_encode, vertex_bake). Monte Carlo estimation of the texel mean irradiance: N paths per
// texel, path j starting at the texel's sample j mod S (S stratified sample points), so the texel's
// area is covered evenly (stratified sampling, A. B. Owen, "Monte Carlo theory, methods and
// examples", 2013, ch. 10).
// Cost: O(texels x samples x bounces) rays; memory O(texels) per map.
#include "hmdnode/bake/bake.hpp"

#include <algorithm>
#include <atomic>
#include <cassert>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <set>
#include <string>

#include "hmdnode/bake/lightmap_encode.hpp"
#include "hmdnode/bake/path_tracer.hpp"
#include "hmdnode/bake/texel_raster.hpp"
#include "hmdnode/bake/uv_atlas.hpp"
#include "hmdnode/bake/vertex_bake.hpp"
#include "lightmap_passes.hpp"

namespace hmdnode {
namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) {
    return std::chrono::duration<double>(Clock::now() - t0).count();
}

uint64_t mix(uint64_t a, uint64_t b) {
    uint64_t z = a * 0x9e3779b97f4a7c15ULL + b + 0x632be59bd9b4e019ULL;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
}

bool has_lightmap(const Scene& scene, const Primitive& prim) {
    return prim.material >= 0 && size_t(prim.material) < scene.materials.size() &&
           scene.materials[prim.material].lightmap.texture >= 0 &&
           prim.uv1.size() == prim.positions.size();
}

float luminance(const glm::vec3& c) {
    return 0.2126f * c.r + 0.7152f * c.g + 0.0722f * c.b;
}

// Winsorises outliers: every sample brighter than `factor` x the mean luminance of the others
// (all but the brightest) is scaled down to that. Biased (dark), but only for rare, very bright
// paths -- the fireflies of low sample counts (e.g. a bounce that finds a lamp's hot shade). The
// bake applies it to the indirect part of each path; at factor 8 its bias in the furnace is
// <= 0.1 % (Bake.FireflyClampBiasIsUnderHalfAPercentInTheFurnace; factor 4: up to 2.3 %).
void clamp_fireflies(std::vector<glm::vec3>& values, float factor) {
    assert(values.size() >= 2 && factor > 0.0f);  // the mean of the others needs one other
    size_t brightest = 0;
    double total = 0.0;
    for (size_t i = 0; i < values.size(); ++i) {
        total += luminance(values[i]);
        if (luminance(values[i]) > luminance(values[brightest])) brightest = i;
    }
    const double others = (total - luminance(values[brightest])) / double(values.size() - 1);
    if (!(others > 0.0)) return;
    const float limit = float(factor * others);
    for (glm::vec3& v : values) {
        const float l = luminance(v);
        if (l > limit) v *= limit / l;
    }
}

// Mean and variance (of one path) of a texel's paths, the variance on luminance.
struct Moments {
    glm::vec3 mean{0.0f};
    double var = 0.0;
};
Moments moments(const std::vector<glm::vec3>& values) {
    assert(!values.empty());
    Moments m;
    double l1 = 0.0, l2 = 0.0;
    for (const glm::vec3& v : values) {
        m.mean += v;
        const double l = luminance(v);
        l1 += l;
        l2 += l * l;
    }
    const double count = double(std::max<size_t>(1, values.size()));
    m.mean /= float(count);
    m.var = std::max(0.0, l2 / count - (l1 / count) * (l1 / count));
    return m;
}

// Lights must be physical: a negative (or non-finite) intensity, colour or range would bake
// black or nonsense without a word.
Status check_lights(const Scene& scene) {
    for (size_t i = 0; i < scene.lights.size(); ++i) {
        const Light& l = scene.lights[i];
        const std::string name = "light " + std::to_string(i) + " '" + l.name + "'";
        if (!std::isfinite(l.intensity) || l.intensity < 0.0f)
            return make_error(name + ": intensity " + std::to_string(l.intensity) +
                              " is not a finite number >= 0");
        for (int c = 0; c < 3; ++c)
            if (!std::isfinite(l.color[c]) || l.color[c] < 0.0f)
                return make_error(name + ": colour component " + std::to_string(c) + " = " +
                                  std::to_string(l.color[c]) + " is not a finite number >= 0");
        if (!std::isfinite(l.range) || l.range < 0.0f)
            return make_error(name + ": range " + std::to_string(l.range) +
                              " is not a finite number >= 0 (0: infinite)");
    }
    return {};
}

// Something must light the scene: a light, a used emissive material or the sky.
Status check_light_sources(const Scene& scene, const BakeOptions& options, BakeReport& report) {
    // Emissive materials that the traced geometry (level 0 of every object) uses: only those
    // light the scene; an unused one is a warning.
    std::vector<uint8_t> used(scene.materials.size(), 0);
    for (const SceneObject& obj : flatten_objects(scene))
        for (const Primitive& prim : scene.meshes[size_t(obj.levels[0].mesh)].primitives)
            if (prim.material >= 0 && size_t(prim.material) < used.size())
                used[size_t(prim.material)] = 1;
    bool emissive = false;
    for (size_t i = 0; i < scene.materials.size(); ++i) {
        const Material& m = scene.materials[i];
        if (!(m.emissive_factor.r > 0.0f || m.emissive_factor.g > 0.0f ||
              m.emissive_factor.b > 0.0f))
            continue;
        if (used[i])
            emissive = true;
        else
            report.warnings.push_back("material " + std::to_string(i) + " '" + m.name +
                                      "' is emissive but no mesh of the traced geometry (level "
                                      "0 of every object) uses it: it lights nothing");
    }
    const bool sky = options.sky_radiance.r > 0.0f || options.sky_radiance.g > 0.0f ||
                     options.sky_radiance.b > 0.0f;
    if (scene.lights.empty() && !emissive && !sky) {
        std::string why =
            "nothing to bake: the scene has no KHR_lights_punctual light, no emissive material "
            "that a mesh uses, and the sky is black (give --sky R,G,B or add a light)";
        for (const std::string& w : report.warnings) why += "; " + w;
        return make_error(why);
    }
    return {};
}

// 3. Atlas.
Status build_atlas(Scene& scene, const BakeOptions& options, BakeReport& report) {
    if (options.vertex || !(options.texels_per_metre > 0.0)) return {};
    AtlasOptions ao;
    ao.texels_per_metre = options.texels_per_metre;
    Result<AtlasReport> atlas = build_uv_atlas(scene, ao);
    if (!atlas) return atlas.error();
    for (const std::string& s : atlas->kept_without_lightmap)
        report.warnings.push_back(s +
                                  " keeps its TEXCOORD_1 but has no lightmap material: "
                                  "baked as vertex colours");
    return {};
}

void warn_bounce_limit(const PathTracer& tracer, const BakeOptions& options, BakeReport& report) {
    if (options.bounces < 0) return;
    // A closed scene of albedo rho keeps sum_k rho^k of the light; n reflections keep the
    // first n + 1 terms and drop rho^(n+1) of it (less in open scenes, where light escapes).
    const double rho = tracer.mean_albedo();
    const double dropped = std::pow(rho, options.bounces + 1);
    if (dropped > 0.02) {
        char buf[320];
        std::snprintf(buf, sizeof buf,
                      "bounces %d drops up to %.1f %% of the light (rho^%d with the scene's "
                      "area-weighted mean albedo rho = %.2f); leave the bounce limit out to "
                      "let Russian roulette end the paths (unbiased)",
                      options.bounces, 100.0 * dropped, options.bounces + 1, rho);
        report.warnings.push_back(buf);
    }
}

struct VertexJob {
    Primitive* prim;
    glm::dmat4 world;
    float lift;
    std::vector<std::pair<glm::vec3, glm::vec3>> queries;  // (point, normal)
};

// The vertex bake's jobs: every primitive without a lightmap, once per mesh, with the queries of
// a dry run of its fit.
Result<std::vector<VertexJob>> record_vertex_jobs(Scene& scene) {
    std::vector<VertexJob> vertex_jobs;
    std::set<int> done_meshes;
    for (const SceneObject& obj : flatten_objects(scene)) {
        for (size_t li = 0; li < obj.levels.size(); ++li) {
            const LodLevel& level = obj.levels[li];
            if (!done_meshes.insert(level.mesh).second) continue;
            // A coarse level's surface lies within its geometric error of level 0 (the traced
            // geometry), often inside it: its points are lifted by twice that error along the
            // normal before tracing, so that level 0 does not shadow them.
            const float lift = li == 0 ? 0.0f : float(2.0 * level.geometric_error_m);
            for (Primitive& prim : scene.meshes[level.mesh].primitives) {
                if (has_lightmap(scene, prim) || prim.positions.empty()) continue;
                VertexJob job{&prim, obj.world, lift, {}};
                IrradianceOracle record = [&](const glm::vec3& p, const glm::vec3& n) {
                    job.queries.emplace_back(p, n);
                    return glm::vec3(0.0f);
                };
                Result<std::vector<glm::vec3>> dry =
                    vertex_irradiance_least_squares(prim, obj.world, record, 2);
                if (!dry) return dry.error();
                vertex_jobs.push_back(std::move(job));
            }
        }
    }
    return vertex_jobs;
}

// Progress = paths traced / paths to trace (the validity pass, denoising and encoding, a
// small part of the time, are not counted).
class PathProgress {
  public:
    PathProgress(const BakeProgress& progress, uint64_t total_paths)
        : progress_(progress), total_paths_(total_paths) {}

    // `paths` more traced; reported from the calling thread (parallel_for's 0).
    void add(uint64_t paths, int thread) {
        paths_done_ += paths;
        if (thread != 0 || !progress_) return;
        const double frac = double(paths_done_) / double(std::max<uint64_t>(1, total_paths_));
        if (frac - last_report_ >= 0.002) {
            last_report_ = frac;
            progress_(std::min(1.0, frac));
        }
    }

  private:
    const BakeProgress& progress_;
    const uint64_t total_paths_;
    std::atomic<uint64_t> paths_done_{0};
    double last_report_ = -1.0;
};

// What every pass of the lightmaps and the vertex bake uses.
struct BakeContext {
    Scene& scene;
    const BakeOptions& options;
    const PathTracer& tracer;
    PathProgress& paths;
    std::atomic<uint64_t>& total_rays;
};

// Per texel of one map: the parts of its mean, their noise, its mean normal and position.
struct TexelTrace {
    explicit TexelTrace(size_t n)
        : direct(n, glm::vec3(0.0f)),
          indirect(n, glm::vec3(0.0f)),
          stddev(n, 0.0f),
          direct_stddev(n, 0.0f),
          indirect_var(n, 0.0f),
          normals(n, glm::vec3(0.0f)),
          positions(n, glm::vec3(0.0f)),
          rays(n, 0) {}
    std::vector<glm::vec3> direct, indirect;
    std::vector<float> stddev, direct_stddev, indirect_var;
    std::vector<glm::vec3> normals, positions;
    std::vector<uint64_t> rays;
};

// Validity and push-off. Returns per texel the samples outside every solid (first); empty
// without validity rays.
std::vector<uint32_t> texel_validity(const BakeContext& ctx, TexelRaster& r, size_t mi,
                                     BakedMap& map) {
    const BakeOptions& options = ctx.options;
    const size_t n = size_t(r.width) * r.height;
    std::vector<uint32_t> visible;
    if (options.validity_rays > 0) {
        detail::ValidityResult v = detail::fix_texel_validity(
            r, ctx.tracer, options.validity_rays, options.validity_threshold, options.threads,
            mix(options.seed, 0x76616c6964ULL + mi));
        map.valid = std::move(v.valid);
        visible = std::move(v.visible);
        map.invalid = v.invalid;
        map.pushed_samples = v.pushed;
        map.buried_samples = v.buried;
        ctx.total_rays += v.rays;
    } else {
        map.valid.assign(n, 0);
        for (size_t i = 0; i < n; ++i) map.valid[i] = r.is_covered(i) ? 1 : 0;
    }
    return visible;
}

// The paths of one valid texel, from its samples [b, e).
void trace_texel_paths(const BakeContext& ctx, const TexelRaster& r, uint32_t b, uint32_t e,
                       size_t mi, size_t texel, BakedMap& map, TexelTrace& t) {
    const BakeOptions& options = ctx.options;
    const int samples = options.samples;
    const bool clamp = options.firefly_factor > 0.0f && samples >= 4;
    // A valid texel's visible samples: at least one, within the raster.
    assert(samples >= 1 && b < e && e <= r.samples.size() && texel < t.rays.size());
    Pcg32 rng(options.seed, mix(mi + 1, texel));
    uint64_t rc = 0;
    thread_local std::vector<glm::vec3> dv, iv, sp, sn;
    dv.resize(size_t(samples));
    iv.resize(size_t(samples));
    sp.resize(size_t(samples));
    sn.resize(size_t(samples));
    for (int j = 0; j < samples; ++j) {
        const TexelSample& s = r.samples[b + uint32_t(j) % (e - b)];
        sp[size_t(j)] = s.position;
        sn[size_t(j)] = s.normal;
    }
    // The texel's paths as one batch: their shadow rays go to Embree together.
    ctx.tracer.irradiance_batch(size_t(samples), sp.data(), sn.data(), rng, dv.data(), iv.data(),
                                &rc);
    auto finite = [](glm::vec3& v) {
        if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z)) v = glm::vec3(0.0f);
    };
    for (int j = 0; j < samples; ++j) {
        finite(dv[size_t(j)]);
        finite(iv[size_t(j)]);
    }
    if (clamp && options.firefly_indirect_only) {
        clamp_fireflies(iv, options.firefly_factor);
    } else if (clamp) {  // the whole path (before the split; kept to compare)
        for (int j = 0; j < samples; ++j) dv[j] += iv[j], iv[j] = glm::vec3(0.0f);
        clamp_fireflies(dv, options.firefly_factor);
    }
    const Moments md = moments(dv), mi_ = moments(iv);
    std::vector<glm::vec3>& tv = dv;  // totals, for the one-pass filter
    for (int j = 0; j < samples; ++j) tv[j] += iv[j];
    const Moments mt = moments(tv);
    t.direct[texel] = md.mean;
    t.indirect[texel] = mi_.mean;
    map.raw[texel] = mt.mean;
    t.stddev[texel] = float(std::sqrt(mt.var / samples));
    t.direct_stddev[texel] = float(std::sqrt(md.var / samples));
    t.indirect_var[texel] = float(mi_.var / samples);
    t.rays[texel] = rc;
}

// Trace: per texel the mean of its paths, its direct and indirect parts apart (the
// firefly clamp and the second filter pass act on the indirect part only).
void trace_map(const BakeContext& ctx, const TexelRaster& r, const std::vector<uint32_t>& visible,
               size_t mi, BakedMap& map, TexelTrace& t) {
    const size_t n = size_t(r.width) * r.height;
    assert(r.first.size() == n + 1 && r.first.back() == r.samples.size());
    assert(map.valid.size() == n && t.normals.size() == n &&
           (visible.empty() || visible.size() == n));
    map.raw.assign(n, glm::vec3(0.0f));
    const int samples = ctx.options.samples;
    parallel_for(n, ctx.options.threads, 16, [&](size_t texel, int thread) {
        const uint32_t b = r.first[texel], e_all = r.first[texel + 1];
        assert(b <= e_all);  // CSR offsets rise
        if (b == e_all) return;
        assert(visible.empty() || visible[texel] <= e_all - b);
        glm::vec3 nsum(0.0f), psum(0.0f);
        for (uint32_t s = b; s < e_all; ++s) {
            nsum += r.samples[s].normal;
            psum += r.samples[s].position;
        }
        const float nl = glm::length(nsum);
        t.normals[texel] = nl > 0.0f ? nsum / nl : r.samples[b].face_normal;
        t.positions[texel] = psum / float(e_all - b);
        // Paths start at the visible samples only (buried ones come last).
        const uint32_t e = !visible.empty() && visible[texel] > 0 ? b + visible[texel] : e_all;
        if (map.valid[texel]) trace_texel_paths(ctx, r, b, e, mi, texel, map, t);
        ctx.paths.add(uint64_t(samples), thread);
    });
    for (uint64_t x : t.rays) ctx.total_rays += x;
}

// Denoise the valid texels (fills map.final_e).
void denoise_map(const BakeOptions& options, const TexelRaster& r, BakedMap& map, TexelTrace& t) {
    const size_t n = size_t(r.width) * r.height;
    assert(map.raw.size() == n && map.valid.size() == n && r.texel_size_m.size() == n);
    map.final_e = map.raw;
    if (options.denoise_iterations <= 0) return;
    double size_sum = 0.0;
    size_t size_n = 0;
    for (size_t i = 0; i < n; ++i)
        if (map.valid[i]) {
            size_sum += r.texel_size_m[i];
            ++size_n;
        }
    const float texel_m = size_n ? float(size_sum / size_n) : 0.01f;
    if (options.indirect_denoise_iterations > 0) {
        // Direct light: sharp shadows, little noise; indirect: smooth, noisy.
        detail::atrous_denoise(t.direct, map.valid, t.normals, t.positions, t.direct_stddev,
                               r.width, r.height, options.denoise_iterations, 2.0f * texel_m, 4.0f);
        detail::variance_atrous(t.indirect, t.indirect_var, map.valid, t.normals, t.positions,
                                r.width, r.height, options.indirect_denoise_iterations, texel_m,
                                4.0f);
        for (size_t i = 0; i < n; ++i)
            if (map.valid[i]) map.final_e[i] = t.direct[i] + t.indirect[i];
    } else {
        detail::atrous_denoise(map.final_e, map.valid, t.normals, t.positions, t.stddev, r.width,
                               r.height, options.denoise_iterations, 2.0f * texel_m, 4.0f);
    }
}

// Fill invalid and gutter texels, then blend the seams. Returns the texels that have a value.
std::vector<uint8_t> fill_map(Scene& scene, const BakeOptions& options, const TexelRaster& r,
                              BakedMap& map) {
    const size_t n = size_t(r.width) * r.height;
    assert(map.final_e.size() == n && map.valid.size() == n);
    std::vector<uint8_t> filled = map.valid;
    // Invalid texels inside charts: fill until done (bounded by the map size).
    std::vector<uint8_t> want(n, 0);
    for (size_t i = 0; i < n; ++i) want[i] = r.is_covered(i) && !map.valid[i];
    size_t rings = 0;
    for (bool more = map.invalid > 0; more && rings < size_t(r.width + r.height); ++rings) {
        map.dilated += detail::dilate(map.final_e, filled, r.width, r.height, 1);
        more = false;
        for (size_t i = 0; i < n && !more; ++i) more = want[i] && !filled[i];
    }
    map.dilated +=
        detail::dilate(map.final_e, filled, r.width, r.height, std::max(0, options.dilate_rings));
    for (size_t i = 0; i < n; ++i)
        if (!filled[i]) map.final_e[i] = glm::vec3(0.0f);
    if (options.seam_iterations > 0)
        map.seams = detail::blend_seams(scene, r.texture, map.final_e, r.width, r.height,
                                        options.seam_iterations);
    return filled;
}

// Encode: PNG-able RGBA8 + intensity in the glTF, EXR master beside the output.
Status encode_map(Scene& scene, const BakeOptions& options, const TexelRaster& r, size_t mi,
                  const std::vector<uint8_t>& filled, BakedMap& map) {
    HdrImage img;
    img.width = r.width;
    img.height = r.height;
    img.rgb = map.final_e;
    Result<float> intensity = store_lightmap(scene, r.texture, img, options.intensity_percentile,
                                             filled, options.lightmap_encoding);
    if (!intensity) return intensity.error();
    map.intensity = *intensity;
    if (!options.exr_prefix.empty()) {
        map.exr = options.exr_prefix + std::to_string(mi) + ".exr";
        if (Status st = write_exr(map.exr, img); !st) return st.error();
    }
    return {};
}

// 5. Lightmaps: one map per raster.
Status bake_lightmap(const BakeContext& ctx, TexelRaster& r, size_t mi, BakeReport& report) {
    const size_t n = size_t(r.width) * r.height;
    BakedMap map;
    map.texture = r.texture;
    map.width = r.width;
    map.height = r.height;
    map.covered = r.covered;
    const std::vector<uint32_t> visible = texel_validity(ctx, r, mi, map);
    TexelTrace t(n);
    trace_map(ctx, r, visible, mi, map, t);
    denoise_map(ctx.options, r, map, t);
    const std::vector<uint8_t> filled = fill_map(ctx.scene, ctx.options, r, map);
    if (Status s = encode_map(ctx.scene, ctx.options, r, mi, filled, map); !s) return s;
    report.texels += r.covered;
    report.maps.push_back(std::move(map));
    return {};
}

// 6. Vertex light for a primitive without a lightmap: the recorded queries are traced in
// parallel, then the fit runs again with the answers replayed in the same order.
Status bake_vertex_job(const BakeContext& ctx, VertexJob& job, int vsamples, uint64_t query_base,
                       BakeReport& report) {
    const BakeOptions& options = ctx.options;
    std::vector<glm::vec3> answers(job.queries.size());
    std::vector<uint64_t> rays(job.queries.size(), 0);
    parallel_for(job.queries.size(), options.threads, 16, [&](size_t q, int thread) {
        Pcg32 rng(options.seed, mix(0x7665727465ULL, query_base + q));
        const glm::vec3 p = job.queries[q].first + job.queries[q].second * job.lift;
        thread_local std::vector<glm::vec3> ps, ns, es;
        ps.assign(size_t(vsamples), p);
        ns.assign(size_t(vsamples), job.queries[q].second);
        es.resize(size_t(vsamples));
        ctx.tracer.irradiance_batch(size_t(vsamples), ps.data(), ns.data(), rng, es.data(), nullptr,
                                    &rays[q]);
        glm::vec3 sum(0.0f);
        for (const glm::vec3& x : es) sum += x;
        answers[q] = sum / float(vsamples);
        ctx.paths.add(uint64_t(vsamples), thread);
    });
    for (uint64_t x : rays) ctx.total_rays += x;
    size_t next = 0;
    IrradianceOracle replay = [&](const glm::vec3&, const glm::vec3&) {
        return next < answers.size() ? answers[next++] : glm::vec3(0.0f);
    };
    Primitive& prim = *job.prim;
    Result<std::vector<glm::vec3>> e = vertex_irradiance_least_squares(prim, job.world, replay, 2);
    if (!e) return e.error();
    // The fit asked the same queries, in the same order, as the dry run that recorded them.
    assert(next == answers.size() && e->size() == prim.positions.size());
    prim.light.resize(prim.positions.size());
    for (size_t i = 0; i < prim.positions.size(); ++i)
        prim.light[i] = glm::max((*e)[i], glm::vec3(0.0f));
    report.vertices += prim.positions.size();
    return {};
}

}  // namespace

Result<BakeReport> bake_scene(Scene& scene, const BakeOptions& options,
                              const BakeProgress& progress) {
    const Clock::time_point t0 = Clock::now();
    BakeReport report;
    if (options.samples < 1) return make_error("samples must be >= 1");
    if (Status s = check_lights(scene); !s) return s.error();
    if (Status s = check_light_sources(scene, options, report); !s) return s.error();

    // 1. Tracer, on the geometry as given (double-sided surfaces as one sheet).
    PathTracerOptions po;
    po.sky_radiance = options.sky_radiance;
    po.bounces = options.bounces;
    Result<PathTracer> built = PathTracer::build(scene, po);
    if (!built) return built.error();
    const PathTracer& tracer = *built;
    report.triangles = tracer.triangle_count();
    for (const std::string& w : tracer.warnings()) report.warnings.push_back(w);

    // 2. Two-sided surfaces: a front and a back sheet, each lit from its own side (two_sided.cpp),
    // except where an input lightmap is kept (it has texels for one side only).
    if (options.two_sided)
        report.two_sided_primitives = detail::split_two_sided(
            scene, [&](const Primitive& p) { return !options.vertex && has_lightmap(scene, p); });

    // 3. Atlas (build_atlas).
    if (Status s = build_atlas(scene, options, report); !s) return s.error();
    warn_bounce_limit(tracer, options, report);

    const Clock::time_point t_trace0 = Clock::now();
    std::atomic<uint64_t> total_rays{0};

    // 4. The work, known before any path is traced so that the progress covers all of it: the
    // lightmaps' texels and the vertex bake's irradiance queries. The vertex queries are recorded
    // by a dry run of the least-squares fit (it calls its oracle in a deterministic order).
    if (options.vertex)
        for (Material& m : scene.materials) m.lightmap.texture = -1;
    std::vector<TexelRaster> rasters;
    if (!options.vertex) {
        Result<std::vector<TexelRaster>> r = rasterize_texels(scene, options.strata);
        if (!r) return r.error();
        rasters = std::move(*r);
    }
    Result<std::vector<VertexJob>> jobs = record_vertex_jobs(scene);
    if (!jobs) return jobs.error();
    std::vector<VertexJob>& vertex_jobs = *jobs;
    const int vsamples = options.vertex_samples > 0 ? options.vertex_samples : options.samples;
    uint64_t total_paths = 0;
    for (const TexelRaster& r : rasters) total_paths += uint64_t(r.covered) * options.samples;
    for (const VertexJob& j : vertex_jobs) total_paths += uint64_t(j.queries.size()) * vsamples;
    PathProgress paths(progress, total_paths);
    const BakeContext ctx{scene, options, tracer, paths, total_rays};

    // 5. Lightmaps (bake_lightmap).
    if (!options.vertex)
        for (size_t mi = 0; mi < rasters.size(); ++mi)
            if (Status s = bake_lightmap(ctx, rasters[mi], mi, report); !s) return s.error();

    // 6. Vertex light (bake_vertex_job).
    uint64_t query_base = 0;
    for (VertexJob& job : vertex_jobs) {
        if (Status s = bake_vertex_job(ctx, job, vsamples, query_base, report); !s)
            return s.error();
        query_base += job.queries.size();
    }
    if (progress) progress(1.0);
    report.rays = total_rays;
    report.trace_seconds = seconds_since(t_trace0);
    report.rays_per_second =
        report.trace_seconds > 0.0 ? double(report.rays) / report.trace_seconds : 0.0;
    report.seconds = seconds_since(t0);
    return report;
}

}  // namespace hmdnode
