// The bake pipeline (docs/baking.md): UV atlas -> texel rasterisation -> texel validity /
// back-face push-off -> path-traced irradiance per texel -> dilation of invalid and gutter texels
// -> edge-aware A-trous denoise -> seam blending -> encoding (EXR master + RGBM PNG in the glTF
// with MOZ_lightmap.intensity), and per-vertex _LIGHT_0 for the primitives without a lightmap (or
// all, with `vertex`).
//
// Stored quantity: linear irradiance E (RGBM texel x intensity); the renderer's diffuse is
// albedo x E / pi (docs/formats.md). Vertex light: _LIGHT_0 = E (float, Primitive::light).
//
// Deterministic: texel t of map m draws its random numbers from Pcg32(seed, hash(m, t)), so a
// given seed gives the same result for any thread count.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "hmdnode/core/result.hpp"
#include "hmdnode/core/scene.hpp"

namespace hmdnode {

struct BakeOptions {
    double texels_per_metre = 0.0;  // > 0: build a UV atlas for primitives without uv1 / lightmap
    int samples = 64;               // paths per texel (>= 1)
    // Reflections at most (>= 0); < 0 (the default): no limit, Russian roulette ends each path
    // (unbiased). A limit that drops more than 2 % of the light by the estimate rho^(bounces+1)
    // (rho: PathTracer::mean_albedo) is a warning.
    int bounces = -1;
    int threads = 0;  // 0: all cores
    uint64_t seed = 1;
    // Double-sided materials: a front and a back sheet, each with its own texels (or vertex
    // light), the material made single-sided so renderers pick the side by culling. Primitives
    // that keep an input lightmap stay as they are.
    bool two_sided = true;
    bool vertex = false;  // per-vertex _LIGHT_0 for every primitive, no lightmaps
    glm::vec3 sky_radiance{0.0f};
    int strata = 2;                   // n x n candidate sample points per texel
    int validity_rays = 8;            // per sample (0: no validity pass)
    float validity_threshold = 0.1f;  // invalid when more of its rays see back faces (Unity's
                                      // default backface tolerance 0.9)
    int dilate_rings = 4;
    int denoise_iterations = 3;  // 0: off (no filter at all)
    // > 0: the direct and the indirect light are filtered apart, the direct light by the
    // edge-aware A-trous above (denoise_iterations passes) and the indirect light, which is smooth
    // but noisy, by a variance-guided A-trous (SVGF's, this many passes); 0: one edge-aware A-trous
    // over their sum.
    int indirect_denoise_iterations = 5;
    int seam_iterations = 64;  // seam-blend sweeps (0: off)
    // > 0 (and samples >= 4): firefly suppression. A path whose indirect part (the light that
    // reflected at least once) is brighter than this x the mean indirect part of the texel's
    // other paths (all but the brightest) is clamped to it; direct light is never touched.
    // Biased (dark) by a bounded amount: <= 0.5 % of the mean in the furnace at factor 4
    // (docs/baking.md "Noise"). 0: off, the unbiased estimate.
    float firefly_factor = 0.0f;
    // false: the clamp acts on the whole path (direct + indirect), as before the split; kept so
    // that the noise bench can show the old result.
    bool firefly_indirect_only = true;
    int vertex_samples = 0;  // paths per vertex-oracle call (0: samples)
    // MOZ_lightmap.intensity = this quantile of the texels' max channel: the RGBM range (the
    // precision bound holds down to 1e-3 of it) goes to the bulk of the map and the brightest
    // 0.1 % (e.g. next to a bulb) clamp in the PNG (the EXR master keeps them). 1: the maximum,
    // nothing clamps.
    double intensity_percentile = 0.999;
    // How the glTF's lightmap texels hold E (RGBM: 8-bit HDR, decoded by the renderer).
    LightmapEncoding lightmap_encoding = LightmapEncoding::Rgbm;
    std::string exr_prefix;  // non-empty: write <prefix><k>.exr (linear E) per map
};

struct BakedMap {
    int texture = -1;
    int width = 0, height = 0;
    float intensity = 1.0f;
    size_t covered = 0, invalid = 0, dilated = 0, pushed_samples = 0, seams = 0;
    size_t buried_samples = 0;       // samples inside a solid (validity): left out of the paths
    std::vector<glm::vec3> raw;      // E before dilation and denoising (0 where uncovered)
    std::vector<glm::vec3> final_e;  // E as encoded (before 8-bit quantisation)
    std::vector<uint8_t> valid;      // covered and valid texels
    std::filesystem::path exr;       // written master, if any
};

struct BakeReport {
    std::vector<BakedMap> maps;
    size_t texels = 0;     // covered texels over all maps
    size_t vertices = 0;   // baked vertex colours
    uint64_t rays = 0;     // all rays cast (validity + paths)
    double seconds = 0.0;  // wall time of the whole bake
    double trace_seconds = 0.0;
    double rays_per_second = 0.0;  // rays / trace_seconds
    size_t triangles = 0;
    size_t two_sided_primitives = 0;  // split into a front and a back sheet
    std::vector<std::string> warnings;
};

// progress(fraction in [0, 1]) is called from the calling thread now and then.
using BakeProgress = std::function<void(double fraction)>;

// Errors: no punctual light, no emissive material that the traced geometry uses and no sky
// (nothing to bake); a light with a negative or non-finite intensity, colour or range (named);
// non-finite positions (mesh / vertex named); charts too large for the atlas at the requested
// density; lightmap textures without a size. Warnings: missing base-colour textures, emissive
// materials no traced mesh uses, a bounce limit that drops over 2 % of the light. On error the
// scene may be partly modified: callers write it out only on success. `progress` gets the
// fraction of all paths traced (lightmap texels and vertex queries).
Result<BakeReport> bake_scene(Scene& scene, const BakeOptions& options,
                              const BakeProgress& progress = {});

}  // namespace hmdnode
