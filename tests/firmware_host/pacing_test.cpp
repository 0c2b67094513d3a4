// Frame pacing and honest accounting of the node runtime on the simulated clock, with a scripted
// renderer whose cost per frame the test chooses (spikes, a render slower than the refresh), the
// simulated tracker and the mock display; and the per-vsync summary on hand-made presents.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <functional>
#include <memory>

#include "hmdnode/firmware_host/node.hpp"
#include "hmdnode/firmware_host/replay.hpp"
#include "hmdnode/hal/display/mock_display.hpp"
#include "hmdnode/hal/sim/sim_tracker.hpp"

using namespace hmdnode;

namespace {

// A renderer that draws nothing and costs what the script says, by advancing the simulated clock:
// a frame's cost is spread over its pieces by their share of the draw items.
class ScriptedRenderer final : public Renderer {
  public:
    ScriptedRenderer(SimulatedClock& clock, std::function<int64_t(int)> render_cost,
                     int64_t warp_cost)
        : clock_(clock), render_cost_(std::move(render_cost)), warp_cost_(warp_cost) {}
    Status upload(const Scene&) override { return Status::success(); }
    Result<RenderStats> render(const StereoViews& views, std::span<const DrawItem> items,
                               StereoImage*) override {
        if (Status s = begin_frame(views, items); !s.ok()) return s.error();
        Result<bool> done = render_more(UINT64_MAX, nullptr);
        if (!done.ok()) return done.error();
        return RenderStats{};
    }
    Status begin_frame(const StereoViews&, std::span<const DrawItem> items) override {
        clock_.advance_ns(setup_cost_);  // recording, uploads, waits a driver makes here
        items_ = items.size();
        cursor_ = 0;
        frame_cost_ = render_cost_(renders_++);
        // A pixel-bound renderer: the cost falls with the pixels of the eye buffers.
        if (pixel_bound_) frame_cost_ = int64_t(double(frame_cost_) * scale_ * scale_);
        return Status::success();
    }
    // One item per piece when max_triangles is limited (the test's items have 12 triangles).
    Result<bool> render_more(uint64_t max_triangles, size_t* items_rendered) override {
        const size_t n =
            items_ == 0 ? 0
            : max_triangles == UINT64_MAX
                ? items_ - cursor_
                : std::max<size_t>(1, std::min<size_t>(items_ - cursor_, max_triangles / 12));
        clock_.advance_ns(items_ == 0 ? frame_cost_ : frame_cost_ * int64_t(n) / int64_t(items_));
        cursor_ += n;
        pieces_ += 1;
        if (items_rendered) *items_rendered = n;
        return cursor_ >= items_;
    }
    Status set_warp(int, int, const DistortionMesh&, const DistortionMesh&) override {
        return Status::success();
    }
    Result<WarpStats> warp(const glm::dquat&, StereoImage*) override {
        int64_t cost = warp_sequence_ ? warp_sequence_(warps_) : warp_cost_;
        ++warps_;
        // Without chromatic-aberration correction: one sample per pixel instead of three.
        if (!chromatic_) cost = cost * 2 / 5;
        clock_.advance_ns(cost);
        return WarpStats{};
    }
    Status set_lens_warp(int, int, const HeadsetProfile&) override { return Status::success(); }
    const char* lens_pass_name() const override { return "fused"; }
    void set_chromatic_aberration(bool on) override { chromatic_ = on; }
    void set_latency_marker(const LatencyMarkerOverlay*) override {}
    bool chromatic_aberration() const override { return chromatic_; }
    Status set_render_scale(double scale) override {
        scale_ = scale;
        return Status::success();
    }
    double render_scale() const override { return scale_; }
    std::string device_name() const override { return "scripted"; }
    const char* backend_name() const override { return "scripted"; }
    int renders() const { return renders_; }
    void set_setup_cost(int64_t ns) { setup_cost_ = ns; }
    void set_pixel_bound(bool on) { pixel_bound_ = on; }
    void set_warp_sequence(std::function<int64_t(int)> f) { warp_sequence_ = std::move(f); }
    int pieces() const { return pieces_; }

