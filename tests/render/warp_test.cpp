// The late-warp + lens-distortion pass on lavapipe against closed forms: without rotation or
// distortion it reproduces the eye buffer; a rotational warp matches rendering at the new pose;
// with a lens profile, a small marker straight at a known view direction lands, per colour
// channel, where the analytic lens model (lens_sample) says that channel shows that direction —
// between the mesh's vertices too, and for the Valve Index's chromatic aberration.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "hmdnode/core/stereo.hpp"
#include "hmdnode/render/lens.hpp"
#include "hmdnode/render/renderer.hpp"

namespace hmdnode {
namespace {

std::unique_ptr<Renderer> make_renderer(int width, int height) {
    RendererConfig config;
    config.eye_width = width;
    config.eye_height = height;
    auto r = create_renderer(config);
    EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().message);
    return r.ok() ? std::move(r.value()) : nullptr;
}

// A quad facing the viewer at the origin, centred on the direction (tx, ty, -1) at distance d,
// `size` wide in tangent units, white and unlit.
Primitive marker(double tx, double ty, double size, double d, int material) {
    Primitive p;
    const float x0 = float((tx - size / 2) * d), x1 = float((tx + size / 2) * d);
    const float y0 = float((ty - size / 2) * d), y1 = float((ty + size / 2) * d);
    const float z = float(-d);
    p.positions = {{x0, y0, z}, {x1, y0, z}, {x1, y1, z}, {x0, y1, z}};
    p.indices = {0, 1, 2, 0, 2, 3};
    p.material = material;
    return p;
}

Scene scene_of(std::vector<Primitive> prims, std::vector<glm::vec4> colors) {
    Scene s;
    for (const glm::vec4& c : colors) {
        Material m;
        m.base_color_factor = c;
        m.double_sided = true;
        s.materials.push_back(m);
    }
    s.meshes.push_back(Mesh{"markers", std::move(prims)});
    return s;
}

// Both eyes at the origin (no IPD), head orientation q, the given per-eye fields of view.
StereoViews views_for(const glm::dquat& q, const EyeFov fov[2]) {
    StereoRig rig = StereoRig::typical();
    rig.ipd_m = 0.0;
    Pose head;
    head.orientation = q;
    StereoViews v;
    for (int e = 0; e < 2; ++e) {
        rig.eye[e] = fov[e];
        v.view[e] = eye_view_matrix(rig, head, e);
        v.projection[e] = eye_projection(fov[e], 0.1, 1000.0);
    }
    return v;
}

// The panel shows `fov` undistorted: the lens model `none`, tangents linear in panel position
// (exact with one cell).
DistortionMesh linear_mesh(const EyeFov& fov) {
    HeadsetProfile flat;
    flat.eye[0].model = LensModel::none;
    flat.eye[0].fov = fov;
    return make_distortion_mesh(flat, 0, 1, 1);
}

// Intensity-weighted centroid (pixels, centres at +0.5) of channel c above a threshold.
glm::dvec2 centroid(const ImageRGBA8& img, int c, int threshold = 40) {
    double sx = 0, sy = 0, sw = 0;
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x) {
            const int v = img.at(x, y)[c];
            if (v < threshold) continue;
            sx += v * (x + 0.5);
            sy += v * (y + 0.5);
            sw += v;
        }
    return sw > 0 ? glm::dvec2(sx / sw, sy / sw) : glm::dvec2(-1.0);
}

// The panel position (pixels) where channel c of the lens model shows the view direction t:
// Gauss-Newton on lens_sample from the panel centre, finite-difference Jacobian.
glm::dvec2 panel_position_of(const HeadsetProfile& p, int eye, int c, glm::dvec2 t, int w, int h) {
    glm::dvec2 uv(0.5, 0.5);
    for (int it = 0; it < 50; ++it) {
        const double e = 1e-6;
        const glm::dvec2 f = lens_sample(p, eye, uv).tangent[c] - t;
        const glm::dvec2 fx = lens_sample(p, eye, uv + glm::dvec2(e, 0)).tangent[c] - t;
        const glm::dvec2 fy = lens_sample(p, eye, uv + glm::dvec2(0, e)).tangent[c] - t;
        const glm::dmat2 j((fx - f) / e, (fy - f) / e);
        uv -= glm::inverse(j) * f;
    }
    return {uv.x * w, uv.y * h};
}

