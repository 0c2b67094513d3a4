// The observed replay's device path without a device: a camera streamed on a capture thread for
// the replay's run on the real clock (the test-pattern camera, whose frames carry no marker: each
// is reported undecoded with its reason, none guessed), a camera failing mid-run (the run fails
// naming it), and the options the observer refuses. And the one read-back rule: a mock display
// with a watcher reads every present back.
#include "hmdnode/firmware_host/observed_replay.hpp"

#include <gtest/gtest.h>

#include <memory>
#include <string>

#include "hmdnode/firmware_host/motion_profiles.hpp"
#include "hmdnode/firmware_host/node_assembly.hpp"

namespace hmdnode {
namespace {

ReplayOptions real_clock_options() {
    ReplayOptions o;
    o.scene = HMDNODE_DEMO_SCENE;
    Result<Trace> t = make_motion_profile("step", 0.6);
    EXPECT_TRUE(t.ok());
    o.trace_data = std::make_shared<const Trace>(std::move(t).value());
    o.simulated_clock = false;
    o.duration_s = 0.6;
    o.display.eye_width = 64;
    o.display.eye_height = 64;
    o.node.latency_marker_cell_px = 3;  // 42 px: fits the 64 px eye below its top tenth
    return o;
}

// A camera whose third frame request fails, as a device unplugged mid-run.
class FailingCamera final : public Camera {
  public:
    std::string name() const override { return "/dev/video-gone"; }
    Status start() override { return {}; }
    void stop() override {}
    Result<std::optional<CameraFrame>> next_frame(int timeout_ms) override {
        if (++calls_ >= 3) return make_error("device removed (ENODEV)");
        SystemClock().sleep_until_ns(SystemClock().now_ns() + int64_t(timeout_ms) * 1'000'000);
        return std::optional<CameraFrame>{};
    }
    uint32_t width() const override { return 64; }
    uint32_t height() const override { return 64; }
    uint32_t fourcc() const override { return kFourccGrey; }

  private:
    int calls_ = 0;
};

TEST(ObservedReplay, ADeviceOnACaptureThreadReportsFramesItCannotDecode) {
    SystemClock clock;
    SimCameraConfig sc;
    sc.width = 64;
    sc.height = 48;
    sc.fps = 30.0;
    std::unique_ptr<Camera> camera = create_sim_camera(clock, sc);
    Result<ObservedReplay> r = run_replay_observed(real_clock_options(), *camera, 1'000'000);
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_EQ(r->camera, "sim");
    const ObserverSummary& s = r->observer.summary;
    EXPECT_GT(s.frames, 3u);  // 30 Hz over the run
    EXPECT_EQ(s.decoded, 0u);
    EXPECT_EQ(s.undecoded, s.frames);
    for (const ObservedFrame& f : r->observer.frames) {
        EXPECT_FALSE(f.decoded);
        EXPECT_FALSE(f.reason.empty());
    }
    // The frames kept lie within the run.
    ASSERT_FALSE(r->replay.frames.empty());
    for (const ObservedFrame& f : r->observer.frames) {
        EXPECT_GE(f.capture_ns, r->replay.frames.front().vsync_ns);
        EXPECT_LT(f.capture_ns, r->replay.frames.back().vsync_ns + r->replay.period_ns);
    }
}

TEST(ObservedReplay, ACameraFailingMidRunFailsTheRunNamingIt) {
    FailingCamera camera;
    Result<ObservedReplay> r = run_replay_observed(real_clock_options(), camera);
    ASSERT_FALSE(r.ok());
    EXPECT_NE(r.error().message.find("/dev/video-gone"), std::string::npos) << r.error().message;
    EXPECT_NE(r.error().message.find("ENODEV"), std::string::npos) << r.error().message;
}

TEST(ObservedReplay, RefusesARunWithoutTheMarkerOrOnTheSimulatedClock) {
    FailingCamera camera;
    ReplayOptions o = real_clock_options();
    o.node.latency_marker_cell_px = 0;
    Result<ObservedReplay> r = run_replay_observed(o, camera);
    ASSERT_FALSE(r.ok());
    EXPECT_NE(r.error().message.find("latency marker"), std::string::npos);
    Result<ObservedReplay> f = run_replay_filmed(o, PanelCameraConfig{});
    ASSERT_FALSE(f.ok());
    EXPECT_NE(f.error().message.find("latency marker"), std::string::npos);
    o = real_clock_options();
    o.simulated_clock = true;
    r = run_replay_observed(o, camera);
    ASSERT_FALSE(r.ok());
    EXPECT_NE(r.error().message.find("real clock"), std::string::npos);
}

TEST(ObservedReplay, AWatchedMockDisplayIsReadBackAtEveryPresent) {
    DisplaySpec d;
    NodeConfig n;
    EXPECT_EQ(read_back_rule(d, n, false), ReadBack::none);
    d.mock_watcher = [](Clock&, const MockDisplayConfig&) -> Result<PanelWatcher*> {
        return static_cast<PanelWatcher*>(nullptr);
    };
    EXPECT_EQ(read_back_rule(d, n, false), ReadBack::every_present);
    n.read_back = false;  // off means off
    EXPECT_EQ(read_back_rule(d, n, false), ReadBack::none);
}

}  // namespace
}  // namespace hmdnode