  private:
    SimulatedClock& clock_;
    std::function<int64_t(int)> render_cost_;
    int64_t warp_cost_;
    int renders_ = 0, pieces_ = 0;
    size_t items_ = 0, cursor_ = 0;
    int64_t frame_cost_ = 0;
    int64_t setup_cost_ = 0;
    bool chromatic_ = true;
    double scale_ = 1.0;
    bool pixel_bound_ = false;
    std::function<int64_t(int)> warp_sequence_;
    int warps_ = 0;
};

// The simulated clock as the node sees it, with a thread that wakes `late_ns` after the time it
// asked for, as a system clock's sleep does (tens of microseconds or more).
class OversleepingClock final : public Clock {
  public:
    OversleepingClock(SimulatedClock& clock, int64_t late_ns) : clock_(clock), late_ns_(late_ns) {}
    int64_t now_ns() const override { return clock_.now_ns(); }
    void sleep_until_ns(int64_t t_ns) override {
        if (t_ns > clock_.now_ns()) clock_.sleep_until_ns(t_ns + late_ns_);
    }
    bool is_simulated() const override { return true; }

  private:
    SimulatedClock& clock_;
    int64_t late_ns_;
};

// Twenty boxes of 12 triangles on a ring around the viewer, one draw item each: whatever the
// heading, a few are in view (a frame always has items to render in pieces).
Scene boxes() {
    Scene s;
    s.materials.push_back(Material{});
    Primitive p;
    for (int i = 0; i < 8; ++i)
        p.positions.push_back(
            glm::vec3(i & 1 ? 0.1f : -0.1f, i & 2 ? 0.1f : -0.1f, i & 4 ? 0.1f : -0.1f));
    p.indices = {0, 2, 1, 0, 3, 2, 4, 5, 6, 4, 6, 7, 0, 1, 5, 0, 5, 4,
                 3, 6, 2, 3, 7, 6, 0, 4, 7, 0, 7, 3, 1, 2, 6, 1, 6, 5};
    p.material = 0;
    s.meshes.push_back(Mesh{"box", {p}});
    for (int i = 0; i < 20; ++i) {
        Node n;
        n.name = "box" + std::to_string(i);
        n.mesh = 0;
        const double a = deg_to_rad(18.0 * i);
        n.translation = {2.5 * std::sin(a), 1.6, -2.5 * std::cos(a)};
        s.nodes.push_back(n);
        s.roots.push_back(i);
    }
    return s;
}

// A constant 90 deg/s yaw sampled at 1 kHz for `seconds`.
std::shared_ptr<const Trace> yaw_trace(double seconds) {
    auto t = std::make_shared<Trace>();
    for (int i = 0; i <= int(seconds * 1000); ++i) {
        TraceSample s;
        s.time_ns = int64_t(i) * kNsPerMs;
        s.orientation = glm::angleAxis(deg_to_rad(90.0 * i / 1000.0), glm::dvec3(0, 1, 0));
        t->samples.push_back(s);
    }
    return t;
}

struct PacedRun {
    std::vector<FrameRecord> frames;
    ReplaySummary summary;
    int renders = 0, pieces = 0;
};

// What a run may change: the late warp, the trace the simulated tracker plays (default:
// yaw_trace), the node's settings, a call on the node at seconds/2, the renderer's set-up cost per
// frame and how late the node's clock wakes from each sleep.
struct RunOptions {
    bool warp = true;
    std::shared_ptr<const Trace> trace = nullptr;
    std::function<void(NodeConfig&)> config = {};
    std::function<void(NodeRuntime&)> midway = {};
    int64_t setup_cost_ns = 0;
    int64_t oversleep_ns = 0;
    bool pixel_bound = false;                        // render cost x scale^2 (the ladder's lever)
    std::function<int64_t(int)> warp_sequence = {};  // per warp, instead of the fixed warp cost
};

// Runs the node for `seconds` with the scripted costs and returns its presents and summary.
PacedRun run(std::function<int64_t(int)> render_cost, int64_t warp_cost, double seconds,
             RunOptions o = {}) {
    const bool warp = o.warp;
    std::shared_ptr<const Trace> trace = o.trace;
    const std::function<void(NodeConfig&)>& config = o.config;
    const std::function<void(NodeRuntime&)>& midway = o.midway;
    SimulatedClock clock(0);
    if (!trace) trace = yaw_trace(seconds + 0.5);
    SimTrackerConfig tc;
    auto tracker = create_sim_tracker(trace, clock, tc);
    EXPECT_TRUE(tracker.ok());
    MockDisplayConfig dc;
    dc.eye_width = 32;
    dc.eye_height = 32;
    auto display = create_mock_display(clock, dc);
    EXPECT_TRUE(display.ok());
    ScriptedRenderer renderer(clock, std::move(render_cost), warp_cost);
    renderer.set_setup_cost(o.setup_cost_ns);
    renderer.set_pixel_bound(o.pixel_bound);
    if (o.warp_sequence) renderer.set_warp_sequence(o.warp_sequence);
    const Scene scene = boxes();
    NodeConfig nc;
    nc.warp = warp;
    nc.sim_cost.base_ns = 0;
    nc.sim_cost.warp_ns = 0;
    if (config) config(nc);
    OversleepingClock node_clock(clock, o.oversleep_ns);
    NodeRuntime node(node_clock, **tracker, **display, renderer, scene, nc);
    EXPECT_TRUE(node.start().ok());
    TruthFn truth = [&](int64_t t) -> std::optional<TruthPose> {
        return TruthPose{trace->pose_at(t).orientation, std::nullopt};
    };
    PacedRun r;
    FrameRecord rec;
    bool midway_done = !midway;
    while (clock.now_ns() < s_to_ns(seconds)) {
        if (!midway_done && clock.now_ns() >= s_to_ns(seconds / 2)) {
            midway(node);
            midway_done = true;
        }
        Result<FrameOutcome> fr = node.run_frame(&rec, truth);
        EXPECT_TRUE(fr.ok());
        if (!fr.ok()) break;
        if (*fr != FrameOutcome::no_pose_yet) r.frames.push_back(rec);
    }
    node.stop();
    r.summary = summarize_presents(r.frames, (*display)->info().period_ns, truth, 1.0);
    r.renders = renderer.renders();
    r.pieces = renderer.pieces();
    return r;
}

}  // namespace

