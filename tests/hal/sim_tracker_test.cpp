#include <gtest/gtest.h>

#include <glm/gtc/quaternion.hpp>
#include <thread>

#include "hmdnode/hal/sim/sim_tracker.hpp"

using namespace hmdnode;

namespace {

// A head turning about +Y at a constant rate, sampled at rate_hz for duration_s.
std::shared_ptr<Trace> yaw_trace(double rate_hz, double duration_s, double dps) {
    auto t = std::make_shared<Trace>();
    const int n = int(rate_hz * duration_s) + 1;
    for (int i = 0; i < n; ++i) {
        TraceSample s;
        s.time_ns = s_to_ns(i / rate_hz);
        s.orientation = glm::angleAxis(deg_to_rad(dps * i / rate_hz), glm::dvec3(0, 1, 0));
        t->samples.push_back(s);
    }
    return t;
}

std::vector<TrackerSample> drain_all(Tracker& tr, SimulatedClock& clock, int64_t step_ns,
                                     int64_t until_ns) {
    std::vector<TrackerSample> all, buf(64);
    while (clock.now_ns() <= until_ns) {
        size_t n;
        while ((n = tr.read(buf)) > 0) all.insert(all.end(), buf.begin(), buf.begin() + n);
        clock.advance_ns(step_ns);
    }
    return all;
}

}  // namespace

TEST(SimTracker, DeliversEverySampleAtItsArrivalTimeOnTheSimulatedClock) {
    SimulatedClock clock(0);
    SimTrackerConfig cfg;
    cfg.latency_ns = 2 * kNsPerMs;
    auto tr = create_sim_tracker(yaw_trace(60, 2.0, 30), clock, cfg);
    ASSERT_TRUE(tr.ok()) << tr.error().message;
    ASSERT_TRUE((*tr)->start().ok());
    std::vector<TrackerSample> buf(16);
    EXPECT_EQ((*tr)->read(buf), 0u);  // first arrival is at 2 ms
    clock.sleep_until_ns(2 * kNsPerMs);
    ASSERT_EQ((*tr)->read(buf), 1u);
    EXPECT_EQ(buf[0].time_ns, 0);
    EXPECT_EQ(buf[0].arrival_ns, 2 * kNsPerMs);
    auto rest = drain_all(**tr, clock, kNsPerMs, s_to_ns(2.1));
    EXPECT_EQ(rest.size(), 120u);
    EXPECT_TRUE((*tr)->finished());
    for (size_t i = 1; i < rest.size(); ++i) {
        EXPECT_GT(rest[i].time_ns, rest[i - 1].time_ns);
        EXPECT_EQ(rest[i].sequence, rest[i - 1].sequence + 1);
    }
}

TEST(SimTracker, ResamplesAt1kHzWithoutLosingASample) {
    SimulatedClock clock(0);
    SimTrackerConfig cfg;
    cfg.resample_hz = 1000.0;
    auto tr = create_sim_tracker(yaw_trace(60, 60.0, 45), clock, cfg);  // a minute at 1 kHz
    ASSERT_TRUE(tr.ok());
    ASSERT_TRUE((*tr)->start().ok());
    auto all = drain_all(**tr, clock, 11 * kNsPerMs, s_to_ns(61.0));
    ASSERT_EQ(all.size(), 60001u);
    EXPECT_EQ((*tr)->counters().samples_dropped, 0u);
    // Resampled orientation follows the truth: 45 deg/s about +Y.
    const TrackerSample& s = all[12345];
    glm::dquat truth = glm::angleAxis(deg_to_rad(45.0 * 12.345), glm::dvec3(0, 1, 0));
    EXPECT_LT(angle_between_deg(s.orientation, truth), 1e-6);
}

TEST(SimTracker, NoiseAndJitterAreDeterministicForASeed) {
    SimTrackerConfig cfg;
    cfg.noise_deg = 0.5;
    cfg.jitter_ns = 3 * kNsPerMs;
    cfg.seed = 42;
    auto run = [&] {
        SimulatedClock clock(0);
        auto tr = create_sim_tracker(yaw_trace(60, 1.0, 10), clock, cfg);
        EXPECT_TRUE((*tr)->start().ok());
        return drain_all(**tr, clock, kNsPerMs, s_to_ns(1.2));
    };
    auto a = run(), b = run();
    ASSERT_EQ(a.size(), b.size());
    double max_noise = 0.0;
    for (size_t i = 0; i < a.size(); ++i) {
        EXPECT_EQ(a[i].arrival_ns, b[i].arrival_ns);
        EXPECT_EQ(a[i].orientation, b[i].orientation);
        EXPECT_GE(a[i].arrival_ns, a[i].time_ns + cfg.latency_ns);
        if (i) {
            EXPECT_GE(a[i].arrival_ns, a[i - 1].arrival_ns);
        }
        glm::dquat truth =
            glm::angleAxis(deg_to_rad(10.0 * ns_to_s(a[i].time_ns)), glm::dvec3(0, 1, 0));
        max_noise = std::max(max_noise, angle_between_deg(a[i].orientation, truth));
    }
    EXPECT_GT(max_noise, 0.1);  // the noise is there
    EXPECT_LT(max_noise, 5.0);  // and of the requested size
}

TEST(SimTracker, RealTimeReaderThreadPushesThroughTheRing) {
    SystemClock clock;
    SimTrackerConfig cfg;
    cfg.host_start_ns = clock.now_ns();
    cfg.resample_hz = 1000.0;
    cfg.duration_ns = 200 * kNsPerMs;
    auto tr = create_sim_tracker(yaw_trace(60, 1.0, 10), clock, cfg);
    ASSERT_TRUE(tr.ok());
    ASSERT_TRUE((*tr)->start().ok());
    std::vector<TrackerSample> buf(64);
    size_t got = 0;
    uint64_t expect_seq = 0;
    const int64_t deadline = clock.now_ns() + 5 * kNsPerSecond;
    while (!(*tr)->finished() && clock.now_ns() < deadline) {
        size_t n = (*tr)->read(buf);
        for (size_t i = 0; i < n; ++i) {
            EXPECT_EQ(buf[i].sequence, expect_seq++);
            EXPECT_LE(buf[i].arrival_ns, clock.now_ns());
        }
        got += n;
        std::this_thread::sleep_for(std::chrono::milliseconds(3));
    }
    (*tr)->stop();
    EXPECT_EQ(got, 201u);
    EXPECT_EQ((*tr)->counters().samples_dropped, 0u);
}

TEST(SimTracker, RejectsATooShortRange) {
    SimulatedClock clock;
    SimTrackerConfig cfg;
    cfg.start_offset_ns = s_to_ns(5.0);
    auto tr = create_sim_tracker(yaw_trace(60, 1.0, 10), clock, cfg);
    ASSERT_FALSE(tr.ok());
    EXPECT_NE(tr.error().message.find("past the end"), std::string::npos);
}