TEST(Warp, WithoutRotationOrDistortionThePanelIsTheEyeBuffer) {
    const int w = 96, h = 80;
    auto r = make_renderer(w, h);
    ASSERT_TRUE(r);
    Scene s = scene_of({marker(0.1, 0.05, 0.4, 5.0, 0), marker(-0.5, -0.3, 0.3, 5.0, 1)},
                       {{1.0f, 0.5f, 0.2f, 1.0f}, {0.2f, 0.9f, 0.4f, 1.0f}});
    ASSERT_TRUE(r->upload(s).ok());
    const EyeFov fov[2] = {EyeFov{-1.0, 0.9, 0.8, -1.1}, EyeFov{-0.9, 1.0, 0.8, -1.1}};
    ASSERT_TRUE(r->set_warp(w, h, linear_mesh(fov[0]), linear_mesh(fov[1])).ok());
    const DrawItem item{0, glm::mat4(1.0f)};
    StereoImage eyes, panel;
    ASSERT_TRUE(r->render(views_for(glm::dquat(1, 0, 0, 0), fov), {&item, 1}, &eyes).ok());
    ASSERT_TRUE(r->warp(glm::dquat(1, 0, 0, 0), &panel).ok());
    for (int e = 0; e < 2; ++e) {
        ASSERT_EQ(panel.eye[e].width, w);
        int worst = 0;
        for (size_t i = 0; i < eyes.eye[e].pixels.size(); ++i)
            worst =
                std::max(worst, std::abs(int(eyes.eye[e].pixels[i]) - int(panel.eye[e].pixels[i])));
        EXPECT_LE(worst, 1) << "eye " << e;
    }
}

// Where a world direction shows on a panel of `fov` (w x h pixels) for a head at q.
glm::dvec2 panel_position_of_direction(const glm::dquat& q, glm::dvec3 world, const EyeFov& fov,
                                       int w, int h) {
    const glm::dvec3 d = glm::inverse(q) * world;
    const double tx = d.x / -d.z, ty = d.y / -d.z;
    return {(tx - fov.tan_left) / (fov.tan_right - fov.tan_left) * w,
            (fov.tan_up - ty) / (fov.tan_up - fov.tan_down) * h};
}

