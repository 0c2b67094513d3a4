// The LOD cross-fade's screen-door masks (DrawItem::dither, scene.frag) and MSAA (RendererConfig::
// msaa_samples), against pixels: two complementary masks cover every pixel of an object exactly
// once, with one sample per pixel and with four; a 4x edge has intermediate values and a 1x edge
// none. Small eye buffers: runs on lavapipe.
#include <gtest/gtest.h>

#include <glm/gtc/matrix_transform.hpp>

#include <cstring>
#include <string>

#include "hmdnode/core/stereo.hpp"
#include "hmdnode/render/renderer.hpp"

namespace hmdnode {
namespace {

constexpr int kSize = 48;

std::unique_ptr<Renderer> make_renderer(int samples) {
    RendererConfig config;
    config.eye_width = kSize;
    config.eye_height = kSize;
    config.msaa_samples = samples;
    auto r = create_vulkan_renderer(config);
    EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().message);
    return r.ok() ? std::move(r.value()) : nullptr;
}

StereoViews straight_views() {
    StereoViews v;
    for (int e = 0; e < 2; ++e) {
        v.view[e] = glm::mat4(1.0f);
        v.projection[e] = eye_projection(EyeFov{}, 0.1, 100.0);
    }
    return v;
}

// A triangle one metre ahead with slanted edges (so MSAA has partly covered pixels), unlit white,
// as two meshes (the "levels" of one object): 0 and 1 are the same geometry.
Scene triangle_scene() {
    Scene scene;
    Material m;
    m.base_color_factor = {1.0f, 1.0f, 1.0f, 1.0f};
    scene.materials.push_back(m);
    Primitive p;
    p.positions = {{-0.8f, -0.7f, -1.0f}, {0.9f, -0.5f, -1.0f}, {-0.2f, 0.8f, -1.0f}};
    p.indices = {0, 1, 2};
    p.material = 0;
    for (int i = 0; i < 2; ++i) scene.meshes.push_back(Mesh{"level" + std::to_string(i), {p}});
    return scene;
}

ImageRGBA8 render_left(Renderer& r, std::initializer_list<DrawItem> items) {
    StereoImage img;
    auto stats =
        r.render(straight_views(), std::span<const DrawItem>(items.begin(), items.size()), &img);
    EXPECT_TRUE(stats.ok()) << (stats.ok() ? "" : stats.error().message);
    return img.eye[0];
}

int red(const ImageRGBA8& img, int x, int y) {
    return img.at(x, y)[0];
}

class CrossFade : public ::testing::TestWithParam<int> {};

TEST_P(CrossFade, ComplementaryMasksCoverEachPixelOfTheObjectExactlyOnce) {
    auto r = make_renderer(GetParam());
    ASSERT_TRUE(r);
    ASSERT_TRUE(r->upload(triangle_scene()).ok());
    const ImageRGBA8 whole = render_left(*r, {DrawItem{0, glm::mat4(1.0f), 0}});
    int covered = 0;
    for (int y = 0; y < kSize; ++y)
        for (int x = 0; x < kSize; ++x) covered += red(whole, x, y) > 0;
    ASSERT_GT(covered, kSize * kSize / 4);
    for (int k = 1; k <= kMaxDither; ++k) {
        // The old level fading out (-k) and the new one fading in (+k), alone and together.
        const ImageRGBA8 out = render_left(*r, {DrawItem{0, glm::mat4(1.0f), -k}});
        const ImageRGBA8 in = render_left(*r, {DrawItem{1, glm::mat4(1.0f), k}});
        const ImageRGBA8 both =
            render_left(*r, {DrawItem{0, glm::mat4(1.0f), -k}, DrawItem{1, glm::mat4(1.0f), k}});
        int in_count = 0, twice = 0, missed = 0, stray = 0;
        for (int y = 0; y < kSize; ++y)
            for (int x = 0; x < kSize; ++x) {
                const bool a = red(out, x, y) > 0, b = red(in, x, y) > 0;
                if (red(whole, x, y) > 0) {
                    twice += a && b;
                    missed += !a && !b;
                    in_count += b;
                    // A pixel keeps the whole object's coverage under its mask (MSAA edges too).
                    EXPECT_EQ(red(a ? out : in, x, y), red(whole, x, y)) << x << "," << y;
                } else {
                    stray += a || b;
                }
            }
        EXPECT_EQ(twice, 0) << "k " << k;
        EXPECT_EQ(missed, 0) << "k " << k;
        EXPECT_EQ(stray, 0) << "k " << k;
        // +k keeps k of every 16 pixels: the share of the object's pixels is near k / 16.
        EXPECT_NEAR(double(in_count) / covered, k / 16.0, 0.06) << "k " << k;
        // Both together are the object drawn once, pixel for pixel.
        EXPECT_EQ(0, std::memcmp(both.pixels.data(), whole.pixels.data(), whole.pixels.size()))
            << "k " << k;
    }
}

INSTANTIATE_TEST_SUITE_P(Samples, CrossFade, ::testing::Values(1, 4));

TEST(CrossFade, DitherBeyondTheTileIsAnError) {
    auto r = make_renderer(1);
    ASSERT_TRUE(r);
    ASSERT_TRUE(r->upload(triangle_scene()).ok());
    const DrawItem bad{0, glm::mat4(1.0f), kMaxDither + 1};
    StereoImage img;
    auto s = r->render(straight_views(), {&bad, 1}, &img);
    ASSERT_FALSE(s.ok());
    EXPECT_NE(s.error().message.find("dither 16"), std::string::npos) << s.error().message;
}

// Pixels strictly between the clear colour and the triangle's (0 and 255 in every channel).
int intermediate_pixels(const ImageRGBA8& img) {
    int n = 0;
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x) n += red(img, x, y) > 0 && red(img, x, y) < 255;
    return n;
}

TEST(Msaa, FourSamplesGiveTheEdgesIntermediateCoverageAndOneSampleNone) {
    for (int samples : {1, 4}) {
        auto r = make_renderer(samples);
        ASSERT_TRUE(r);
        EXPECT_EQ(r->msaa_samples(), samples);
        ASSERT_TRUE(r->upload(triangle_scene()).ok());
        const DrawItem item{0, glm::mat4(1.0f)};
        StereoImage img;
        auto s = r->render(straight_views(), {&item, 1}, &img);
        ASSERT_TRUE(s.ok()) << s.error().message;
        for (const ImageRGBA8& eye : img.eye) {
            // Inside and outside are the same either way.
            EXPECT_EQ(red(eye, kSize / 2, kSize / 2), 255)
                << &eye - img.eye << " samples " << samples;
            EXPECT_EQ(red(eye, 1, 1), 0);
            const int n = intermediate_pixels(eye);
            if (samples == 1)
                EXPECT_EQ(n, 0);
            else  // three slanted edges, about a pixel wide, some 100 pixels long together
                EXPECT_GT(n, kSize);
        }
    }
}

TEST(Msaa, SampleCountsOtherThanOneOrFourAreAnError) {
    RendererConfig config;
    config.eye_width = config.eye_height = 8;
    config.msaa_samples = 2;
    auto r = create_vulkan_renderer(config);
    ASSERT_FALSE(r.ok());
    EXPECT_NE(r.error().message.find("MSAA sample count 2"), std::string::npos)
        << r.error().message;
}

}  // namespace
}  // namespace hmdnode
