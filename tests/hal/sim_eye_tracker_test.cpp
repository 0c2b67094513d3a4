// The simulated eye tracker: replays a trace's gaze columns on the host timeline, by arrival
// time, counts invalid samples, and refuses a trace without gaze.
#include <gtest/gtest.h>

#include <glm/gtc/quaternion.hpp>

#include "hmdnode/hal/sim/sim_eye_tracker.hpp"

using namespace hmdnode;

namespace {

// 1 s at 100 Hz; the gaze sweeps yaw 0..10 deg, every tenth sample a blink.
std::shared_ptr<Trace> gaze_trace() {
    auto t = std::make_shared<Trace>();
    for (int i = 0; i <= 100; ++i) {
        TraceSample s;
        s.time_ns = 1'000'000'000 + s_to_ns(i / 100.0);
        const double yaw = deg_to_rad(0.1 * i);
        s.gaze = TraceGaze{{-std::sin(yaw), 0.0, -std::cos(yaw)}, i % 10 == 5 ? 0.0 : 0.9};
        t->samples.push_back(s);
    }
    return t;
}

}  // namespace

TEST(SimEyeTracker, DeliversGazeAtItsArrivalTimeOnTheHostTimeline) {
    SimulatedClock clock(5'000'000'000);
    SimEyeTrackerConfig cfg;
    cfg.host_start_ns = clock.now_ns();
    cfg.start_offset_ns = 200'000'000;  // from trace sample 20
    cfg.latency_ns = 4'000'000;
    auto r = create_sim_eye_tracker(gaze_trace(), clock, cfg);
    ASSERT_TRUE(r.ok()) << r.error().message;
    EyeTracker& et = **r;
    std::vector<GazeSample> buf(8);
    EXPECT_EQ(et.read(buf), 0u);  // not started
    ASSERT_TRUE(et.start().ok());
    EXPECT_EQ(et.read(buf), 0u);  // the first arrives 4 ms after its time
    clock.advance_ns(4'000'000);
    ASSERT_EQ(et.read(buf), 1u);
    EXPECT_EQ(buf[0].time_ns, cfg.host_start_ns);
    EXPECT_EQ(buf[0].arrival_ns, cfg.host_start_ns + 4'000'000);
    EXPECT_NEAR(glm::length(buf[0].direction), 1.0, 1e-12);
    EXPECT_NEAR(buf[0].direction.x, -std::sin(deg_to_rad(2.0)), 1e-12);  // sample 20: yaw 2 deg
    EXPECT_DOUBLE_EQ(buf[0].confidence, 0.9);
    // The rest, oldest first; samples 25, 35, ... are blinks (invalid).
    size_t total = 1, invalid = 0;
    int64_t last = buf[0].time_ns;
    for (int k = 0; k < 200 && !et.finished(); ++k) {
        clock.advance_ns(10'000'000);
        const size_t n = et.read(buf);
        for (size_t i = 0; i < n; ++i) {
            EXPECT_GT(buf[i].time_ns, last);
            EXPECT_LE(buf[i].arrival_ns, clock.now_ns());
            last = buf[i].time_ns;
            invalid += !buf[i].valid();
        }
        total += n;
    }
    EXPECT_TRUE(et.finished());
    EXPECT_EQ(total, 81u);  // samples 20..100
    EXPECT_EQ(invalid, 8u);
    EXPECT_EQ(et.counters().samples_delivered, 81u);
    EXPECT_EQ(et.counters().samples_invalid, 8u);
}

TEST(SimEyeTracker, ATraceWithoutGazeIsAnErrorThatSaysHowToAddIt) {
    SimulatedClock clock(0);
    auto t = std::make_shared<Trace>();
    t->samples.resize(2);
    t->samples[1].time_ns = 10;
    auto r = create_sim_eye_tracker(t, clock, {});
    ASSERT_FALSE(r.ok());
    EXPECT_NE(r.error().message.find("no gaze columns"), std::string::npos);
    EXPECT_NE(r.error().message.find("hmdnode trace add-gaze"), std::string::npos);
}
