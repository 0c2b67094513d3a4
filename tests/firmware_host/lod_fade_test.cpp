// No pops, end to end on the simulated clock with the Vulkan renderer (lavapipe): a head moving
// to and from three LOD objects makes their levels change; without transitions every visible
// change is a pop, with them none is, and each transition frame draws the old and the new level
// with complementary screen-door masks whose pixels cover the object exactly once.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <memory>

#include <nlohmann/json.hpp>

#include "firmware_host/command_run.hpp"
#include "hmdnode/core/gltf.hpp"
#include "hmdnode/firmware_host/node.hpp"
#include "hmdnode/firmware_host/replay.hpp"
#include "hmdnode/hal/display/mock_display.hpp"
#include "hmdnode/hal/sim/sim_tracker.hpp"

using namespace hmdnode;
namespace fs = std::filesystem;

namespace {

constexpr int kEye = 64;

// Three objects 1.5 m apart at head height; level 0 a square (1.2 m, four triangles), level 1 a
// diamond inside it (two triangles, 0.1 m error): the silhouettes differ.
Scene fade_scene() {
    Scene s;
    Material m;
    m.base_color_factor = {1.0f, 1.0f, 1.0f, 1.0f};
    m.double_sided = true;
    s.materials.push_back(m);
    Primitive square;
    square.positions = {
        {-0.6f, -0.6f, 0}, {0.6f, -0.6f, 0}, {0.6f, 0.6f, 0}, {-0.6f, 0.6f, 0}, {0.0f, 0.0f, 0}};
    square.indices = {0, 1, 4, 1, 2, 4, 2, 3, 4, 3, 0, 4};
    square.material = 0;
    Primitive diamond;
    diamond.positions = {{0.0f, -0.6f, 0}, {0.6f, 0.0f, 0}, {0.0f, 0.6f, 0}, {-0.6f, 0.0f, 0}};
    diamond.indices = {0, 1, 2, 0, 2, 3};
    diamond.material = 0;
    s.meshes.push_back(Mesh{"square", {square}});
    s.meshes.push_back(Mesh{"diamond", {diamond}});
    for (int i = 0; i < 3; ++i) {
        const glm::dvec3 at{1.5 * (i - 1), 1.6, 0.0};
        Node head;
        head.name = "object" + std::to_string(i);
        head.translation = at;
        head.mesh = 0;
        head.geometric_error_m = 0.0;
        const int first = int(s.nodes.size());
        head.lod_ids = {first + 1};
        s.nodes.push_back(head);
        s.roots.push_back(first);
        Node coarse;
        coarse.mesh = 1;
        coarse.geometric_error_m = 0.1;
        coarse.translation = at;
        s.nodes.push_back(coarse);
    }
    return s;
}

// The head looks at the objects (-Z) from 1 to 4.5 m away and back, every 2 s, for `seconds`.
std::shared_ptr<const Trace> to_and_fro(double seconds) {
    auto t = std::make_shared<Trace>();
    for (int i = 0; i <= int(seconds * 1000); ++i) {
        TraceSample s;
        s.time_ns = int64_t(i) * kNsPerMs;
        s.position = glm::dvec3(0.0, 1.6, 2.75 - 1.75 * std::cos(kPi * i / 1000.0));
        t->samples.push_back(s);
    }
    return t;
}

// Forwards to the Vulkan renderer and keeps every frame's views and draw items.
class RecordingRenderer final : public Renderer {
  public:
    explicit RecordingRenderer(std::unique_ptr<Renderer> r) : r_(std::move(r)) {}
    Status upload(const Scene& s) override { return r_->upload(s); }
    Result<RenderStats> render(const StereoViews& v, std::span<const DrawItem> items,
                               StereoImage* out) override {
        return r_->render(v, items, out);
    }
    Status begin_frame(const StereoViews& v, std::span<const DrawItem> items) override {
        frames.push_back({v, std::vector<DrawItem>(items.begin(), items.end())});
        return r_->begin_frame(v, items);
    }
    Result<bool> render_more(uint64_t max_triangles, size_t* n) override {
        return r_->render_more(max_triangles, n);
    }
    Status set_warp(int w, int h, const DistortionMesh& l, const DistortionMesh& r) override {
        return r_->set_warp(w, h, l, r);
    }
    Result<WarpStats> warp(const glm::dquat& d, StereoImage* out) override {
        return r_->warp(d, out);
    }
    Status set_lens_warp(int w, int h, const HeadsetProfile& p) override {
        return r_->set_lens_warp(w, h, p);
    }
    const char* lens_pass_name() const override { return r_->lens_pass_name(); }
    void set_chromatic_aberration(bool on) override { r_->set_chromatic_aberration(on); }
    void set_latency_marker(const LatencyMarkerOverlay* o) override { r_->set_latency_marker(o); }
    bool chromatic_aberration() const override { return r_->chromatic_aberration(); }
    Status set_render_scale(double s) override { return r_->set_render_scale(s); }
    double render_scale() const override { return r_->render_scale(); }
    std::string device_name() const override { return r_->device_name(); }
    const char* backend_name() const override { return r_->backend_name(); }
    int msaa_samples() const override { return r_->msaa_samples(); }
    Renderer& inner() { return *r_; }