TEST(Pacing, ARenderThatFitsShowsANewFrameAtEveryVsync) {
    const PacedRun r = run([](int) { return 5 * kNsPerMs; }, kNsPerMs, 3.0);
    ASSERT_GT(r.summary.vsyncs, 250u);
    EXPECT_EQ(r.summary.missed_vsyncs, 0u);
    EXPECT_DOUBLE_EQ(r.summary.on_time_rate, 1.0);
    EXPECT_DOUBLE_EQ(r.summary.new_frames_per_vsync, 1.0);
    EXPECT_EQ(r.summary.rewarps, 0u);
    // Late warp: the pose is sampled about latch + warp + margin before vsync; motion-to-photon is
    // that plus the photon offset (5.56 + 1 ms) plus the sample's age (1 kHz, 1 ms transport).
    EXPECT_LT(r.summary.latency_ms.max, 11.1);
    // A constant turn is predicted exactly, so the warped pose matches the truth at photon time.
    EXPECT_LT(r.summary.registration_error_deg.max, 0.01);
}

TEST(Pacing, ASpikeMissesItsVsyncAndTheLoopDoesNotLockLate) {
    // Frame 100 takes 25 ms; every other frame 5 ms.
    const PacedRun r = run([](int i) { return (i == 100 ? 25 : 5) * kNsPerMs; }, kNsPerMs, 3.0);
    // The spike costs the vsyncs it spans, and only those: every later vsync is on time again.
    EXPECT_GE(r.summary.missed_vsyncs, 2u);
    EXPECT_LE(r.summary.missed_vsyncs, 3u);
    EXPECT_LE(r.summary.longest_late_run, 3u);
    size_t after = 0;
    for (const FrameRecord& f : r.frames)
        if (f.frame > 101) {
            EXPECT_TRUE(f.on_time) << f.index;
            EXPECT_EQ(f.missed_vsyncs_before, 0) << f.index;
            ++after;
        }
    EXPECT_GT(after, 150u);
    // The spike's frame was rendered for a vsync it could not make: it is late.
    EXPECT_EQ(r.summary.late_frames, 1u);
}

TEST(Pacing, ARenderSlowerThanTheRefreshIsCountedAsMissedVsyncs) {
    // 14 ms per render at 90 Hz: at most one new frame every other vsync; without the warp the
    // vsyncs in between repeat the old frame.
    const PacedRun r = run([](int) { return 14 * kNsPerMs; }, kNsPerMs, 3.0, {.warp = false});
    EXPECT_NEAR(r.summary.new_frames_per_vsync, 0.5, 0.02);
    // Every vsync without a new or re-warped frame counts as missed: about half of them.
    EXPECT_NEAR(double(r.summary.missed_vsyncs) / double(r.summary.vsyncs),
                1.0 - r.summary.on_time_rate, 1e-12);
    EXPECT_LE(r.summary.on_time_rate, 0.55);
    // A repeated frame ages: the latency of the vsyncs between new frames is one period longer.
    EXPECT_GT(r.summary.latency_ms.max - r.summary.latency_ms.p50 + 1e-9, 0.0);
    EXPECT_GT(r.summary.latency_ms.max, 11.1 + 5.0);
}

