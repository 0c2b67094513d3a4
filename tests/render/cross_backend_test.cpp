// The two renderer backends against each other: the demo room (lightmapped, RGBM lightmaps, base
// colour textures, single- and double-sided materials) from a few head poses, both eyes, rendered
// by Vulkan (lavapipe) and by OpenGL ES 3 (llvmpipe), then warped through the generic lens profile
// (distortion and chromatic aberration) with a late head rotation. Both the eye buffers and the
// panels must agree to PSNR >= 40 dB (over R, G and B of every pixel, per eye and pose).
//
// Tolerance and why (docs/rendering.md, "Cross-backend agreement"): both backends run the same
// shader maths on the same vertex data through the same projection, so pixels differ only where
// the two APIs leave the rasteriser or the sampler latitude: (a) the coverage rule for pixels on
// a triangle edge (Vulkan's top-left rule in a y-down framebuffer against GL's in a y-up one:
// edge pixels may go to the neighbouring triangle, visible only where the two sides differ in
// colour), (b) attribute interpolation and texture filtering precision (llvmpipe's 8-bit
// filtering weights in either API, different code paths for the two), a code value here and
// there, and (c) depth ties between coplanar surfaces. 40 dB is an RMS error of 2.5 code values.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "hmdnode/core/gltf.hpp"
#include "hmdnode/core/stereo.hpp"
#include "hmdnode/render/lens.hpp"
#include "hmdnode/render/renderer.hpp"

