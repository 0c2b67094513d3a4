// Clock tracking against injected offset, drift, exponential USB delays, jumps and tick wrap. The
// estimate is checked against the true host time of each measurement plus the minimum delay (the
// constant part of the delay is unobservable from one-way stamps).
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "hmdnode/hal/tracking/clock_sync.hpp"

namespace hmdnode {
namespace {

struct Link {
    double offset_ns = 5e9;  // host - device at device time 0
    double drift = 50e-6;    // host runs 50 ppm faster than the device
    double min_delay_ns = 100e3;
    double mean_extra_ns = 200e3;  // exponential delay above the minimum
    std::mt19937_64 rng{7};
    int64_t true_host(int64_t device_ns) const {
        return int64_t(std::llround(offset_ns + double(device_ns) * (1.0 + drift)));
    }
    int64_t arrival(int64_t device_ns) {
        std::exponential_distribution<double> extra(1.0 / mean_extra_ns);
        return true_host(device_ns) + int64_t(min_delay_ns + extra(rng));
    }
};

TEST(ClockSync, TracksOffsetDriftUnderExponentialJitter) {
    Link link;
    ClockSync sync;
    double max_err_us = 0;
    for (int64_t i = 0; i < 20000; ++i) {  // 20 s at 1 kHz
        const int64_t dev = 1'000'000'000 + i * 1'000'000;
        const int64_t arr = link.arrival(dev);
        const int64_t host = sync.update(dev, arr);
        EXPECT_LE(host, arr);
        if (i > 4000) {
            const double err = double(host - (link.true_host(dev) + int64_t(link.min_delay_ns)));
            max_err_us = std::max(max_err_us, std::abs(err) / 1e3);
        }
    }
    EXPECT_LT(max_err_us, 20.0);
    EXPECT_NEAR(sync.drift_ppm(), 50.0, 3.0);
    EXPECT_NEAR(sync.jitter_ns(), 200e3, 40e3);  // mean delay above the floor
    EXPECT_EQ(sync.resets(), 0u);
    const int64_t dev_end = 1'000'000'000 + 19999 * int64_t(1'000'000);
    EXPECT_NEAR(double(sync.offset_ns()),
                double(link.true_host(dev_end) + int64_t(link.min_delay_ns) - dev_end), 20e3);
}

TEST(ClockSync, ConstantOffsetModeLagsUnderDriftButDriftModeDoesNot) {
    Link a, b;
    ClockSync with_drift;
    ClockSync without(ClockSyncConfig{2'000'000'000, 20'000'000, false, 0});
    double err_with = 0, err_without = 0;
    for (int64_t i = 0; i < 10000; ++i) {
        const int64_t dev = i * 1'000'000;
        const int64_t h1 = with_drift.update(dev, a.arrival(dev));
        const int64_t h2 = without.update(dev, b.arrival(dev));
        if (i > 5000) {
            const int64_t truth = a.true_host(dev) + int64_t(a.min_delay_ns);
            err_with = std::max(err_with, std::abs(double(h1 - truth)));
            err_without = std::max(err_without, std::abs(double(h2 - truth)));
        }
    }
    EXPECT_LT(err_with, 20e3);
    EXPECT_GT(err_without, 50e3);  // the 2 s window's minimum lags 50 ppm by up to 100 µs
}

TEST(ClockSync, ResetsOnDeviceClockJumpsBothWays) {
    Link link;
    link.drift = 0;
    ClockSync sync;
    int64_t dev = 0;
    for (int i = 0; i < 3000; ++i, dev += 1'000'000) sync.update(dev, link.arrival(dev));
    // Device reboots: its clock restarts at 0 while the host goes on.
    const int64_t host_at_reboot = link.true_host(dev);
    link.offset_ns = double(host_at_reboot);
    dev = 0;
    for (int i = 0; i < 3000; ++i, dev += 1'000'000) {
        const int64_t host = sync.update(dev, link.arrival(dev));
        if (i > 100) {
            EXPECT_NEAR(double(host), double(link.true_host(dev) + 100'000), 20e3) << i;
        }
    }
    EXPECT_EQ(sync.resets(), 1u);
    // Device clock jumps forward by 1 s (a sample would seem to arrive before it was taken).
    link.offset_ns -= 1e9;
    dev += 1'000'000'000;
    for (int i = 0; i < 2000; ++i, dev += 1'000'000) {
        const int64_t host = sync.update(dev, link.arrival(dev));
        if (i > 100) {
            EXPECT_NEAR(double(host), double(link.true_host(dev) + 100'000), 20e3) << i;
        }
    }
    EXPECT_EQ(sync.resets(), 2u);
    // Host clock jumps forward by 1 s (suspend): every arrival is late; reset within two buckets.
    link.offset_ns += 1e9;
    int64_t last_err = 0;
    for (int i = 0; i < 2000; ++i, dev += 1'000'000) {
        const int64_t host = sync.update(dev, link.arrival(dev));
        last_err = host - (link.true_host(dev) + 100'000);
        if (i > 600) {
            EXPECT_LT(std::abs(double(last_err)), 20e3) << i;
        }
    }
    EXPECT_EQ(sync.resets(), 3u);
}

TEST(ClockSync, UnwrapsA32BitMicrosecondCounter) {
    TickUnwrapper unwrap(uint64_t(1) << 32);
    Link link;
    link.drift = 0;
    ClockSync sync;
    const uint64_t start_us = (uint64_t(1) << 32) - 1'500'000;  // wraps 1.5 s in
    for (int64_t i = 0; i < 4000; ++i) {
        const uint64_t raw = (start_us + uint64_t(i) * 1000) & 0xffffffffu;
        const uint64_t us = unwrap.unwrap(raw);
        EXPECT_EQ(us, start_us + uint64_t(i) * 1000);
        const int64_t dev_ns = int64_t(us) * 1000;
        const int64_t host = sync.update(dev_ns, link.arrival(dev_ns));
        if (i > 500) {
            EXPECT_NEAR(double(host), double(link.true_host(dev_ns) + 100'000), 20e3);
        }
    }
    EXPECT_EQ(unwrap.wraps(), 1u);
    EXPECT_EQ(sync.resets(), 0u);
    // A reordered (older) value is not a wrap.
    const uint64_t before = unwrap.unwrap((start_us + 3999 * 1000) & 0xffffffffu);
    EXPECT_EQ(unwrap.unwrap((start_us + 3990 * 1000) & 0xffffffffu), before);
    EXPECT_EQ(unwrap.backward_steps(), 1u);
}

// A 1 kHz device read by 1 ms USB polling: a sample waits for the next poll after it is ready, so
// host - device is a sawtooth whose phase drifts with the crystals (33 ppm: one period per 30 s),
// plus exponential delays. Least squares through sub-window minima followed the sawtooth; the
// lower envelope must not. Over 60 s, with wide and with tight delays: the drift stays within
// 5 ppm of the truth once 16 s are in, outputs increase and are never closer than 0.5 ms.
TEST(ClockSync, PollingQuantisationDoesNotBendTheDrift) {
    for (const double mean_extra_ns : {150e3, 20e3}) {
        const double drift = 33e-6;
        std::mt19937_64 rng(11);
        std::exponential_distribution<double> extra(1.0 / mean_extra_ns);
        ClockSync sync;
        int64_t prev_out = 0;
        double worst_ppm = 0, min_gap_ms = 1e9;
        for (int64_t i = 0; i < 60000; ++i) {
            const int64_t dev = 3'000'000'000 + i * 1'012'760;  // 987.4 Hz, as the Vive's IMU
            const double ready = 7e9 + double(dev) * (1.0 + drift) + 100e3 + extra(rng);
            const double poll_ns = 1e6, phase = 370e3;
            const int64_t arr = int64_t(std::ceil((ready - phase) / poll_ns) * poll_ns + phase);
            const int64_t out = sync.update(dev, arr);
            if (i > 0) {
                EXPECT_GT(out, prev_out) << i;
                min_gap_ms = std::min(min_gap_ms, double(out - prev_out) * 1e-6);
            }
            prev_out = out;
            if (i >= 16000) worst_ppm = std::max(worst_ppm, std::abs(sync.drift_ppm() - 33.0));
        }
        std::printf(
            "1 ms polling, mean extra delay %.0f us: drift %.2f ppm (worst error after 16 s "
            "%.2f ppm), closest outputs %.3f ms\n",
            mean_extra_ns / 1e3, sync.drift_ppm(), worst_ppm, min_gap_ms);
        EXPECT_LE(worst_ppm, 5.0);
        EXPECT_GE(min_gap_ms, 0.5);
        EXPECT_EQ(sync.resets(), 0u);
    }
}

}  // namespace
}  // namespace hmdnode
