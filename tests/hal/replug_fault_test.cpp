// Fault injection (the service's target: 100 unplug/replug cycles, each recovered in < 1 s): the
// simulated reference tracker unplugged and replugged 100 times under the device tracker. On the
// simulated clock (the frame thread pumps the device) every cycle resumes tracking within one
// reopen interval of the replug, each disconnect and reopen is counted, and the process holds no
// more file descriptors after the hundred cycles than before. On the real clock (the tracker's
// reader thread) the same hundred cycles all resume, with a short reopen interval so the test stays
// brief; how long recovery takes with the default interval is bench/replug_bench.cpp's figure (no
// timed assertion here).
#include <gtest/gtest.h>

#include <filesystem>
#include <thread>
#include <vector>

#include "hmdnode/hal/codec/reference_protocol.hpp"
#include "hmdnode/hal/sim/sim_reference_device.hpp"
#include "hmdnode/hal/tracking/device_tracker.hpp"

namespace hmdnode {
namespace {

constexpr int kCycles = 100;

// Open file descriptors of this process (/proc/self/fd, less the one listing it).
size_t open_fds() {
    size_t n = 0;
    for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator("/proc/self/fd")) ++n;
    return n - 1;
}

struct Tracked {
    SimReferenceBackend* device = nullptr;  // owned by the tracker
    std::unique_ptr<DeviceTracker> tracker;
};

Tracked track(Clock& clock, int64_t reopen_interval_ns) {
    Tracked t;
    SimReferenceDeviceConfig dc;
    auto backend = create_sim_reference_backend(clock, dc, sinusoidal_motion());
    t.device = backend.get();
    DeviceTrackerConfig tc;
    tc.filter = DeviceFilter{dc.vendor_id, dc.product_id, ""};
    tc.reopen_interval_ns = reopen_interval_ns;
    auto tracker = create_device_tracker(std::move(backend), make_reference_codec(), clock, tc);
    EXPECT_TRUE(tracker.ok()) << tracker.error().message;
    if (tracker.ok()) t.tracker = std::move(*tracker);
    return t;
}

TEST(ReplugFault, HundredCyclesOnTheSimulatedClockEachResumeWithinAReopenInterval) {
    SimulatedClock clock(5 * kNsPerSecond);
    Tracked t = track(clock, DeviceTrackerConfig{}.reopen_interval_ns);
    ASSERT_TRUE(t.tracker);
    const size_t fds_before = open_fds();
    ASSERT_TRUE(t.tracker->start().ok());
    std::vector<TrackerSample> buf(256);
    auto run_ms = [&](int ms) {
        size_t n = 0;
        for (int i = 0; i < ms; ++i) {
            clock.advance_ns(kNsPerMs);
            n += t.tracker->read(buf);
        }
        return n;
    };
    ASSERT_GT(run_ms(100), 0u);
    for (int cycle = 0; cycle < kCycles; ++cycle) {
        t.device->unplug();
        EXPECT_EQ(run_ms(20 + cycle % 7 * 30), 0u) << "cycle " << cycle;  // 20..200 ms unplugged
        t.device->replug(/*reboot=*/cycle % 2 == 0);  // a reboot restarts sequence and clock
        const int64_t replug_ns = clock.now_ns();
        int64_t first = 0;
        for (int ms = 0; ms < 1000 && !first; ++ms) {
            clock.advance_ns(kNsPerMs);
            const size_t n = t.tracker->read(buf);
            if (n) first = buf[0].arrival_ns;
        }
        ASSERT_GT(first, 0) << "cycle " << cycle << ": tracking did not resume within 1 s";
        // The tracker reopens at most one reopen interval after the failed read; the device's
        // first report follows 1.5 ms after the open.
        EXPECT_LE(first - replug_ns, DeviceTrackerConfig{}.reopen_interval_ns + 2 * kNsPerMs)
            << "cycle " << cycle;
        run_ms(50);
    }
    const DeviceTrackerStatus st = t.tracker->status();
    EXPECT_EQ(st.disconnects, uint64_t(kCycles));
    EXPECT_EQ(st.opens, uint64_t(kCycles) + 1);
    EXPECT_TRUE(st.connected);
    EXPECT_EQ(st.codec.malformed, 0u);
    t.tracker->stop();
    EXPECT_EQ(open_fds(), fds_before);
}

TEST(ReplugFault, HundredCyclesOnTheRealClockAllResumeAndLeakNoDescriptor) {
    SystemClock clock;
    Tracked t = track(clock, 2 * kNsPerMs);
    ASSERT_TRUE(t.tracker);
    const size_t fds_before = open_fds();
    ASSERT_TRUE(t.tracker->start().ok());
    std::vector<TrackerSample> buf(256);
    // Samples that arrived at or after `since` (host time), waiting up to 10 s for one.
    auto resumed_after = [&](int64_t since) {
        for (int i = 0; i < 10'000; ++i) {
            const size_t n = t.tracker->read(buf);
            for (size_t k = 0; k < n; ++k)
                if (buf[k].arrival_ns >= since) return true;
            std::this_thread::sleep_for(std::chrono::milliseconds(1));
        }
        return false;
    };
    ASSERT_TRUE(resumed_after(clock.now_ns()));
    for (int cycle = 0; cycle < kCycles; ++cycle) {
        t.device->unplug();
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
        t.device->replug(/*reboot=*/cycle % 2 == 0);
        ASSERT_TRUE(resumed_after(clock.now_ns())) << "cycle " << cycle << ": never resumed";
    }
    const DeviceTrackerStatus st = t.tracker->status();
    // A 5 ms unplug between two 1 ms reports is seen by the reader as one disconnect each cycle.
    EXPECT_EQ(st.disconnects, uint64_t(kCycles));
    EXPECT_EQ(st.opens, uint64_t(kCycles) + 1);
    t.tracker->stop();
    EXPECT_EQ(open_fds(), fds_before);
}

}  // namespace
}  // namespace hmdnode