TEST(Warp, RotationalWarpPutsADistantPointWhereTheDisplayedPoseSeesIt) {
    const int w = 200, h = 200;
    auto r = make_renderer(w, h);
    ASSERT_TRUE(r);
    const EyeFov panel_fov{};
    const EyeFov render_fov{-1.3, 1.3, 1.3, -1.3};
    const EyeFov panel[2] = {panel_fov, panel_fov}, render[2] = {render_fov, render_fov};
    ASSERT_TRUE(r->set_warp(w, h, linear_mesh(panel_fov), linear_mesh(panel_fov)).ok());
    const glm::dvec2 t(0.15, -0.1);  // the marker's direction in the world
    ASSERT_TRUE(r->upload(scene_of({marker(t.x, t.y, 0.08, 100.0, 0)}, {{1, 1, 1, 1}})).ok());
    const DrawItem item{0, glm::mat4(1.0f)};
    const glm::dquat rendered = glm::angleAxis(deg_to_rad(4.0), glm::dvec3(0, 1, 0));
    const glm::dvec3 axes[] = {
        {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, glm::normalize(glm::dvec3(1, 2, 0.3))};
    for (const glm::dvec3& axis : axes) {
        const glm::dquat displayed = glm::angleAxis(deg_to_rad(-5.0), axis);
        StereoImage warped, direct;
        ASSERT_TRUE(r->render(views_for(rendered, render), {&item, 1}, nullptr).ok());
        ASSERT_TRUE(r->warp(glm::inverse(rendered) * displayed, &warped).ok());
        ASSERT_TRUE(r->render(views_for(displayed, panel), {&item, 1}, &direct).ok());
        const glm::dvec2 expected = panel_position_of_direction(
            displayed, glm::normalize(glm::dvec3(t.x, t.y, -1.0)), panel_fov, w, h);
        for (int e = 0; e < 2; ++e) {
            // Rasterising the 8-pixel marker without anti-aliasing moves its centroid by up to
            // half a pixel of the eye buffer (1.3 panel pixels wide here).
            const glm::dvec2 got = centroid(warped.eye[e], 1), ref = centroid(direct.eye[e], 1);
            EXPECT_NEAR(ref.x, expected.x, 0.5) << "axis " << axis.x << axis.y << axis.z;
            EXPECT_NEAR(ref.y, expected.y, 0.5) << "axis " << axis.x << axis.y << axis.z;
            EXPECT_NEAR(got.x, expected.x, 0.7) << "axis " << axis.x << axis.y << axis.z;
            EXPECT_NEAR(got.y, expected.y, 0.7) << "axis " << axis.x << axis.y << axis.z;
        }
    }
}

// A marker at each of several view directions, through a lens profile: per channel, its centroid
// on the panel is where lens_sample says that channel shows that direction.
// fused: the fused pass (the model per pixel) instead of the 64 x 64 mesh.
void check_lens(const HeadsetProfile& profile, int w, int h, double tolerance_px,
                bool fused = false) {
    auto r = make_renderer(w, h);
    ASSERT_TRUE(r);
    const DistortionMesh mesh[2] = {make_distortion_mesh(profile, 0, 64, 64),
                                    make_distortion_mesh(profile, 1, 64, 64)};
    const EyeFov fov[2] = {mesh_render_fov(mesh[0]), mesh_render_fov(mesh[1])};
    if (fused) {
        ASSERT_TRUE(r->set_lens_warp(w, h, profile).ok());
        EXPECT_STREQ(r->lens_pass_name(), "fused");
    } else {
        ASSERT_TRUE(r->set_warp(w, h, mesh[0], mesh[1]).ok());
        EXPECT_STREQ(r->lens_pass_name(), "mesh");
    }
    const glm::dvec2 directions[] = {{0.0, 0.0},   {0.45, 0.2},  {-0.6, -0.35},
                                     {0.3, -0.55}, {-0.5, 0.45}, {0.6, 0.05}};
    for (const glm::dvec2& t : directions) {
        ASSERT_TRUE(r->upload(scene_of({marker(t.x, t.y, 0.02, 100.0, 0)}, {{1, 1, 1, 1}})).ok());
        const DrawItem item{0, glm::mat4(1.0f)};
        StereoImage panel;
        ASSERT_TRUE(r->render(views_for(glm::dquat(1, 0, 0, 0), fov), {&item, 1}, nullptr).ok());
        ASSERT_TRUE(r->warp(glm::dquat(1, 0, 0, 0), &panel).ok());
        for (int e = 0; e < 2; ++e)
            for (int c = 0; c < 3; ++c) {
                const glm::dvec2 expected = panel_position_of(profile, e, c, t, w, h);
                const glm::dvec2 got = centroid(panel.eye[e], c);
                EXPECT_NEAR(got.x, expected.x, tolerance_px)
                    << profile.name << " eye " << e << " channel " << c << " t " << t.x << ","
                    << t.y;
                EXPECT_NEAR(got.y, expected.y, tolerance_px)
                    << profile.name << " eye " << e << " channel " << c << " t " << t.x << ","
                    << t.y;
            }
    }
}

TEST(Warp, DistortionFollowsTheGenericLensModel) {
    check_lens(generic_headset_profile(), 216, 240, 0.5);
}

TEST(Warp, DistortionAndChromaticAberrationFollowTheIndexLensModel) {
    auto index = load_headset_profile(HMDNODE_SOURCE_DIR "/data/headsets/valve-index.json");
    ASSERT_TRUE(index.ok()) << index.error().message;
    check_lens(*index, 360, 400, 0.5);
    // The Index's lateral chromatic aberration is visible at this size: red and blue land apart.
    const glm::dvec2 t(-0.6, -0.35);
    const double split = glm::length(panel_position_of(*index, 0, 0, t, 360, 400) -
                                     panel_position_of(*index, 0, 2, t, 360, 400));
    EXPECT_GT(split, 1.0);
}

TEST(Warp, TheFusedPassFollowsTheGenericLensModelPerPixel) {
    check_lens(generic_headset_profile(), 216, 240, 0.5, true);
}

TEST(Warp, TheFusedPassFollowsTheIndexLensModelAndItsChromaticAberrationPerPixel) {
    auto index = load_headset_profile(HMDNODE_SOURCE_DIR "/data/headsets/valve-index.json");
    ASSERT_TRUE(index.ok()) << index.error().message;
    check_lens(*index, 360, 400, 0.5, true);
}

// With chromatic-aberration correction off, either pass samples every colour through the green
// channel's lens: a white marker's red and blue land where its green does.
TEST(Warp, WithChromaticAberrationOffEveryColourFollowsGreen) {
    auto index = load_headset_profile(HMDNODE_SOURCE_DIR "/data/headsets/valve-index.json");
    ASSERT_TRUE(index.ok()) << index.error().message;
    const int w = 360, h = 400;
    for (bool fused : {true, false}) {
        auto r = make_renderer(w, h);
        ASSERT_TRUE(r);
        if (fused)
            ASSERT_TRUE(r->set_lens_warp(w, h, *index).ok());
        else
            ASSERT_TRUE(r->set_warp(w, h, make_distortion_mesh(*index, 0, 64, 64),
                                    make_distortion_mesh(*index, 1, 64, 64))
                            .ok());
        EXPECT_TRUE(r->chromatic_aberration());
        r->set_chromatic_aberration(false);
        EXPECT_FALSE(r->chromatic_aberration());
        const EyeFov fov[2] = {lens_render_fov(*index, 0), lens_render_fov(*index, 1)};
        const glm::dvec2 t(-0.6, -0.35);
        ASSERT_TRUE(r->upload(scene_of({marker(t.x, t.y, 0.02, 100.0, 0)}, {{1, 1, 1, 1}})).ok());
        const DrawItem item{0, glm::mat4(1.0f)};
        StereoImage panel;
        ASSERT_TRUE(r->render(views_for(glm::dquat(1, 0, 0, 0), fov), {&item, 1}, nullptr).ok());
        ASSERT_TRUE(r->warp(glm::dquat(1, 0, 0, 0), &panel).ok());
        const glm::dvec2 green = panel_position_of(*index, 0, 1, t, w, h);
        for (int c = 0; c < 3; ++c) {
            const glm::dvec2 got = centroid(panel.eye[0], c);
            EXPECT_NEAR(got.x, green.x, 0.5) << "channel " << c << (fused ? " fused" : " mesh");
            EXPECT_NEAR(got.y, green.y, 0.5) << "channel " << c << (fused ? " fused" : " mesh");
        }
    }
}

// Dynamic resolution: a frame rendered into half the eye buffer per axis, with the same field of
// view, warps to the same panel positions as a full-size one (the marker is big enough to survive
// the coarser buffer), and a later scale applies to the next frame only.
TEST(Warp, AFrameAtHalfResolutionLandsWhereAFullOneDoes) {
    const HeadsetProfile profile = generic_headset_profile();
    const int w = 216, h = 240;
    for (bool fused : {false, true}) {
        auto r = make_renderer(w, h);
        ASSERT_TRUE(r);
        const DistortionMesh mesh[2] = {make_distortion_mesh(profile, 0, 32, 32),
                                        make_distortion_mesh(profile, 1, 32, 32)};
        const EyeFov fov[2] = {mesh_render_fov(mesh[0]), mesh_render_fov(mesh[1])};
        ASSERT_TRUE(
            (fused ? r->set_lens_warp(w, h, profile) : r->set_warp(w, h, mesh[0], mesh[1])).ok());
        EXPECT_FALSE(r->set_render_scale(0.0).ok());
        EXPECT_FALSE(r->set_render_scale(1.5).ok());
        for (const glm::dvec2 t : {glm::dvec2(0.3, -0.2), glm::dvec2(-0.5, 0.4)}) {
            ASSERT_TRUE(
                r->upload(scene_of({marker(t.x, t.y, 0.08, 100.0, 0)}, {{1, 1, 1, 1}})).ok());
            const DrawItem item{0, glm::mat4(1.0f)};
            StereoImage full, half;
            ASSERT_TRUE(r->set_render_scale(1.0).ok());
            ASSERT_TRUE(
                r->render(views_for(glm::dquat(1, 0, 0, 0), fov), {&item, 1}, nullptr).ok());
            ASSERT_TRUE(r->warp(glm::dquat(1, 0, 0, 0), &full).ok());
            ASSERT_TRUE(r->set_render_scale(0.5).ok());
            EXPECT_DOUBLE_EQ(r->render_scale(), 0.5);
            // The finished frame keeps its scale until the next one is rendered.
            StereoImage again;
            ASSERT_TRUE(r->warp(glm::dquat(1, 0, 0, 0), &again).ok());
            EXPECT_EQ(again.eye[0].pixels, full.eye[0].pixels);
            ASSERT_TRUE(
                r->render(views_for(glm::dquat(1, 0, 0, 0), fov), {&item, 1}, nullptr).ok());
            ASSERT_TRUE(r->warp(glm::dquat(1, 0, 0, 0), &half).ok());
            EXPECT_NE(half.eye[0].pixels, full.eye[0].pixels);
            for (int e = 0; e < 2; ++e) {
                const glm::dvec2 a = centroid(full.eye[e], 1), b = centroid(half.eye[e], 1);
                EXPECT_GT(a.x, 0.0);
                EXPECT_NEAR(a.x, b.x, 1.0) << (fused ? "fused" : "mesh") << " eye " << e;
                EXPECT_NEAR(a.y, b.y, 1.0) << (fused ? "fused" : "mesh") << " eye " << e;
            }
        }
    }
}

TEST(Warp, AFrameInPiecesEqualsOneRenderAndTheWarpReadsTheFinishedFrameMeanwhile) {
    const int w = 64, h = 64;
    auto r = make_renderer(w, h);
    ASSERT_TRUE(r);
    // Three meshes, one draw item each, overlapping (the depth test must carry across pieces).
    Scene s =
        scene_of({marker(0.0, 0.0, 0.8, 5.0, 0)},
                 {{1.0f, 0.2f, 0.1f, 1.0f}, {0.1f, 0.9f, 0.2f, 1.0f}, {0.2f, 0.3f, 1.0f, 1.0f}});
    s.meshes.push_back(Mesh{"b", {marker(0.2, 0.1, 0.6, 4.0, 1)}});
    s.meshes.push_back(Mesh{"c", {marker(-0.2, -0.1, 0.6, 6.0, 2)}});
    ASSERT_TRUE(r->upload(s).ok());
    const EyeFov fov[2] = {EyeFov{}, EyeFov{}};
    ASSERT_TRUE(r->set_warp(w, h, linear_mesh(fov[0]), linear_mesh(fov[1])).ok());
    const DrawItem items[3] = {{2, glm::mat4(1.0f)}, {0, glm::mat4(1.0f)}, {1, glm::mat4(1.0f)}};
    const StereoViews a = views_for(glm::dquat(1, 0, 0, 0), fov);
    const StereoViews b = views_for(glm::angleAxis(0.1, glm::dvec3(0, 1, 0)), fov);
    StereoImage whole_a, whole_b, panel;
    ASSERT_TRUE(r->render(b, items, &whole_b).ok());
    ASSERT_TRUE(r->render(a, items, &whole_a).ok());
    // Frame b again, one item per piece; meanwhile the warp still shows frame a.
    ASSERT_TRUE(r->begin_frame(b, items).ok());
    size_t pieces = 0, n = 0;
    for (;;) {
        auto done = r->render_more(1, &n);
        ASSERT_TRUE(done.ok()) << done.error().message;
        EXPECT_EQ(n, 1u);
        ++pieces;
        if (*done) break;
        ASSERT_TRUE(r->warp(glm::dquat(1, 0, 0, 0), &panel).ok());
        EXPECT_EQ(panel.eye[0].pixels, whole_a.eye[0].pixels) << "piece " << pieces;
    }
    EXPECT_EQ(pieces, 3u);
    ASSERT_TRUE(r->warp(glm::dquat(1, 0, 0, 0), &panel).ok());
    for (int e = 0; e < 2; ++e) EXPECT_EQ(panel.eye[e].pixels, whole_b.eye[e].pixels) << e;
}

TEST(Warp, BeforeSetUpOrRenderIsAnError) {
    auto r = make_renderer(16, 16);
    ASSERT_TRUE(r);
    auto early = r->warp(glm::dquat(1, 0, 0, 0), nullptr);
    ASSERT_FALSE(early.ok());
    EXPECT_NE(early.error().message.find("set_warp"), std::string::npos);
    const EyeFov fov{};
    ASSERT_TRUE(r->set_warp(16, 16, linear_mesh(fov), linear_mesh(fov)).ok());
    auto no_frame = r->warp(glm::dquat(1, 0, 0, 0), nullptr);
    ASSERT_FALSE(no_frame.ok());
    EXPECT_NE(no_frame.error().message.find("render"), std::string::npos);
    EXPECT_FALSE(r->set_warp(16, 16, DistortionMesh{}, linear_mesh(fov)).ok());
    EXPECT_FALSE(r->set_lens_warp(0, 16, generic_headset_profile()).ok());
}

}  // namespace
}  // namespace hmdnode