    struct Frame {
        StereoViews views;
        std::vector<DrawItem> items;
    };
    std::vector<Frame> frames;

  private:
    std::unique_ptr<Renderer> r_;
};

struct FadeRun {
    std::vector<FrameRecord> records;
    ReplaySummary summary;
    std::unique_ptr<RecordingRenderer> renderer;
};

FadeRun run(int fade_frames, double seconds) {
    SimulatedClock clock(0);
    auto trace = to_and_fro(seconds + 0.5);
    auto tracker = create_sim_tracker(trace, clock, SimTrackerConfig{});
    EXPECT_TRUE(tracker.ok());
    MockDisplayConfig dc;
    dc.eye_width = dc.eye_height = kEye;
    auto display = create_mock_display(clock, dc);
    EXPECT_TRUE(display.ok());
    RendererConfig rc;
    rc.eye_width = rc.eye_height = kEye;
    auto vk = create_vulkan_renderer(rc);
    EXPECT_TRUE(vk.ok()) << (vk.ok() ? "" : vk.error().message);
    FadeRun r;
    r.renderer = std::make_unique<RecordingRenderer>(std::move(*vk));
    const Scene scene = fade_scene();
    NodeConfig nc;
    nc.lod_fade_frames = fade_frames;
    nc.read_back = false;
    nc.sim_cost.base_ns = 2 * kNsPerMs;
    nc.sim_cost.warp_ns = kNsPerMs;
    NodeRuntime node(clock, **tracker, **display, *r.renderer, scene, nc);
    EXPECT_TRUE(node.start().ok());
    FrameRecord rec;
    while (clock.now_ns() < s_to_ns(seconds)) {
        Result<FrameOutcome> fr = node.run_frame(&rec);
        EXPECT_TRUE(fr.ok()) << (fr.ok() ? "" : fr.error().message);
        if (!fr.ok()) break;
        if (*fr != FrameOutcome::no_pose_yet) r.records.push_back(rec);
    }
    node.stop();
    r.summary = summarize_presents(r.records, (*display)->info().period_ns, nullptr, 1.0);
    return r;
}

ImageRGBA8 left_eye(Renderer& r, const StereoViews& v, const DrawItem& item) {
    StereoImage img;
    auto s = r.render(v, {&item, 1}, &img);
    EXPECT_TRUE(s.ok()) << (s.ok() ? "" : s.error().message);
    return img.eye[0];
}

}  // namespace

