// Lightmap encodings (docs/baking.md "Encoding"):
//  * the master: linear HDR OpenEXR (tinyexr), RGB, float or half, irradiance E in lux (W/m^2
//    for the renderer's relative units);
//  * for the glTF: RGBA8 with the scale in MOZ_lightmap.intensity, either RGBM (what the bake
//    writes: E = rgb/255 * a/255 * intensity, MOZ_lightmap.extras.encoding "RGBM") or linear
//    (E = rgb/255 * intensity). The renderer samples the lightmap through a UNORM view
//    (render/shaders/scene.frag, render/src/vulkan/gpu_scene.cpp): texels are linear, no sRGB
//    curve, and decodes RGBM per texel before its bilinear filter.
// Pixel order everywhere: rows top to bottom (glTF uv (0,0) = top-left), x left to right.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "hmdnode/core/result.hpp"
#include "hmdnode/core/scene.hpp"

namespace hmdnode {

// A linear HDR image.
struct HdrImage {
    int width = 0, height = 0;
    std::vector<glm::vec3> rgb;  // width * height, rows top to bottom
};

enum class ExrPixel { Float, Half };

// EXR bytes (scanline, ZIP compression, channels B,G,R as OpenEXR orders them). Error on an empty
// or inconsistent image or a tinyexr failure. Half saturates values above 65504.
Result<std::string> encode_exr(const HdrImage& image, ExrPixel pixel = ExrPixel::Float);
// encode_exr + write_file_atomically (never leaves a half-written file).
Status write_exr(const std::filesystem::path& path, const HdrImage& image,
                 ExrPixel pixel = ExrPixel::Float);
// Reads R, G, B (A ignored; a missing channel is an error naming the file); half is widened.
Result<HdrImage> read_exr(const std::filesystem::path& path);
Result<HdrImage> decode_exr(const std::string& bytes, const std::string& name_for_errors);

// RGBA8 with a global scale: texel = round(clamp(E / intensity, 0, 1) * 255), alpha 255.
// intensity = the `percentile` quantile of the per-texel max channel over the texels where
// `mask` is non-zero (all texels when mask is empty); percentile 1 = the maximum, so nothing
// clamps and the error is <= 0.5/255 * intensity per channel. A lower percentile (e.g. 0.999)
// spends the 8 bits on the bulk of the map and clamps the brightest texels (counted in
// `clamped`). An all-dark map gets intensity 1. Negative or non-finite E is stored as 0.
struct ScaledRgba8 {
    std::vector<uint8_t> rgba8;
    float intensity = 1.0f;
    size_t clamped = 0;
};
ScaledRgba8 encode_scaled_rgba8(const HdrImage& image, double percentile = 1.0,
                                const std::vector<uint8_t>& mask = {});
HdrImage decode_scaled_rgba8(const std::vector<uint8_t>& rgba8, int width, int height,
                             float intensity);

// Fills scene.textures[texture] (width/height/rgba8) and sets lightmap.intensity and .encoding on
// every material whose lightmap is that texture. intensity is encode_scaled_rgba8's (the
// `percentile` quantile over `mask`); the texels are encode_rgbm(image, intensity) for Rgbm (the
// default: <= 0.8 % relative error down to 1e-3 of intensity), encode_scaled_rgba8's for Linear.
// Returns the intensity. Error when the texture index is out of range or the image is empty.
Result<float> store_lightmap(Scene& scene, int texture, const HdrImage& image,
                             double percentile = 1.0, const std::vector<uint8_t>& mask = {},
                             LightmapEncoding encoding = LightmapEncoding::Rgbm);

// RGBM: with M = max(r,g,b) of E, m = k/255 with k = clamp(ceil(255 * M / range), 1, 255), and
// rgb = round(255 * E / (m * range)); alpha = k. Decoding: E = rgb/255 * m * range. Values above
// range clamp. Bound (docs/baking.md): every channel's absolute error <= 0.5/255 * m * range, so
// for M >= range/255 (k >= 2) the error relative to M is <= 1/255; darker texels (k = 1) have an
// absolute error <= 0.5 * range / 255^2: relative to M, <= 0.77 % at M = 1e-3 range, 7.7 % at
// 1e-4 range.
std::vector<uint8_t> encode_rgbm(const HdrImage& image, float range = 8.0f);
HdrImage decode_rgbm(const std::vector<uint8_t>& rgba8, int width, int height, float range = 8.0f);

}  // namespace hmdnode
