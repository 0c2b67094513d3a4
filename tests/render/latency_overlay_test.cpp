// The latency marker overlay of the lens pass (Renderer::set_latency_marker), on the backend
// HMDNODE_RENDERER names (ctest runs this suite on Vulkan and on GLES): with the marker on, the
// panel read back is exactly the panel without it with draw_latency_marker() applied (the CPU
// reference), for the fused pass and the mesh pass, and the id decodes from it; with it off again
// the panel is pixel-identical to one never marked; a marker past the panel's edge is clipped.
#include <gtest/gtest.h>

#include "hmdnode/core/latency_marker.hpp"
#include "hmdnode/core/stereo.hpp"
#include "hmdnode/render/lens.hpp"
#include "hmdnode/render/renderer.hpp"

namespace hmdnode {
namespace {

constexpr int kEye = 96, kPanelW = 120, kPanelH = 132;

// A scene of one bright quad straight ahead, so the lens pass draws something under the marker.
Scene quad_scene() {
    Scene s;
    Material m;
    m.base_color_factor = {0.8f, 0.5f, 0.2f, 1.0f};
    m.double_sided = true;
    s.materials.push_back(m);
    Primitive p;
    p.positions = {{-1, -1, -2}, {1, -1, -2}, {1, 1, -2}, {-1, 1, -2}};
    p.indices = {0, 1, 2, 0, 2, 3};
    p.material = 0;
    s.meshes.push_back(Mesh{"quad", {p}});
    return s;
}

struct Fixture {
    std::unique_ptr<Renderer> r;
    Status setup(bool fused) {
        RendererConfig config;
        config.eye_width = config.eye_height = kEye;
        auto made = create_renderer(config);
        if (!made) return made.error();
        r = std::move(made.value());
        if (Status s = r->upload(quad_scene()); !s) return s;
        const HeadsetProfile profile = generic_headset_profile();
        if (fused) {
            if (Status s = r->set_lens_warp(kPanelW, kPanelH, profile); !s) return s;
        } else {
            const DistortionMesh left = make_distortion_mesh(profile, 0, 16, 16);
            const DistortionMesh right = make_distortion_mesh(profile, 1, 16, 16);
            if (Status s = r->set_warp(kPanelW, kPanelH, left, right); !s) return s;
        }
        StereoViews v;
        const StereoRig rig = StereoRig::typical();
        for (int e = 0; e < 2; ++e) {
            v.view[e] = eye_view_matrix(rig, Pose{}, e);
            v.projection[e] = eye_projection(rig.eye[e], 0.1, 100.0);
        }
        const DrawItem item{0, glm::mat4(1.0f), 0};
        auto rendered = r->render(v, {&item, 1}, nullptr);
        if (!rendered) return rendered.error();
        return Status::success();
    }
    StereoImage warp() {
        StereoImage out;
        auto w = r->warp(glm::dquat(1, 0, 0, 0), &out);
        EXPECT_TRUE(w) << (w ? "" : w.error().message);
        return out;
    }
};

void check_marked(bool fused) {
    Fixture f;
    Status s = f.setup(fused);
    ASSERT_TRUE(s) << s.error().message;
    const StereoImage plain = f.warp();
    ASSERT_EQ(plain.eye[0].width, kPanelW);
    LatencyMarkerOverlay o = default_latency_marker_overlay(kPanelW, kPanelH, 3);
    o.payload = make_latency_marker_payload(1'234'567'890'123, 4242);
    f.r->set_latency_marker(&o);
    const StereoImage marked = f.warp();
    for (int e = 0; e < 2; ++e) {
        ImageRGBA8 expected = plain.eye[e];
        draw_latency_marker(expected, o.payload, o.x, o.y, o.cell_px);
        EXPECT_TRUE(expected.pixels == marked.eye[e].pixels)
            << "eye " << e << (fused ? " fused" : " mesh") << ": not the reference marker";
        EXPECT_FALSE(plain.eye[e].pixels == marked.eye[e].pixels);  // it drew something
        const std::vector<uint8_t> g = grey_of(marked.eye[e]);
        const LatencyMarkerDecode d = decode_latency_marker(g.data(), kPanelW, kPanelH, kPanelW);
        ASSERT_TRUE(d.ok) << d.reason;
        EXPECT_EQ(d.payload, o.payload);
    }
    f.r->set_latency_marker(nullptr);
    const StereoImage off = f.warp();
    for (int e = 0; e < 2; ++e) EXPECT_TRUE(off.eye[e].pixels == plain.eye[e].pixels) << e;
}

TEST(LatencyOverlay, FusedPassDrawsTheReferenceMarkerAndNothingWhenOff) {
    check_marked(true);
}

TEST(LatencyOverlay, MeshPassDrawsTheReferenceMarkerAndNothingWhenOff) {
    check_marked(false);
}

TEST(LatencyOverlay, AMarkerPastTheEdgeIsClipped) {
    Fixture f;
    Status s = f.setup(true);
    ASSERT_TRUE(s) << s.error().message;
    const StereoImage plain = f.warp();
    LatencyMarkerOverlay o;
    o.cell_px = 4;
    o.x = kPanelW - 20;
    o.y = -10;
    o.payload = make_latency_marker_payload(99'000, 7);
    f.r->set_latency_marker(&o);
    const StereoImage marked = f.warp();
    ImageRGBA8 expected = plain.eye[1];
    draw_latency_marker(expected, o.payload, o.x, o.y, o.cell_px);
    EXPECT_TRUE(expected.pixels == marked.eye[1].pixels);
    const std::vector<uint8_t> g = grey_of(marked.eye[1]);
    EXPECT_FALSE(decode_latency_marker(g.data(), kPanelW, kPanelH, kPanelW).ok);
}

TEST(LatencyOverlay, DefaultPlaceIsInsideThePanelNearTheTop) {
    const LatencyMarkerOverlay o = default_latency_marker_overlay(360, 400, 4);
    EXPECT_EQ(o.x, (360 - 56) / 2);
    EXPECT_EQ(o.y, 40);
    EXPECT_LE(o.y + latency_marker_size_px(4), 400 / 2);
}

}  // namespace
}  // namespace hmdnode
