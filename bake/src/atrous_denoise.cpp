// Edge-avoiding A-trous wavelet filter (Dammertz, Sewtz, Hanika & Lensch, "Edge-Avoiding
// A-Trous Wavelet Transform for fast Global Illumination Filtering", HPG 2010): a 5 x 5 B3-spline
// kernel (1/16, 1/4, 3/8, 1/4, 1/16) applied with holes of 2^i texels for iteration i, each tap
// weighted by edge-stopping functions of normal, position and luminance.
//
// Departures: applied in lightmap texel space (not screen space); normal weight max(0, n.n')^128
// (SVGF's, Schied et al. 2017) instead of exp(-|n - n'|^2 / sigma); the luminance sigma is the
// texel's standard error x sigma_luminance (SVGF's variance guide), halved each iteration as the
// paper does for colour; texels outside the mask are neither read nor written. Cost: O(25 x
// iterations x texels) time, one copy of the map.
#include <algorithm>
#include <cassert>
#include <cmath>
#include <vector>

#include "lightmap_passes.hpp"

namespace hmdnode::detail {

void atrous_denoise(std::vector<glm::vec3>& texels, const std::vector<uint8_t>& mask,
                    const std::vector<glm::vec3>& normals, const std::vector<glm::vec3>& positions,
                    const std::vector<float>& stddev, int width, int height, int iterations,
                    float sigma_position_m, float sigma_luminance) {
    [[maybe_unused]] const size_t n = size_t(width) * size_t(height);
    assert(width >= 0 && height >= 0 && texels.size() == n && mask.size() == n);
    assert(normals.size() == n && positions.size() == n && stddev.size() == n);
    // The step 2^i of the last pass must fit an int; the sigmas scale weights.
    assert(iterations >= 0 && iterations < 31 && sigma_position_m >= 0.0f &&
           sigma_luminance >= 0.0f);
    static const float kernel[5] = {1.0f / 16, 1.0f / 4, 3.0f / 8, 1.0f / 4, 1.0f / 16};
    const float inv_sp2 = 1.0f / std::max(1e-12f, sigma_position_m * sigma_position_m);
    auto lum = [](const glm::vec3& c) { return 0.2126f * c.r + 0.7152f * c.g + 0.0722f * c.b; };
    float sigma_l = sigma_luminance;
    for (int it = 0; it < iterations; ++it) {
        const int step = 1 << it;
        const std::vector<glm::vec3> in = texels;
        for (int y = 0; y < height; ++y)
            for (int x = 0; x < width; ++x) {
                const size_t idx = size_t(y) * width + x;
                if (!mask[idx]) continue;
                const glm::vec3& n0 = normals[idx];
                const glm::vec3& p0 = positions[idx];
                const float l0 = lum(in[idx]);
                const float lum_scale = sigma_l * stddev[idx] + 1e-6f * (1.0f + l0);
                glm::vec3 sum(0.0f);
                float wsum = 0.0f;
                for (int dy = -2; dy <= 2; ++dy)
                    for (int dx = -2; dx <= 2; ++dx) {
                        const int nx = x + dx * step, ny = y + dy * step;
                        if (nx < 0 || ny < 0 || nx >= width || ny >= height) continue;
                        const size_t nidx = size_t(ny) * width + nx;
                        if (!mask[nidx]) continue;
                        float w = kernel[dx + 2] * kernel[dy + 2];
                        const float nd = std::max(0.0f, glm::dot(n0, normals[nidx]));
                        w *= std::pow(nd, 128.0f);
                        const glm::vec3 dp = positions[nidx] - p0;
                        w *= std::exp(-glm::dot(dp, dp) * inv_sp2);
                        if (sigma_l > 0.0f)
                            w *= std::exp(-std::abs(lum(in[nidx]) - l0) / lum_scale);
                        sum += w * in[nidx];
                        wsum += w;
                    }
                if (wsum > 0.0f) texels[idx] = sum / wsum;
            }
        sigma_l *= 0.5f;
    }
}

}  // namespace hmdnode::detail