TEST(LodFade, WithoutTransitionsLevelChangesPopAndWithThemNoneDoes) {
    const FadeRun off = run(0, 6.0);
    const FadeRun on = run(3, 6.0);
    // Three objects change level about twice per 2 s cycle.
    EXPECT_GE(off.summary.lod_pops, 12u);
    EXPECT_EQ(off.summary.lod_transitions, 0u);
    EXPECT_EQ(off.summary.lod_fading_frames, 0u);
    EXPECT_NEAR(off.summary.lod_pops_per_min, double(off.summary.lod_pops) / (6.0 / 60.0),
                0.05 * off.summary.lod_pops_per_min);
    EXPECT_EQ(on.summary.lod_pops, 0u);
    EXPECT_DOUBLE_EQ(on.summary.lod_pops_per_min, 0.0);
    EXPECT_GE(on.summary.lod_transitions, 12u);
    EXPECT_GE(on.summary.lod_fading_frames, 3u);  // objects change together: frames are shared

    // Each transition: three new frames draw both levels of the object, masks +k and -k with k
    // rising 4, 8, 12, then the new level alone.
    size_t pairs = 0;
    for (const RecordingRenderer::Frame& f : on.renderer->frames) {
        std::map<float, std::vector<DrawItem>> by_object;  // keyed by the world x
        for (const DrawItem& d : f.items) by_object[d.world[3][0]].push_back(d);
        for (const auto& [x, draws] : by_object) {
            ASSERT_LE(draws.size(), 2u);
            if (draws.size() == 1) {
                EXPECT_EQ(draws[0].dither, 0);
                continue;
            }
            ++pairs;
            EXPECT_NE(draws[0].mesh, draws[1].mesh);
            EXPECT_EQ(draws[0].dither, -draws[1].dither);
            const int k = std::abs(draws[0].dither);
            EXPECT_TRUE(k == 4 || k == 8 || k == 12) << k;
        }
    }
    // Three frames per transition (the run may end in the middle of some).
    EXPECT_LE(pairs, 3 * on.summary.lod_transitions);
    EXPECT_GE(pairs + 6, 3 * on.summary.lod_transitions);

    // Pixels of a transition frame of the middle object: no pixel shows both levels, and where
    // both levels cover a pixel exactly one of them is drawn there.
    const RecordingRenderer::Frame* fading = nullptr;
    for (const RecordingRenderer::Frame& f : on.renderer->frames)
        for (const DrawItem& d : f.items)
            if (d.dither == 8 && d.world[3][0] == 0.0f && !fading) fading = &f;
    ASSERT_NE(fading, nullptr);
    std::vector<DrawItem> pair;
    for (const DrawItem& d : fading->items)
        if (d.dither != 0 && d.world[3][0] == 0.0f) pair.push_back(d);
    ASSERT_EQ(pair.size(), 2u);
    Renderer& vk = on.renderer->inner();
    const ImageRGBA8 a = left_eye(vk, fading->views, pair[0]);
    const ImageRGBA8 b = left_eye(vk, fading->views, pair[1]);
    DrawItem a_full = pair[0], b_full = pair[1];
    a_full.dither = b_full.dither = 0;
    const ImageRGBA8 af = left_eye(vk, fading->views, a_full);
    const ImageRGBA8 bf = left_eye(vk, fading->views, b_full);
    int both = 0;
    for (int y = 0; y < kEye; ++y)
        for (int x = 0; x < kEye; ++x) {
            const bool in_a = a.at(x, y)[0] > 0, in_b = b.at(x, y)[0] > 0;
            EXPECT_FALSE(in_a && in_b) << x << "," << y;
            if (af.at(x, y)[0] > 0 && bf.at(x, y)[0] > 0) {
                ++both;
                EXPECT_TRUE(in_a || in_b) << x << "," << y;
            }
        }
    EXPECT_GT(both, 20);
}

TEST(LodFade, TheReplayReportCountsPopsPerMinuteAndNamesTheSettings) {
    const fs::path dir = hmdnode::test::fresh_temp_dir("hmdnode_lod_fade_test");
    Scene scene = fade_scene();
    ASSERT_TRUE(save_glb(scene, dir / "fade.glb").ok());
    ReplayOptions o;
    o.scene = dir / "fade.glb";
    o.trace_data = to_and_fro(4.0);
    o.display.eye_width = o.display.eye_height = kEye;
    o.renderer.msaa_samples = 4;
    FrameCostModel cost;
    cost.base_ns = 2 * kNsPerMs;
    cost.warp_ns = kNsPerMs;
    o.frame_cost = cost;
    for (int fade : {0, 3}) {
        o.node.lod_fade_frames = fade;
        auto r = run_replay(o);
        ASSERT_TRUE(r.ok()) << r.error().message;
        const nlohmann::json j = replay_report_json(o, *r);
        EXPECT_EQ(j["lod_fade_frames"], fade);
        EXPECT_EQ(j["msaa_samples"], 4);
        const nlohmann::json& s = j["summary"];
        if (fade == 0) {
            EXPECT_GT(s["lod_pops"].get<size_t>(), 0u);
            EXPECT_GT(s["lod_pops_per_min"].get<double>(), 60.0);
        } else {
            EXPECT_EQ(s["lod_pops"], 0);
            EXPECT_EQ(s["lod_pops_per_min"], 0.0);
            EXPECT_GT(s["lod_transitions"].get<size_t>(), 0u);
        }
        EXPECT_NE(replay_summary_table(*r).find("MSAA 4x"), std::string::npos);
    }
    o.node.lod_fade_frames = 16;
    EXPECT_FALSE(check_replay_options(o).ok());
    o.node.lod_fade_frames = 3;
    o.renderer.msaa_samples = 2;
    Status bad = check_replay_options(o);
    ASSERT_FALSE(bad.ok());
    EXPECT_NE(bad.error().message.find("MSAA samples 2"), std::string::npos);
}