TEST(Pacing, VsyncsDuringASlowRenderGetTheFinishedFrameReWarped) {
    // 25 ms renders at 90 Hz: a new frame every third vsync at best. Between the render's pieces
    // the finished frame is warped again to the newest pose for each vsync the new one cannot
    // make, so those vsyncs are not missed and stay registered.
    const PacedRun r = run([](int) { return 25 * kNsPerMs; }, kNsPerMs, 3.0);
    EXPECT_GT(r.pieces, r.renders);
    EXPECT_GT(r.summary.rewarps, r.summary.new_frames);
    EXPECT_GT(r.summary.on_time_rate, 0.95);
    EXPECT_LE(r.summary.longest_late_run, 3u);
    for (const FrameRecord& f : r.frames)
        if (f.kind == FrameKind::rewarp) {
            EXPECT_TRUE(f.on_time) << f.index;
            EXPECT_LT(f.registration_error_deg, 0.01) << f.index;  // warped to the newest pose
        }
    // Once the costs are learnt (the ladder tries a lower resolution first and finds that it saves
    // nothing here), every present is on time and shows a pose sampled just before its latch.
    for (const FrameRecord& f : r.frames)
        if (f.photon_time_ns > s_to_ns(0.5)) {
            EXPECT_TRUE(f.on_time) << f.index;
            EXPECT_LT(f.latency_ms, 11.1) << f.index;
        }
    EXPECT_EQ(r.frames.back().render_scale, 1.0);  // the resolution that saved nothing is left
    // Without the warp the same vsyncs repeat an old image: missed, and it ages.
    const PacedRun plain = run([](int) { return 25 * kNsPerMs; }, kNsPerMs, 3.0, {.warp = false});
    EXPECT_EQ(plain.summary.rewarps, 0u);
    EXPECT_LT(plain.summary.on_time_rate, 0.4);
    EXPECT_GT(plain.summary.latency_ms.p50, 20.0);
}

TEST(Pacing, ADearWarpDoesNotStarveNewFrames) {
    // A warp pass dearer than half a period (llvmpipe at large panels) and a 14 ms render: re-warps
    // fill vsyncs, but at most two interrupt one frame, so new frames keep coming.
    const PacedRun r = run([](int) { return 14 * kNsPerMs; }, 7 * kNsPerMs, 3.0);
    EXPECT_GT(r.summary.rewarps, 0u);
    EXPECT_GT(r.summary.new_frames_per_vsync, 0.25);
}

TEST(Pacing, LateWarpCutsMotionToPhotonByTheRenderTime) {
    const PacedRun warped = run([](int) { return 6 * kNsPerMs; }, kNsPerMs, 2.0);
    const PacedRun plain = run([](int) { return 6 * kNsPerMs; }, kNsPerMs, 2.0, {.warp = false});
    EXPECT_NEAR(plain.summary.latency_ms.p50 - warped.summary.latency_ms.p50, 6.0, 1.5);
}

