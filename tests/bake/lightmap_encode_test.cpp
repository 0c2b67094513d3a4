#include "hmdnode/bake/lightmap_encode.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <random>

#include <gtest/gtest.h>

namespace hmdnode {
namespace {

// A gradient plus random HDR values spanning 6 decades, some exactly zero.
HdrImage test_image(int w, int h, unsigned seed = 3) {
    HdrImage im;
    im.width = w, im.height = h;
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> expo(-3.0f, 3.0f), u(0.0f, 1.0f);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            glm::vec3 e(std::pow(10.0f, expo(rng)) * u(rng), std::pow(10.0f, expo(rng)),
                        float(x) / float(w) * 50.0f);
            if ((x + y) % 17 == 0) e = glm::vec3(0.0f);
            im.rgb.push_back(e);
        }
    return im;
}

TEST(LightmapEncode, ExrFloatRoundTripIsBitExact) {
    HdrImage im = test_image(37, 23);
    im.rgb[5] = glm::vec3(1e-30f, 3.0e38f, 0.1f);  // denormal-ish and huge values survive too
    const auto dir = std::filesystem::path(HMDNODE_BINARY_DIR) / "test_output" / "lightmap_encode";
    std::filesystem::create_directories(dir);
    const auto path = dir / "roundtrip.exr";
    ASSERT_TRUE(write_exr(path, im).ok());
    auto back = read_exr(path);
    ASSERT_TRUE(back.ok()) << back.error().message;
    ASSERT_EQ(back->width, im.width);
    ASSERT_EQ(back->height, im.height);
    for (size_t i = 0; i < im.rgb.size(); ++i)
        for (int c = 0; c < 3; ++c)
            ASSERT_EQ(std::memcmp(&back->rgb[i][c], &im.rgb[i][c], 4), 0) << i << " " << c;
}

TEST(LightmapEncode, ExrHalfRoundTripWithinHalfPrecision) {
    HdrImage im = test_image(16, 16);
    auto bytes = encode_exr(im, ExrPixel::Half);
    ASSERT_TRUE(bytes.ok()) << bytes.error().message;
    auto back = decode_exr(*bytes, "mem");
    ASSERT_TRUE(back.ok()) << back.error().message;
    for (size_t i = 0; i < im.rgb.size(); ++i)
        for (int c = 0; c < 3; ++c) {
            const float v = im.rgb[i][c], b = back->rgb[i][c];
            if (v >= 6.1e-5f)  // normal halves: 11-bit significand, rounding error <= 2^-11
                EXPECT_LE(std::abs(b - v), v * std::ldexp(1.0f, -11) * 1.0001f) << v;
            else
                EXPECT_LE(std::abs(b - v), 6e-8f) << v;  // subnormal step 2^-24
        }
}

TEST(LightmapEncode, ExrErrorsNameTheFile) {
    auto r = decode_exr("not an exr at all", "broken.exr");
    ASSERT_FALSE(r.ok());
    EXPECT_NE(r.error().message.find("broken.exr"), std::string::npos);
    HdrImage empty;
    EXPECT_FALSE(encode_exr(empty).ok());
    EXPECT_FALSE(read_exr("/nonexistent/x.exr").ok());
}

TEST(LightmapEncode, ScaledRgba8ErrorIsAtMostHalfAnLsbTimesIntensity) {
    HdrImage im = test_image(64, 32);
    ScaledRgba8 enc = encode_scaled_rgba8(im);  // percentile 1: the max, nothing clamps
    EXPECT_EQ(enc.clamped, 0u);
    float peak = 0.0f;
    for (auto& e : im.rgb) peak = std::max({peak, e.r, e.g, e.b});
    EXPECT_EQ(enc.intensity, peak);
    HdrImage back = decode_scaled_rgba8(enc.rgba8, im.width, im.height, enc.intensity);
    for (size_t i = 0; i < im.rgb.size(); ++i) {
        EXPECT_EQ(enc.rgba8[4 * i + 3], 255);
        for (int c = 0; c < 3; ++c)
            EXPECT_LE(std::abs(back.rgb[i][c] - im.rgb[i][c]),
                      0.5f / 255.0f * enc.intensity * 1.0001f);
    }
}

TEST(LightmapEncode, PercentileClampsOnlyTheBrightestTexels) {
    HdrImage im;
    im.width = 100, im.height = 1;
    for (int i = 0; i < 100; ++i) im.rgb.push_back(glm::vec3(float(i + 1)));  // 1..100
    ScaledRgba8 enc = encode_scaled_rgba8(im, 0.9);
    EXPECT_EQ(enc.intensity, 90.0f);
    EXPECT_EQ(enc.clamped, 10u);  // 91..100
    // A mask restricts the statistics to covered texels.
    std::vector<uint8_t> mask(100, 0);
    mask[4] = 1;
    EXPECT_EQ(encode_scaled_rgba8(im, 1.0, mask).intensity, 5.0f);
    // All dark: intensity 1, all zero.
    HdrImage dark;
    dark.width = dark.height = 2;
    dark.rgb.assign(4, glm::vec3(0.0f));
    EXPECT_EQ(encode_scaled_rgba8(dark).intensity, 1.0f);
}

TEST(LightmapEncode, StoreLightmapSetsTextureAndIntensity) {
    Scene s;
    s.textures.resize(2);
    Material a, b;
    a.lightmap.texture = 1;
    b.lightmap.texture = 0;
    s.materials = {a, b};
    HdrImage im;
    im.width = 2, im.height = 1;
    im.rgb = {glm::vec3(2.0f, 1.0f, 0.0f), glm::vec3(4.0f)};
    auto r = store_lightmap(s, 1, im, 1.0, {}, LightmapEncoding::Linear);
    ASSERT_TRUE(r.ok());
    EXPECT_EQ(*r, 4.0f);
    EXPECT_EQ(s.materials[0].lightmap.intensity, 4.0f);
    EXPECT_EQ(s.materials[0].lightmap.encoding, LightmapEncoding::Linear);
    EXPECT_EQ(s.materials[1].lightmap.intensity, 1.0f);
    EXPECT_EQ(s.textures[1].width, 2);
    EXPECT_EQ(s.textures[1].rgba8, (std::vector<uint8_t>{128, 64, 0, 255, 255, 255, 255, 255}));
    // The default, RGBM with the range 4: (2, 1, 0) -> multiplier 128/255, rgb 254, 127, 0.
    ASSERT_TRUE(store_lightmap(s, 1, im).ok());
    EXPECT_EQ(s.materials[0].lightmap.encoding, LightmapEncoding::Rgbm);
    EXPECT_EQ(s.materials[1].lightmap.encoding, LightmapEncoding::Linear);
    EXPECT_EQ(s.textures[1].rgba8, (std::vector<uint8_t>{254, 127, 0, 128, 255, 255, 255, 255}));
    EXPECT_FALSE(store_lightmap(s, 2, im).ok());
}

// HDR precision: the linear 8-bit PNG lost the dark end (14 % error at 1 % of the scale, 0 at
// 0.1 %). RGBM with the map's maximum as its range keeps every channel within 2 % (in fact 0.77 %)
// of the texel's brightest channel, against the exact E, for E from 1e-3 to 1 of the maximum (grey
// and two tints, 601 values a decade apart in equal log steps); grey texels within that of E
// itself.
TEST(LightmapEncode, RgbmKeepsTwoPercentDownToATenthOfAPercentOfTheMaximum) {
    const float range = 37.0f;  // the map's maximum
    const glm::vec3 tints[3] = {glm::vec3(1.0f), {1.0f, 0.6f, 0.3f}, {0.25f, 0.5f, 1.0f}};
    HdrImage im;
    im.width = 601;
    im.height = 3;
    for (const glm::vec3& tint : tints)
        for (int i = 0; i <= 600; ++i)
            im.rgb.push_back(tint * (range * std::pow(10.0f, -3.0f + 3.0f * float(i) / 600.0f)));
    const std::vector<uint8_t> rgbm = encode_rgbm(im, range);
    const HdrImage back = decode_rgbm(rgbm, im.width, im.height, range);
    const ScaledRgba8 lin = encode_scaled_rgba8(im);  // the linear encoding, the same scale
    ASSERT_EQ(lin.intensity, range);
    const HdrImage lin_back = decode_scaled_rgba8(lin.rgba8, im.width, im.height, lin.intensity);
    float worst = 0.0f, worst_linear = 0.0f;
    for (size_t i = 0; i < im.rgb.size(); ++i) {
        const glm::vec3 e = im.rgb[i];
        const float peak = std::max({e.r, e.g, e.b});
        for (int c = 0; c < 3; ++c) {
            worst = std::max(worst, std::abs(back.rgb[i][c] - e[c]) / peak);
            worst_linear = std::max(worst_linear, std::abs(lin_back.rgb[i][c] - e[c]) / peak);
        }
    }
    std::printf(
        "E in [1e-3, 1] x max: worst error relative to the texel's peak: RGBM %.3f %%, "
        "linear 8-bit %.1f %%\n",
        100.0 * worst, 100.0 * worst_linear);
    EXPECT_LE(worst, 0.5f * range / (255.0f * 255.0f) / (1e-3f * range) * 1.001f);  // 0.77 %
    EXPECT_LE(worst, 0.02f);
    EXPECT_GE(worst_linear, 0.5f);  // 1e-3 of the scale rounds to 0
}

TEST(LightmapEncode, RgbmRelativeErrorBound) {
    const float range = 8.0f;
    HdrImage im = test_image(64, 64, 11);
    for (auto& e : im.rgb) e = glm::min(e, glm::vec3(range));
    auto enc = encode_rgbm(im, range);
    HdrImage back = decode_rgbm(enc, im.width, im.height, range);
    for (size_t i = 0; i < im.rgb.size(); ++i) {
        const glm::vec3 e = im.rgb[i];
        const float peak = std::max({e.r, e.g, e.b});
        const float m = float(enc[4 * i + 3]) / 255.0f;
        for (int c = 0; c < 3; ++c) {
            const float err = std::abs(back.rgb[i][c] - e[c]);
            EXPECT_LE(err, 0.5f / 255.0f * m * range * 1.0001f + 1e-6f);
            if (peak >= range / 255.0f)
                EXPECT_LE(err, peak / 255.0f * 1.0001f);
            else
                EXPECT_LE(err, 0.5f * range / (255.0f * 255.0f) * 1.0001f);
        }
    }
}

}  // namespace
}  // namespace hmdnode