namespace hmdnode {
namespace {

// Peak signal-to-noise ratio of b against a over R, G and B, in dB (infinity when equal).
double psnr(const ImageRGBA8& a, const ImageRGBA8& b) {
    double se = 0.0;
    size_t n = 0;
    for (size_t i = 0; i < a.pixels.size(); i += 4)
        for (size_t c = 0; c < 3; ++c) {
            const double d = double(a.pixels[i + c]) - double(b.pixels[i + c]);
            se += d * d;
            ++n;
        }
    if (se == 0.0) return INFINITY;
    return 10.0 * std::log10(255.0 * 255.0 / (se / double(n)));
}

// Pixels whose R, G or B differ between a and b.
size_t differing_pixels(const ImageRGBA8& a, const ImageRGBA8& b) {
    size_t n = 0;
    for (size_t i = 0; i < a.pixels.size(); i += 4)
        n += a.pixels[i] != b.pixels[i] || a.pixels[i + 1] != b.pixels[i + 1] ||
             a.pixels[i + 2] != b.pixels[i + 2];
    return n;
}

// Standard deviation of the green channel: a frame with content, not a blank one.
double green_spread(const ImageRGBA8& a) {
    double s = 0.0, s2 = 0.0;
    const double n = double(a.pixels.size() / 4);
    for (size_t i = 1; i < a.pixels.size(); i += 4) {
        s += a.pixels[i];
        s2 += double(a.pixels[i]) * a.pixels[i];
    }
    return std::sqrt(std::max(0.0, s2 / n - (s / n) * (s / n)));
}

struct Frame {
    StereoImage eyes, panel;
};

// Renders and warps the demo room from each pose on one backend.
std::vector<Frame> render_poses(const std::string& backend, const Scene& scene,
                                const std::vector<Pose>& poses, int width, int height) {
    RendererConfig rc;
    rc.eye_width = width;
    rc.eye_height = height;
    rc.backend = backend;
    auto renderer = create_renderer(rc);
    EXPECT_TRUE(renderer.ok()) << backend << ": " << renderer.error().message;
    if (!renderer.ok()) return {};
    Renderer& r = **renderer;
    EXPECT_STREQ(r.backend_name(), backend.c_str());
    EXPECT_TRUE(r.upload(scene).ok());
    const HeadsetProfile profile = generic_headset_profile();
    const DistortionMesh left = make_distortion_mesh(profile, 0, 32, 32);
    const DistortionMesh right = make_distortion_mesh(profile, 1, 32, 32);
    EXPECT_TRUE(r.set_warp(width, height, left, right).ok());
    StereoRig rig = StereoRig::typical();
    rig.eye[0] = mesh_render_fov(left, 0.1);
    rig.eye[1] = mesh_render_fov(right, 0.1);
    std::vector<DrawItem> items;
    for (const SceneObject& o : flatten_objects(scene))
        items.push_back(DrawItem{o.levels.front().mesh, glm::mat4(o.world)});
    std::vector<Frame> frames;
    for (const Pose& head : poses) {
        StereoViews views;
        for (int e = 0; e < 2; ++e) {
            views.view[e] = eye_view_matrix(rig, head, e);
            views.projection[e] = eye_projection(rig.eye[e], rig.near_m, rig.far_m);
        }
        Frame f;
        auto stats = r.render(views, items, &f.eyes);
        EXPECT_TRUE(stats.ok()) << (stats.ok() ? "" : stats.error().message);
        // The head turned 2 degrees right and 1 down since the render.
        const glm::dquat delta = glm::angleAxis(deg_to_rad(-2.0), glm::dvec3(0, 1, 0)) *
                                 glm::angleAxis(deg_to_rad(-1.0), glm::dvec3(1, 0, 0));
        auto warped = r.warp(delta, &f.panel);
        EXPECT_TRUE(warped.ok()) << (warped.ok() ? "" : warped.error().message);
        frames.push_back(std::move(f));
    }
    return frames;
}

TEST(CrossBackend, VulkanAndGlesAgreeOnTheDemoRoomToFortyDecibels) {
    auto scene = load_gltf(HMDNODE_DEMO_SCENE);
    ASSERT_TRUE(scene.ok()) << scene.error().message;
    std::vector<Pose> poses;
    const double yaw_deg[] = {0.0, 70.0, 160.0, -110.0};
    const double pitch_deg[] = {0.0, -20.0, 10.0, -35.0};
    for (int i = 0; i < 4; ++i) {
        Pose p;
        p.position = {0.3 * i - 0.4, 1.6, 0.2 * i - 0.3};
        p.orientation = glm::angleAxis(deg_to_rad(yaw_deg[i]), glm::dvec3(0, 1, 0)) *
                        glm::angleAxis(deg_to_rad(pitch_deg[i]), glm::dvec3(1, 0, 0));
        poses.push_back(p);
    }
    const int w = 180, h = 200;
    const std::vector<Frame> vk = render_poses("vulkan", *scene, poses, w, h);
    const std::vector<Frame> gl = render_poses("gles", *scene, poses, w, h);
    ASSERT_EQ(vk.size(), poses.size());
    ASSERT_EQ(gl.size(), poses.size());
    for (size_t i = 0; i < poses.size(); ++i)
        for (int e = 0; e < 2; ++e) {
            const double eye_db = psnr(vk[i].eyes.eye[e], gl[i].eyes.eye[e]);
            const double panel_db = psnr(vk[i].panel.eye[e], gl[i].panel.eye[e]);
            std::printf(
                "pose %zu eye %d: eye buffer %.1f dB (%zu pixels differ), panel %.1f dB "
                "(%zu differ); green spread %.1f\n",
                i, e, eye_db, differing_pixels(vk[i].eyes.eye[e], gl[i].eyes.eye[e]), panel_db,
                differing_pixels(vk[i].panel.eye[e], gl[i].panel.eye[e]),
                green_spread(vk[i].eyes.eye[e]));
            // Both frames show the room (not a blank image that would agree trivially).
            EXPECT_GT(green_spread(vk[i].eyes.eye[e]), 10.0);
            EXPECT_GT(green_spread(gl[i].panel.eye[e]), 10.0);
            ASSERT_EQ(gl[i].eyes.eye[e].width, w);
            ASSERT_EQ(gl[i].panel.eye[e].height, h);
            EXPECT_GE(eye_db, 40.0) << "pose " << i << " eye " << e;
            EXPECT_GE(panel_db, 40.0) << "pose " << i << " eye " << e;
        }
}

TEST(CrossBackend, AnUnknownBackendIsAClearError) {
    RendererConfig rc;
    rc.backend = "metal";
    auto r = create_renderer(rc);
    ASSERT_FALSE(r.ok());
    EXPECT_NE(r.error().message.find("unknown renderer backend \"metal\""), std::string::npos)
        << r.error().message;
    EXPECT_NE(r.error().message.find("vulkan|gles"), std::string::npos);
}

TEST(CrossBackend, TheConfigNamesTheBackendElseHmdnodeRendererElseVulkan) {
    const char* saved = std::getenv("HMDNODE_RENDERER");
    const std::string saved_value = saved ? saved : "";
    unsetenv("HMDNODE_RENDERER");
    RendererConfig rc;
    EXPECT_EQ(resolve_renderer_backend(rc).value(), "vulkan");
    setenv("HMDNODE_RENDERER", "gles", 1);
    EXPECT_EQ(resolve_renderer_backend(rc).value(), "gles");
    rc.backend = "vulkan";  // a config key or option wins over the environment
    EXPECT_EQ(resolve_renderer_backend(rc).value(), "vulkan");
    rc.backend.clear();
    setenv("HMDNODE_RENDERER", "opengl", 1);
    auto bad = resolve_renderer_backend(rc);
    ASSERT_FALSE(bad.ok());
    EXPECT_NE(bad.error().message.find("HMDNODE_RENDERER: unknown renderer backend \"opengl\""),
              std::string::npos)
        << bad.error().message;
    if (saved)
        setenv("HMDNODE_RENDERER", saved_value.c_str(), 1);
    else
        unsetenv("HMDNODE_RENDERER");
}

}  // namespace
}  // namespace hmdnode
