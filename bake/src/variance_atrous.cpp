// Variance-guided A-trous filter for the indirect light (SVGF: Schied et al., "Spatiotemporal
// Variance-Guided Filtering: Real-Time Reconstruction for Path-Traced Global Illumination", High
// Performance Graphics 2017, sec. 4.4, without the temporal part): the edge-avoiding
// A-trous wavelet of Dammertz et al. 2010 (5 x 5 B3 kernel, holes of 2^i texels) whose luminance
// edge stop is scaled by the noise: exp(-|l - l'| / (sigma_l x sqrt(var~ + var~') + eps)), var~
// the 3 x 3 Gaussian blur of the per-texel variance of the mean (SVGF uses the centre texel's
// alone, which, on the skewed noise of path tracing, lets dark texels reject bright neighbours
// and darkens the mean), except that a texel of variance 0 (all its paths agreed) only takes
// neighbours of its own luminance; the variance is filtered
// along with the value (var' = sum w^2 var / (sum w)^2), so each pass sees the noise that is left.
//
// Departures, for lightmaps: texel space instead of screen space; the depth/normal stops become a
// normal stop max(0, n.n')^128 and a position stop that lets a tap lie as far in 3-D as it lies in
// uv (|dp| <= d_uv x 1.5 + one texel, else weight 0): taps across a chart border (another chart's
// texels are next in uv, not in space) and across a crease drop out; texels outside the mask are
// neither read nor written. Cost: O((25 + 9) x iterations x texels) time, two copies of the map.
#include <algorithm>
#include <cassert>
#include <cmath>
#include <vector>

#include "lightmap_passes.hpp"

namespace hmdnode::detail {

void variance_atrous(std::vector<glm::vec3>& texels, std::vector<float>& variance,
                     const std::vector<uint8_t>& mask, const std::vector<glm::vec3>& normals,
                     const std::vector<glm::vec3>& positions, int width, int height, int iterations,
                     float texel_m, float sigma_luminance) {
    static const float kernel[5] = {1.0f / 16, 1.0f / 4, 3.0f / 8, 1.0f / 4, 1.0f / 16};
    static const float gauss[3] = {1.0f / 4, 1.0f / 2, 1.0f / 4};
    auto lum = [](const glm::vec3& c) { return 0.2126f * c.r + 0.7152f * c.g + 0.0722f * c.b; };
    const size_t n = size_t(width) * height;
    assert(width >= 0 && height >= 0 && texels.size() == n && variance.size() == n);
    assert(mask.size() == n && normals.size() == n && positions.size() == n);
    assert(iterations >= 0 && iterations < 31 && texel_m >= 0.0f && sigma_luminance >= 0.0f);
    std::vector<float> blurred(n, 0.0f);
    for (int it = 0; it < iterations; ++it) {
        const int step = 1 << it;
        const std::vector<glm::vec3> in = texels;
        const std::vector<float> var_in = variance;
        // 3 x 3 Gaussian of the variance over the masked texels (SVGF's guide).
        for (int y = 0; y < height; ++y)
            for (int x = 0; x < width; ++x) {
                const size_t idx = size_t(y) * width + x;
                if (!mask[idx]) continue;
                float s = 0.0f, ws = 0.0f;
                for (int dy = -1; dy <= 1; ++dy)
                    for (int dx = -1; dx <= 1; ++dx) {
                        const int nx = x + dx, ny = y + dy;
                        if (nx < 0 || ny < 0 || nx >= width || ny >= height) continue;
                        const size_t j = size_t(ny) * width + nx;
                        if (!mask[j]) continue;
                        const float w = gauss[dx + 1] * gauss[dy + 1];
                        s += w * var_in[j];
                        ws += w;
                    }
                blurred[idx] = ws > 0.0f ? s / ws : var_in[idx];
            }
        for (int y = 0; y < height; ++y)
            for (int x = 0; x < width; ++x) {
                const size_t idx = size_t(y) * width + x;
                if (!mask[idx]) continue;
                const glm::vec3& n0 = normals[idx];
                const glm::vec3& p0 = positions[idx];
                const float l0 = lum(in[idx]);
                glm::vec3 sum(0.0f);
                float wsum = 0.0f, vsum = 0.0f;
                for (int dy = -2; dy <= 2; ++dy)
                    for (int dx = -2; dx <= 2; ++dx) {
                        const int nx = x + dx * step, ny = y + dy * step;
                        if (nx < 0 || ny < 0 || nx >= width || ny >= height) continue;
                        const size_t j = size_t(ny) * width + nx;
                        if (!mask[j]) continue;
                        const float nd = std::max(0.0f, glm::dot(n0, normals[j]));
                        float w = kernel[dx + 2] * kernel[dy + 2] * std::pow(nd, 128.0f);
                        const float d_uv = std::sqrt(float(dx * dx + dy * dy)) * float(step);
                        if (glm::length(positions[j] - p0) > (1.5f * d_uv + 1.0f) * texel_m)
                            continue;
                        // The difference of two noisy estimates has the sum of their variances:
                        // a bright, noisy neighbour is not rejected by a dark, quiet texel (one
                        // texel's own variance alone biases skewed noise dark).
                        // A texel whose paths all agreed (variance 0: no indirect light inside
                        // a closed room) keeps its value: it takes no neighbour that differs.
                        const float var = var_in[idx] > 0.0f ? blurred[idx] + blurred[j] : 0.0f;
                        const float lum_scale =
                            sigma_luminance * std::sqrt(std::max(0.0f, var)) + 1e-6f * (1.0f + l0);
                        w *= std::exp(-std::abs(lum(in[j]) - l0) / lum_scale);
                        sum += w * in[j];
                        wsum += w;
                        vsum += w * w * var_in[j];
                    }
                if (wsum > 0.0f) {
                    texels[idx] = sum / wsum;
                    variance[idx] = vsum / (wsum * wsum);
                }
                // A variance of the mean stays one: filtering sums w^2 var with w >= 0.
                assert(!(variance[idx] < 0.0f));
            }
    }
}

}  // namespace hmdnode::detail