TEST(Accounting, EveryVsyncWithoutAFrameOnTimeIsMissedAndRepeatedFramesAge) {
    const int64_t period = 10 * kNsPerMs, offset = 2 * kNsPerMs;
    auto present = [&](int vsync, int target, int sampled_ms, FrameKind kind) {
        FrameRecord f;
        f.kind = kind;
        f.vsync_ns = vsync * period;
        f.target_vsync_ns = target * period;
        f.render_target_vsync_ns = target * period;
        f.on_time = vsync == target;
        f.late = kind == FrameKind::new_frame && vsync > target;
        f.photon_time_ns = f.vsync_ns + offset;
        f.pose_sample_time_ns = sampled_ms * kNsPerMs;
        f.latency_ms = ns_to_ms(f.photon_time_ns - f.pose_sample_time_ns);
        f.registration_error_deg = 0.0;
        return f;
    };
    // Vsyncs 1..6: 1 on time, 2 nothing, 3 late (meant for 2), 4 re-warp on time, 5 nothing,
    // 6 on time.
    const std::vector<FrameRecord> frames = {
        present(1, 1, 5, FrameKind::new_frame), present(3, 2, 21, FrameKind::new_frame),
        present(4, 4, 37, FrameKind::rewarp), present(6, 6, 57, FrameKind::new_frame)};
    const ReplaySummary s = summarize_presents(frames, period, nullptr, 1.0);
    EXPECT_EQ(s.vsyncs, 6u);
    EXPECT_EQ(s.missed_vsyncs, 3u);  // 2, 3 (late), 5
    EXPECT_DOUBLE_EQ(s.on_time_rate, 0.5);
    EXPECT_EQ(s.late_frames, 1u);
    EXPECT_EQ(s.rewarps, 1u);
    EXPECT_EQ(s.longest_late_run, 2u);  // 2 and 3
    EXPECT_DOUBLE_EQ(s.new_frames_per_vsync, 3.0 / 6.0);
    // Per vsync latency: 1: 12-5=7; 2: 22-5=17 (frame 1 again); 3: 32-21=11; 4: 42-37=5;
    // 5: 52-37=15; 6: 62-57=5.
    EXPECT_NEAR(s.latency_ms.max, 17.0, 1e-9);
    // p50 by nearest rank (core/percentile.hpp; it was the mean of the two middle values before
    // the project took one definition): the 3rd of 5, 5, 7, 11, 15, 17.
    EXPECT_NEAR(s.latency_ms.p50, 7.0, 1e-9);
}

// A frame's set-up (the selector, the draw list, begin_frame: on a GPU driver recording and
// uploads, several ms) is part of its cost: seen on an NVIDIA H200, where a 2.4 ms render after
// a longer set-up missed its vsync every time and the loop showed a new frame every other vsync.
// With 6 ms of set-up, 2 ms of render and 1 ms of warp a frame fits the 11.1 ms period.
TEST(Pacing, AFramesSetUpCountsAsItsCostSoItsVsyncIsMade) {
    const PacedRun r =
        run([](int) { return 2 * kNsPerMs; }, kNsPerMs, 3.0, {.setup_cost_ns = 6 * kNsPerMs});
    ASSERT_GT(r.summary.vsyncs, 250u);
    EXPECT_EQ(r.summary.missed_vsyncs, 0u);
    EXPECT_GT(r.summary.new_frames_per_vsync, 0.98);
    EXPECT_LE(r.summary.late_frames, 2u);  // the first frames, before the cost is learned
}

