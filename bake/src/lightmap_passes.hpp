// Private: the lightmap passes of the bake pipeline (bake.cpp), one algorithm per file:
// texel_validity.cpp, dilate.cpp, atrous_denoise.cpp, seam_blend.cpp, two_sided.cpp.
#pragma once

#include <cmath>
#include <cstdint>
#include <functional>
#include <vector>

#include <glm/glm.hpp>

#include "hmdnode/bake/path_tracer.hpp"
#include "hmdnode/bake/texel_raster.hpp"
#include "hmdnode/core/scene.hpp"

namespace hmdnode::detail {

// Duff et al., "Building an Orthonormal Basis, Revisited", JCGT 2017: tangent frame of unit n,
// branchless.
inline void tangent_frame(const glm::vec3& n, glm::vec3& t, glm::vec3& b) {
    const float sign = std::copysign(1.0f, n.z);
    const float a = -1.0f / (sign + n.z);
    const float bb = n.x * n.y * a;
    t = glm::vec3(1.0f + sign * n.x * n.x * a, sign * bb, -sign * n.x);
    b = glm::vec3(bb, sign + n.y * n.y * a, -n.y);
}

struct ValidityResult {
    std::vector<uint8_t> valid;  // per texel: 1 covered and valid
    size_t invalid = 0;          // covered texels marked invalid
    size_t pushed = 0;           // samples moved in front of a back face
    size_t buried = 0;           // samples inside a solid (not traced)
    // Per texel: its first `visible` samples (in raster.samples) are outside every solid; the
    // rest are buried and left out of the paths.
    std::vector<uint32_t> visible;
    uint64_t rays = 0;
};

// texel_validity.cpp: from every sample, `rays_per_sample` rays of length 1.5 x texel size over
// the sphere; a back-face hit moves the sample in front of the nearest back face; a texel whose
// back-face fraction exceeds `threshold` is invalid. Modifies the samples' positions.
ValidityResult fix_texel_validity(TexelRaster& raster, const PathTracer& tracer,
                                  int rays_per_sample, float threshold, int threads, uint64_t seed);

// dilate.cpp: `rings` passes; each fills every texel without a value (valid == 0) that has valued
// 8-neighbours with their mean and marks it valued. Returns the number of texels filled.
size_t dilate(std::vector<glm::vec3>& texels, std::vector<uint8_t>& valid, int width, int height,
              int rings);

// atrous_denoise.cpp: edge-aware A-trous wavelet filter (Dammertz et al. 2010) over the texels
// with mask != 0, guided by per-texel normal and position; `iterations` passes with step 2^i.
// sigma_position_m scales the position weight (typically ~2 texel sizes); the luminance weight is
// exp(-|l - l'| / (sigma_luminance x stddev + eps)) with stddev the texel's standard error.
void atrous_denoise(std::vector<glm::vec3>& texels, const std::vector<uint8_t>& mask,
                    const std::vector<glm::vec3>& normals, const std::vector<glm::vec3>& positions,
                    const std::vector<float>& stddev, int width, int height, int iterations,
                    float sigma_position_m, float sigma_luminance);

// variance_atrous.cpp: variance-guided A-trous (SVGF's spatial filter, Schied et al. 2017) for
// the indirect light: `iterations` passes with step 2^i over the texels with mask != 0; the
// luminance stop is exp(-|l - l'| / (sigma_luminance x sqrt(blurred variance) + eps)) with
// `variance` the per-texel variance of the mean (filtered along, updated in place); taps farther
// in 3-D than 1.5 x their uv distance + one texel (`texel_m` metres) are skipped (chart borders).
void variance_atrous(std::vector<glm::vec3>& texels, std::vector<float>& variance,
                     const std::vector<uint8_t>& mask, const std::vector<glm::vec3>& normals,
                     const std::vector<glm::vec3>& positions, int width, int height, int iterations,
                     float texel_m, float sigma_luminance);

// seam_blend.cpp: for every edge shared in 3-D (positions equal within 10 um) by two triangles of
// primitives lightmapped into `texture` but split in uv1, samples the edge at 2 points per texel
// on both sides and moves the texels of the two bilinear footprints so both sides read their mean
// (`iterations` Gauss-Seidel sweeps). Returns the number of seam edges.
size_t blend_seams(const Scene& scene, int texture, std::vector<glm::vec3>& texels, int width,
                   int height, int iterations);

// two_sided.cpp: every primitive of a double-sided material for which keep() is false becomes a
// front and a back sheet (reversed winding, negated normals, attributes copied) under a
// single-sided material (cloned when kept primitives share it), so that each side gets its own
// texels or vertex light. Returns the number of primitives split.
size_t split_two_sided(Scene& scene, const std::function<bool(const Primitive&)>& keep);

}  // namespace hmdnode::detail
