// The Cornell box (published geometry) baked into a lightmap by the path tracer, rendered by the
// Vulkan renderer (lavapipe on CI), against an image traced directly by the same path tracer
// from the same camera.
//
// Tolerance and why: both images estimate the same radiance albedo x E / pi, so they differ only
// by (a) the lightmap's resolution (1/48 m texels) and bilinear filtering, which blur E over about
// a texel: visible only at contact shadows and geometric edges, which we exclude (pixels whose
// 3 x 3 neighbourhood sees another quad, and the light, whose emitted radiance saturates the
// 8-bit output); (b) 8-bit storage: the lightmap texel (0.5/255 of the map's maximum) and the sRGB
// output
// (< 0.4 % in mid-tones); (c) Monte Carlo noise: the bake's 128 paths per texel (denoised) and
// the reference's 64 paths per pixel (about 10 % per pixel, so pixels are pooled into 4 x 4
// blocks: about 2.5 %); (d) the A-trous denoiser's bias at shading gradients (~1 %). Hence: the
// mean of all compared pixels agrees within 3 %, and the mean absolute difference of 4 x 4 block
// means is under 6 % of the mean radiance, per channel.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>

#include "hmdnode/bake/bake.hpp"
#include "hmdnode/bake/cornell_box.hpp"
#include "hmdnode/bake/path_tracer.hpp"
#include "hmdnode/core/stereo.hpp"
#include "hmdnode/render/renderer.hpp"

namespace hmdnode {
namespace {

float srgb_to_linear(float c) {
    return c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f);
}

TEST(Cornell, RendererLightmapMatchesDirectPathTracing) {
    const int size = 64;
    Scene scene = cornell_box_scene(48.0);
    ASSERT_EQ(scene.textures.size(), 1u);
    BakeOptions o;
    o.samples = 128;
    o.bounces = 4;
    o.seed = 3;
    Result<BakeReport> baked = bake_scene(scene, o);
    ASSERT_TRUE(baked.ok()) << baked.error().message;

    RendererConfig rc;
    rc.eye_width = size;
    rc.eye_height = size;
    Result<std::unique_ptr<Renderer>> renderer = create_vulkan_renderer(rc);
    if (!renderer) GTEST_SKIP() << "no Vulkan device: " << renderer.error().message;
    ASSERT_TRUE((*renderer)->upload(scene).ok());
    const CornellCamera cam;
    const float t = std::tan(0.5f * cam.vertical_fov_rad);
    EyeFov fov;
    fov.tan_left = -t;
    fov.tan_right = t;
    fov.tan_up = t;
    fov.tan_down = -t;
    StereoViews views;
    const glm::mat4 view = glm::lookAt(cam.position, cam.position + cam.forward, cam.up);
    const glm::mat4 proj = eye_projection(fov, 0.05, 10.0);
    for (int e = 0; e < 2; ++e) {
        views.view[e] = view;
        views.projection[e] = proj;
    }
    const DrawItem item{0, glm::mat4(1.0f)};
    StereoImage image;
    Result<RenderStats> rendered = (*renderer)->render(views, {&item, 1}, &image);
    ASSERT_TRUE(rendered.ok()) << rendered.error().message;
    const ImageRGBA8& img = image.eye[0];
    ASSERT_EQ(img.width, size);

    // Reference: the same path tracer through the same camera (rays from the inverse of
    // projection x view through pixel centres, Vulkan NDC: y down).
    PathTracerOptions po;
    po.bounces = o.bounces;
    Result<PathTracer> tracer = PathTracer::build(scene, po);
    ASSERT_TRUE(tracer.ok());
    const glm::mat4 inv = glm::inverse(proj * view);
    std::vector<glm::vec3> ref(size * size), got(size * size);
    std::vector<int> quad(size * size, -1);
    const int spp = 64;
    parallel_for(size_t(size) * size, 0, 8, [&](size_t i, int) {
        const int x = int(i % size), y = int(i / size);
        const glm::vec2 ndc((x + 0.5f) / size * 2 - 1, (y + 0.5f) / size * 2 - 1);
        glm::vec4 a = inv * glm::vec4(ndc, 0.0f, 1.0f), b = inv * glm::vec4(ndc, 1.0f, 1.0f);
        const glm::vec3 o3 = glm::vec3(a) / a.w;
        const glm::vec3 d = glm::normalize(glm::vec3(b) / b.w - o3);
        std::optional<TraceHit> h = tracer->intersect(o3, d, 0.0f, 100.0f);
        if (h) quad[i] = int(h->triangle / 2);
        Pcg32 rng(99, i);
        glm::vec3 sum(0.0f);
        for (int s = 0; s < spp; ++s) sum += tracer->radiance(o3, d, rng);
        ref[i] = sum / float(spp);
    });
    for (int i = 0; i < size * size; ++i)
        for (int c = 0; c < 3; ++c) got[i][c] = srgb_to_linear(img.pixels[4 * i + c] / 255.0f);

    // Compared pixels: hit a non-light quad, and so does their whole 3 x 3 neighbourhood.
    const int light_quad = int(tracer->triangle_count() / 2) - 1;  // the light is the last quad
    std::vector<char> keep(size * size, 0);
    size_t kept = 0;
    for (int y = 1; y + 1 < size; ++y)
        for (int x = 1; x + 1 < size; ++x) {
            const int q = quad[y * size + x];
            if (q < 0 || q == light_quad) continue;
            bool same = true;
            for (int dy = -1; dy <= 1; ++dy)
                for (int dx = -1; dx <= 1; ++dx) same &= quad[(y + dy) * size + x + dx] == q;
            keep[y * size + x] = same;
            kept += same;
        }
    ASSERT_GT(kept, size_t(size * size / 2));
    glm::dvec3 mean_ref(0.0), mean_got(0.0);
    for (int i = 0; i < size * size; ++i)
        if (keep[i]) {
            mean_ref += glm::dvec3(ref[i]);
            mean_got += glm::dvec3(got[i]);
        }
    mean_ref /= double(kept);
    mean_got /= double(kept);
    glm::dvec3 block_err(0.0);
    size_t blocks = 0;
    for (int by = 0; by < size; by += 4)
        for (int bx = 0; bx < size; bx += 4) {
            bool all = true;
            glm::dvec3 r(0.0), g(0.0);
            for (int y = by; y < by + 4; ++y)
                for (int x = bx; x < bx + 4; ++x) {
                    all &= keep[y * size + x] != 0;
                    r += glm::dvec3(ref[y * size + x]);
                    g += glm::dvec3(got[y * size + x]);
                }
            if (!all) continue;
            block_err += glm::abs(r - g) / 16.0;
            ++blocks;
        }
    ASSERT_GT(blocks, 50u);
    block_err /= double(blocks);
    for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(mean_got[c], mean_ref[c], 0.03 * mean_ref[c]) << "channel " << c;
        EXPECT_LT(block_err[c], 0.06 * mean_ref[c]) << "channel " << c;
    }
    std::printf(
        "cornell: %zu pixels, %zu blocks; mean ref (%.4f %.4f %.4f) renderer (%.4f %.4f "
        "%.4f); block MAE / mean (%.2f %.2f %.2f) %%\n",
        kept, blocks, mean_ref.x, mean_ref.y, mean_ref.z, mean_got.x, mean_got.y, mean_got.z,
        100 * block_err.x / mean_ref.x, 100 * block_err.y / mean_ref.y,
        100 * block_err.z / mean_ref.z);
}

}  // namespace
}  // namespace hmdnode