// A thread never wakes exactly when it asked: on the system clock every sleep ends a little late.
// The pacing's margin is the slack for that and for the estimates' error; the checks whether a
// frame still makes its vsync used the margin a second time, so any late wake-up re-aimed the new
// frame one vsync later (seen on an NVIDIA H200: one new frame every other vsync, every one late).
TEST(Pacing, AWakeUpALittleLateStillMakesTheVsync) {
    const PacedRun r =
        run([](int) { return 4 * kNsPerMs; }, kNsPerMs, 3.0, {.oversleep_ns = 100'000});
    ASSERT_GT(r.summary.vsyncs, 250u);
    EXPECT_EQ(r.summary.missed_vsyncs, 0u);
    EXPECT_GT(r.summary.new_frames_per_vsync, 0.98);
    EXPECT_LE(r.summary.late_frames, 2u);
}

// Recentre (the control socket's `recentre`): the heading of the newest pose becomes straight
// ahead (-z) while its pitch stays (gravity fixes it), and its position becomes the default head
// position; later motion is turned and moved with it.
TEST(Controls, RecentreTurnsTheHeadingToStraightAheadAndMovesThePositionHome) {
    auto still = std::make_shared<Trace>();
    const glm::dquat turned = glm::angleAxis(deg_to_rad(40.0), glm::dvec3(0, 1, 0)) *
                              glm::angleAxis(deg_to_rad(10.0), glm::dvec3(1, 0, 0));
    for (int i = 0; i <= 1500; ++i) {
        TraceSample s;
        s.time_ns = int64_t(i) * kNsPerMs;
        s.orientation = turned;
        s.position = glm::dvec3(0.5, 1.2, 0.3);
        still->samples.push_back(s);
    }
    const glm::dvec3 home{0.0, 1.6, 0.0};
    const PacedRun r =
        run([](int) { return 2 * kNsPerMs; }, kNsPerMs, 1.0,
            {.trace = still, .midway = [](NodeRuntime& n) { ASSERT_TRUE(n.recentre().ok()); }});
    ASSERT_GT(r.frames.size(), 60u);
    // Before: the pose as tracked. After: heading 0, pitch 10 degrees, at home.
    const Pose before = r.frames.front().shown_pose;
    const Pose after = r.frames.back().shown_pose;
    const glm::dvec3 fb = forward_of(before.orientation), fa = forward_of(after.orientation);
    EXPECT_NEAR(rad_to_deg(std::atan2(-fb.x, -fb.z)), 40.0, 1e-6);
    EXPECT_NEAR(rad_to_deg(std::atan2(-fa.x, -fa.z)), 0.0, 1e-6);
    EXPECT_NEAR(rad_to_deg(std::asin(fa.y)), 10.0, 1e-6);
    EXPECT_NEAR(glm::length(before.position - glm::dvec3(0.5, 1.2, 0.3)), 0.0, 1e-9);
    EXPECT_NEAR(glm::length(after.position - home), 0.0, 1e-9);
    // The head's own roll stays: the right vector is level before and after.
    EXPECT_NEAR((after.orientation * glm::dvec3(1, 0, 0)).y, 0.0, 1e-9);
}

// `node.prediction_ms` (config and control socket) predicts that much further ahead: with a
// 90 deg/s yaw, 20 ms more turns the shown heading 1.8 degrees further.
TEST(Controls, APredictionOffsetFromTheConfigTurnsTheShownPoseAhead) {
    auto heading = [](const FrameRecord& f) {
        const glm::dvec3 v = forward_of(f.shown_pose.orientation);
        return rad_to_deg(std::atan2(-v.x, -v.z));
    };
    const PacedRun plain = run([](int) { return 2 * kNsPerMs; }, kNsPerMs, 1.0, {.warp = false});
    const PacedRun ahead =
        run([](int) { return 2 * kNsPerMs; }, kNsPerMs, 1.0,
            {.warp = false, .config = [](NodeConfig& c) { c.prediction_offset_ms = 20.0; }});
    ASSERT_EQ(plain.frames.size(), ahead.frames.size());
    const size_t i = plain.frames.size() / 2;  // a heading well inside (-180, 180]
    ASSERT_EQ(plain.frames[i].vsync_ns, ahead.frames[i].vsync_ns);
    EXPECT_NEAR(heading(ahead.frames[i]) - heading(plain.frames[i]), 1.8, 1e-6);
}

namespace hmdnode {
namespace {

// The presents' share at the ladder's first (full) step, and the largest render-rate divisor.
double full_share(const PacedRun& r) {
    size_t full = 0;
    for (const FrameRecord& f : r.frames) full += f.ladder_step == 0;
    return double(full) / double(std::max<size_t>(1, r.frames.size()));
}

}  // namespace

TEST(Ladder, APixelBoundFrameStepsDownTheResolutionAndKeepsEveryVsync) {
    // 16 ms at full resolution (pixel-bound) in an 11.1 ms period with a 1.5 ms warp: only a lower
    // eye-buffer resolution makes every vsync.
    const PacedRun r =
        run([](int) { return 16 * kNsPerMs; }, 3 * kNsPerMs / 2, 4.0, {.pixel_bound = true});
    // After the first frames it settles on a step that fits and keeps it.
    size_t late_after = 0, step_changes = 0;
    int last_step = -1;
    for (const FrameRecord& f : r.frames) {
        if (f.index > 45 && !f.on_time) ++late_after;
        if (f.kind == FrameKind::new_frame && f.ladder_step != last_step) ++step_changes;
        if (f.kind == FrameKind::new_frame) last_step = f.ladder_step;
    }
    EXPECT_EQ(late_after, 0u);
    EXPECT_GE(r.summary.on_time_rate, 0.99);
    EXPECT_GT(r.summary.new_frames_per_vsync, 0.95);
    EXPECT_LT(full_share(r), 0.05);
    EXPECT_LE(step_changes, 6u);  // no oscillation
    const FrameRecord& f = r.frames.back();
    EXPECT_LT(f.render_scale, 0.9);
    EXPECT_GE(f.render_scale, 0.5);
    EXPECT_EQ(f.render_divisor, 1);
}

TEST(Ladder, WhenEvenTheBottomStepMissesTheNodeRendersAtHalfRateAndReWarpsBetween) {
    // 44 ms at full resolution: 11 ms at half resolution per axis, with a 2 ms warp more than a
    // period. At half the refresh every vsync still gets a freshly warped image.
    const PacedRun r =
        run([](int) { return 44 * kNsPerMs; }, 2 * kNsPerMs, 4.0, {.pixel_bound = true});
    size_t half = 0, missed_after = 0;
    for (const FrameRecord& f : r.frames) {
        half += f.render_divisor == 2;
        if (f.index > 60 && !f.on_time) ++missed_after;
    }
    EXPECT_GT(double(half) / double(r.frames.size()), 0.9);
    EXPECT_EQ(missed_after, 0u);
    EXPECT_GE(r.summary.on_time_rate, 0.99);
    EXPECT_NEAR(r.summary.new_frames_per_vsync, 0.5, 0.03);
    EXPECT_LE(r.summary.longest_late_run, 2u);
    // Each re-warp samples the newest pose: latency stays within a period of the new frames'.
    EXPECT_LT(r.summary.latency_ms.p99, 11.1 + 5.0);
}

TEST(Ladder, ChromaticAberrationCorrectionIsTheLastStepOfTheLadder) {
    // 28 ms at full resolution and a 3.5 ms warp: half resolution (7 ms) with the full warp and
    // its margin does not fit a period; without the aberration correction (1.4 ms) it does.
    const PacedRun r =
        run([](int) { return 28 * kNsPerMs; }, 7 * kNsPerMs / 2, 4.0, {.pixel_bound = true});
    // Once learnt (the second half of the run): every present on time, a new frame at every
    // vsync, at half resolution without the correction.
    size_t later = 0, no_ca = 0, late = 0, rewarps = 0;
    for (const FrameRecord& f : r.frames)
        if (f.photon_time_ns > s_to_ns(2.0)) {
            ++later;
            no_ca += !f.chromatic;
            late += !f.on_time;
            rewarps += f.kind == FrameKind::rewarp;
            EXPECT_EQ(f.render_divisor, 1) << f.index;
        }
    EXPECT_GT(later, 150u);
    EXPECT_EQ(no_ca, later);
    EXPECT_EQ(late, 0u);
    EXPECT_EQ(rewarps, 0u);
    EXPECT_GE(r.summary.on_time_rate, 0.97);
}

TEST(Ladder, OffItStaysAtFullResolutionAndTheRateCarriesTheLoad) {
    const PacedRun r =
        run([](int) { return 16 * kNsPerMs; }, 3 * kNsPerMs / 2, 3.0,
            {.config = [](NodeConfig& c) { c.pixel_ladder = false; }, .pixel_bound = true});
    EXPECT_DOUBLE_EQ(full_share(r), 1.0);
    EXPECT_GE(r.summary.on_time_rate, 0.99);
    EXPECT_NEAR(r.summary.new_frames_per_vsync, 0.5, 0.03);
}

TEST(Ladder, CostsThatReturnBelowTheBudgetClimbBackToFullResolutionWithoutOscillating) {
    // Pixel-bound 16 ms for the first 1.5 s, then 6 ms: the ladder steps down, then back up once
    // the finer steps fit with room, and stays.
    const PacedRun r = run([](int i) { return (i < 135 ? 16 : 6) * kNsPerMs; }, kNsPerMs, 5.0,
                           {.pixel_bound = true});
    size_t changes = 0;
    int last = 0;
    for (const FrameRecord& f : r.frames)
        if (f.kind == FrameKind::new_frame) {
            changes += f.ladder_step != last;
            last = f.ladder_step;
        }
    EXPECT_EQ(r.frames.back().ladder_step, 0);
    EXPECT_LE(changes, 12u);
    EXPECT_GE(r.summary.on_time_rate, 0.98);
}

}  // namespace hmdnode

namespace hmdnode {
namespace {

// The recorded lavapipe costs (tests/data/pacing/lavapipe_360x400_costs.csv, its header says how
// they were made): full-resolution renders and one-sample warps, in the order they came.
struct RecordedCosts {
    std::vector<int64_t> render, warp;
};

RecordedCosts recorded_lavapipe_costs() {
    RecordedCosts c;
    std::ifstream in(HMDNODE_SOURCE_DIR "/tests/data/pacing/lavapipe_360x400_costs.csv");
    EXPECT_TRUE(in.good());
    std::string line;
    while (std::getline(in, line)) {
        if (line.empty() || line[0] == '#' || line[0] == 'r') continue;
        const size_t comma = line.find(',');
        if (comma > 0) c.render.push_back(int64_t(std::stod(line.substr(0, comma)) * 1e6));
        c.warp.push_back(int64_t(std::stod(line.substr(comma + 1)) * 1e6));
    }
    return c;
}

}  // namespace

// lavapipe's own jitter on a 2-core machine, replayed through the simulated clock: renders of
// 10 ms p50 and 42 ms p99 at full resolution, one-sample warps of 5 ms p50 and 14 ms p99. Aimed at
// every vsync at full resolution (the node before the ladder and the rate) the loop shows about
// 38 % of the vsyncs on time, with runs of 19 missed; with the ladder and the rate about 74 %,
// runs of at most 8. (Not the 99 % of a machine whose pass fits: here a one-sample warp alone
// overruns a period in 2.4 % of the warps, and the costs swing by 3x from frame to frame.)
TEST(Ladder, RecordedLavapipeCostsKeepTheirVsyncsWithTheLadderAndTheRate) {
    const RecordedCosts c = recorded_lavapipe_costs();
    ASSERT_GT(c.render.size(), 4000u);
    ASSERT_GT(c.warp.size(), c.render.size());
    auto render = [&](int i) { return c.render[size_t(i) % c.render.size()]; };
    // With chromatic-aberration correction the scripted warp costs 2.5x its one-sample cost.
    auto warp = [&](int i) { return c.warp[size_t(i) % c.warp.size()] * 5 / 2; };
    const PacedRun plain = run(render, 0, 20.0,
                               {.config =
                                    [](NodeConfig& n) {
                                        n.pixel_ladder = false;
                                        n.pacing.max_divisor = 1;
                                    },
                                .pixel_bound = true,
                                .warp_sequence = warp});
    const PacedRun paced = run(render, 0, 20.0, {.pixel_bound = true, .warp_sequence = warp});
    EXPECT_LT(plain.summary.on_time_rate, 0.5);
    EXPECT_GT(paced.summary.on_time_rate, plain.summary.on_time_rate + 0.25);
    // About 94 %, runs of at most 5 (74 % and 8 before a vsync the plan could no longer reach was
    // re-warped at once).
    EXPECT_GT(paced.summary.on_time_rate, 0.92);
    EXPECT_LE(paced.summary.longest_late_run, 6u);
    // The bound the pass itself sets: one-sample warps back to back on one queue with no
    // rendering at all, each started `lead` before its latch or as soon as the one before ends,
    // on time when it ends by its latch. About 97.8 % at a 14 ms lead and 98.9 % at 20 ms: the
    // 99 % target is out of reach on these costs whatever the pacing, and the paced loop, which
    // also renders, stays within 5 points of it.
    auto warp_only = [&](int64_t lead) {
        const int64_t period = 11'111'111, latch = 500'000;
        int64_t end = INT64_MIN;
        size_t on_time = 0;
        for (size_t i = 0; i < c.warp.size(); ++i) {
            const int64_t deadline = int64_t(i + 3) * period - latch;
            end = std::max(deadline - lead, end) + c.warp[i];
            on_time += end <= deadline;
        }
        return double(on_time) / double(c.warp.size());
    };
    const double bound14 = warp_only(14 * kNsPerMs), bound20 = warp_only(20 * kNsPerMs);
    std::printf(
        "recorded lavapipe costs: paced %.1f %% of vsyncs on time (longest missed run %zu); "
        "warp-only bound %.1f %% (14 ms lead), %.1f %% (20 ms lead)\n",
        100.0 * paced.summary.on_time_rate, size_t(paced.summary.longest_late_run), 100.0 * bound14,
        100.0 * bound20);
    EXPECT_LT(bound20, 0.99);
    EXPECT_GT(paced.summary.on_time_rate, bound14 - 0.05);
}

// A pass whose 95th percentile and margin exceed a period (a 5 ms warp, 15 ms one time in ten:
// the plan wakes every warp more than a period early) beside a 4 ms pixel-bound render: the vsync
// whose planned wake-up has passed is still warped for at once, since a typical warp makes it, so
// only the slow warps themselves cost vsyncs.
TEST(Pacing, AJitteryPassWhoseTailExceedsAPeriodStillKeepsTheVsyncsItsMedianMakes) {
    auto warp = [](int i) { return (i % 10 == 9 ? 15 : 5) * kNsPerMs * 5 / 2; };  // CA: 2.5x
    const PacedRun r = run([](int) { return 4 * kNsPerMs; }, 0, 10.0,
                           {.pixel_bound = true, .warp_sequence = warp});
    EXPECT_GE(r.summary.on_time_rate, 0.9);
    EXPECT_LE(r.summary.longest_late_run, 2u);
}

}  // namespace hmdnode
