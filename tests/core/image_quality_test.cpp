// PSNR and SSIM (core/src/image_quality.cpp) against closed forms: constant images, where every
// window's variances vanish and SSIM is (2ab + C1) / (a^2 + b^2 + C1); one channel step of MSE;
// identical images; and the errors for mismatched or too-small images.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "hmdnode/core/image_quality.hpp"

using namespace hmdnode;

namespace {

ImageRGBA8 grey(int w, int h, uint8_t v) {
    ImageRGBA8 im;
    im.width = w;
    im.height = h;
    im.pixels.assign(size_t(w) * h * 4, v);
    for (size_t i = 3; i < im.pixels.size(); i += 4) im.pixels[i] = 255;
    return im;
}

ImageRGBA8 noise(int w, int h, uint32_t seed, int lo, int hi) {
    ImageRGBA8 im = grey(w, h, 0);
    std::mt19937 rng(seed);
    std::uniform_int_distribution<int> d(lo, hi);
    for (size_t i = 0; i < im.pixels.size(); ++i)
        if (i % 4 != 3) im.pixels[i] = uint8_t(d(rng));
    return im;
}

}  // namespace

TEST(ImageQuality, SsimOfConstantImagesIsTheLuminanceTerm) {
    const double C1 = (0.01 * 255) * (0.01 * 255);
    const double a = 100, b = 120;
    const double expected = (2 * a * b + C1) / (a * a + b * b + C1);  // 0.98363...
    Result<double> s = ssim(grey(32, 20, 100), grey(32, 20, 120));
    ASSERT_TRUE(s.ok());
    EXPECT_NEAR(*s, expected, 1e-9);
    EXPECT_NEAR(*ssim(grey(11, 11, 0), grey(11, 11, 255)), C1 / (255.0 * 255 + C1), 1e-9);
}

TEST(ImageQuality, SsimOfIdenticalImagesIsOneAndFallsWithNoise) {
    const ImageRGBA8 x = noise(40, 30, 1, 40, 200);
    EXPECT_NEAR(*ssim(x, x), 1.0, 1e-12);
    ImageRGBA8 small = x, large = x;
    std::mt19937 rng(7);
    std::normal_distribution<double> n(0.0, 1.0);
    for (size_t i = 0; i < x.pixels.size(); ++i) {
        if (i % 4 == 3) continue;
        const double e = n(rng);
        small.pixels[i] = uint8_t(std::clamp(x.pixels[i] + 3.0 * e, 0.0, 255.0));
        large.pixels[i] = uint8_t(std::clamp(x.pixels[i] + 30.0 * e, 0.0, 255.0));
    }
    const double s_small = *ssim(x, small), s_large = *ssim(x, large);
    EXPECT_LT(s_small, 1.0);
    EXPECT_LT(s_large, s_small);
    EXPECT_NEAR(*ssim(small, x), s_small, 1e-12);  // symmetric
}

TEST(ImageQuality, PsnrIsTenLogOfPeakOverMse) {
    // One channel of one pixel off by 10 in a 10x10 image: MSE = 100 / 300.
    ImageRGBA8 a = grey(10, 10, 50), b = a;
    b.pixels[0] = 60;
    EXPECT_NEAR(*psnr_db(a, b), 10.0 * std::log10(255.0 * 255.0 / (100.0 / 300.0)), 1e-9);
    // Every value off by 1: MSE 1, 48.13 dB. Alpha does not count.
    ImageRGBA8 c = grey(10, 10, 51);
    for (size_t i = 3; i < c.pixels.size(); i += 4) c.pixels[i] = 0;
    EXPECT_NEAR(*psnr_db(a, c), 20.0 * std::log10(255.0), 1e-9);
    EXPECT_EQ(*psnr_db(a, a), kPsnrCapDb);  // identical: infinite, reported as the cap
}

TEST(ImageQuality, MismatchedOrTooSmallImagesAreErrors) {
    Result<double> p = psnr_db(grey(10, 10, 0), grey(10, 11, 0));
    ASSERT_FALSE(p.ok());
    EXPECT_NE(p.error().message.find("10x10 against 10x11"), std::string::npos);
    Result<double> s = ssim(grey(10, 40, 0), grey(10, 40, 0));
    ASSERT_FALSE(s.ok());
    EXPECT_NE(s.error().message.find("smaller than the 11x11 window"), std::string::npos);
    EXPECT_FALSE(psnr_db(ImageRGBA8{}, ImageRGBA8{}).ok());
}
