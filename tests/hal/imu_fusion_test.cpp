// IMU fusion against synthetic motion with known truth: the true orientation is integrated
// finely from a known body rate; the gyro reads that rate plus a bias and noise, the accelerometer
// reads gravity in the head frame plus noise.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <random>
#include <vector>

#include "hmdnode/core/percentile.hpp"
#include "hmdnode/core/trace.hpp"
#include "hmdnode/hal/tracking/imu_fusion.hpp"

namespace hmdnode {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kG = 9.80665;

double angle_deg(const glm::dquat& a, const glm::dquat& b) {
    const glm::dquat d = glm::conjugate(a) * b;
    return 2.0 * std::acos(std::min(1.0, std::abs(d.w))) * 180.0 / kPi;
}
double tilt_deg(const glm::dquat& a, const glm::dquat& b) {
    const glm::dvec3 ua = glm::conjugate(a) * glm::dvec3(0, 1, 0);
    const glm::dvec3 ub = glm::conjugate(b) * glm::dvec3(0, 1, 0);
    return std::acos(std::clamp(glm::dot(ua, ub), -1.0, 1.0)) * 180.0 / kPi;
}

struct RunResult {
    double max_err_deg = 0, max_tilt_deg = 0;
    glm::dvec3 bias{0.0};
};

// Runs `seconds` at 1 kHz; errors are measured after `settle_s`.
RunResult run(const std::function<glm::dvec3(double)>& rate, glm::dquat truth, double seconds,
              double settle_s, glm::dvec3 bias, double gyro_noise, double accel_noise,
              ImuFusion& f) {
    std::mt19937_64 rng(3);
    std::normal_distribution<double> n01(0.0, 1.0);
    RunResult r;
    const int sub = 10;
    for (int i = 0; i <= int(seconds * 1000); ++i) {
        const double t = i * 1e-3;
        if (i > 0)
            for (int k = 0; k < sub; ++k) {  // fine integration of the truth
                const double ts = t - 1e-3 + (k + 0.5) * 1e-3 / sub;
                const glm::dvec3 w = rate(ts);
                const double a = glm::length(w) * 1e-3 / sub;
                if (a > 0) truth = glm::normalize(truth * glm::angleAxis(a, w / glm::length(w)));
            }
        const glm::dvec3 gyro =
            rate(t) + bias + gyro_noise * glm::dvec3(n01(rng), n01(rng), n01(rng));
        const glm::dvec3 accel = glm::conjugate(truth) * glm::dvec3(0, kG, 0) +
                                 accel_noise * glm::dvec3(n01(rng), n01(rng), n01(rng));
        f.update(int64_t(i) * 1'000'000, gyro, accel);
        if (t >= settle_s) {
            r.max_err_deg = std::max(r.max_err_deg, angle_deg(truth, f.orientation()));
            r.max_tilt_deg = std::max(r.max_tilt_deg, tilt_deg(truth, f.orientation()));
        }
    }
    r.bias = f.gyro_bias();
    return r;
}

TEST(ImuFusion, FirstSampleAlignsToGravity) {
    ImuFusion f;
    const glm::dquat tilt = glm::angleAxis(0.4, glm::normalize(glm::dvec3(1, 0, 0.5)));
    f.update(0, glm::dvec3(0), glm::conjugate(tilt) * glm::dvec3(0, kG, 0));
    EXPECT_LT(tilt_deg(tilt, f.orientation()), 1e-6);
}

TEST(ImuFusion, ConstantRateRotationTracksWithinHalfADegree) {
    ImuFusion f;
    const glm::dquat start = glm::angleAxis(0.3, glm::dvec3(1, 0, 0));
    // 90 deg/s about the head's y axis for 8 s, then 45 deg/s about x for 4 s.
    auto rate = [](double t) {
        return t < 8.0 ? glm::dvec3(0, kPi / 2, 0) : glm::dvec3(kPi / 4, 0, 0);
    };
    RunResult r = run(rate, start, 12.0, 0.0, glm::dvec3(0), 0.0, 0.0, f);
    EXPECT_LT(r.max_err_deg, 0.5);
}

// Sinusoidal head shakes keep the head near upright, so gravity observes the x and z (tilt-axis)
// biases but not the yaw-axis one: tilt stays bounded and the tilt-axis biases converge, while
// heading may wander (the integral term leaks part of the transient into the unobservable axis).
TEST(ImuFusion, HeadShakesWithTiltAxisBiasAndNoiseConvergeAndStayWithinBounds) {
    ImuFusion f;
    const glm::dvec3 bias(0.02, 0.0, -0.015);
    auto rate = [](double t) {
        return glm::dvec3(0.8 * std::sin(2 * kPi * 0.5 * t), 1.5 * std::sin(2 * kPi * 1.0 * t),
                          0.5 * std::sin(2 * kPi * 0.7 * t + 1.0));
    };
    RunResult r = run(rate, glm::dquat(1, 0, 0, 0), 60.0, 30.0, bias, 0.005, 0.05, f);
    std::printf("head shakes: max error %.3f deg (tilt %.3f deg), bias error %.5f %.5f %.5f\n",
                r.max_err_deg, r.max_tilt_deg, r.bias.x - bias.x, r.bias.y - bias.y,
                r.bias.z - bias.z);
    EXPECT_LT(r.max_tilt_deg, 1.0);
    EXPECT_NEAR(r.bias.x, bias.x, 0.003);
    EXPECT_NEAR(r.bias.z, bias.z, 0.003);
}

// A session of shakes with pauses: the pauses teach the yaw-axis bias, so heading drift stays
// bounded too (a yaw bias is unobservable from gravity while the head stays upright).
TEST(ImuFusion, ShakesWithPausesLearnTheYawBiasAndBoundHeadingDrift) {
    ImuFusion f;
    const glm::dvec3 bias(0.01, -0.008, 0.006);
    auto rate = [](double t) {
        if (std::fmod(t, 15.0) < 5.0) return glm::dvec3(0);  // 5 s still, 10 s of shakes
        return glm::dvec3(0.8 * std::sin(2 * kPi * 0.5 * t), 1.5 * std::sin(2 * kPi * 1.0 * t),
                          0.5 * std::sin(2 * kPi * 0.7 * t + 1.0));
    };
    RunResult r = run(rate, glm::dquat(1, 0, 0, 0), 60.0, 0.0, bias, 0.005, 0.05, f);
    std::printf(
        "shakes with pauses: max error %.3f deg (tilt %.3f deg), bias error %.5f %.5f "
        "%.5f\n",
        r.max_err_deg, r.max_tilt_deg, r.bias.x - bias.x, r.bias.y - bias.y, r.bias.z - bias.z);
    EXPECT_LT(r.max_tilt_deg, 1.0);
    EXPECT_LT(r.max_err_deg, 1.5);
    EXPECT_NEAR(r.bias.y, bias.y, 0.002);
}

TEST(ImuFusion, StillDeviceLearnsAllThreeBiasAxesAndHoldsStill) {
    ImuFusion f;
    const glm::dvec3 bias(0.008, 0.010, -0.006);  // y: the yaw axis when level
    auto rate = [](double) { return glm::dvec3(0); };
    RunResult warm = run(rate, glm::dquat(1, 0, 0, 0), 10.0, 1e9, bias, 0.002, 0.02, f);
    EXPECT_NEAR(warm.bias.y, bias.y, 0.001);
    const glm::dquat held = f.orientation();
    run(rate, glm::dquat(1, 0, 0, 0), 10.0, 0.0, bias, 0.002, 0.02, f);
    EXPECT_LT(angle_deg(held, f.orientation()), 0.3);  // < 0.03 deg/s of drift
    EXPECT_TRUE(f.still());
    EXPECT_TRUE(f.heading_bias_observed());
}

TEST(ImuFusion, GatesGravityCorrectionUnderLinearAcceleration) {
    ImuFusion f;
    f.update(0, glm::dvec3(0), glm::dvec3(0, kG, 0));
    const glm::dquat before = f.orientation();
    // 1.5 g sideways push: no correction from it.
    for (int i = 1; i <= 200; ++i) f.update(i * 1'000'000, glm::dvec3(0), glm::dvec3(14.7, kG, 0));
    EXPECT_EQ(f.gated_samples(), 200u);
    EXPECT_LT(angle_deg(before, f.orientation()), 1e-9);
}

// ---- IMU synthesised from a real head trace ----

// Index-like sensor noise per 1 kHz sample: the standard deviations measured on the still Vive of
// data/traces/vive_cal.pcap.gz (same IMU family; see docs/tracking.md §3).
constexpr double kIndexGyroNoise = 0.0017;  // rad/s
constexpr double kIndexAccelNoise = 0.03;   // m/s^2

// Heading error: the twist about world up of the world-frame error rotation; tilt error: the angle
// between the true and the estimated world-up in the head frame.
double heading_deg(const glm::dquat& truth, const glm::dquat& est) {
    const glm::dquat d = est * glm::conjugate(truth);
    double a = 2.0 * std::atan2(d.y, d.w);
    a = std::remainder(a, 2.0 * kPi);
    return std::abs(a) * 180.0 / kPi;
}

struct TraceRun {
    double heading_p95 = 0, heading_p50 = 0, tilt_p95 = 0;
};

// Runs the fusion over IMU samples synthesised at 1 kHz from the trace (slerp between its
// samples): the gyro reads the exact mean body rate over each 1 ms interval (so a noise-free run
// integrates the truth exactly) plus `bias` and noise; the accelerometer reads gravity (the trace
// has no positions, so no linear acceleration) plus noise. Errors after the first second, with
// the start's heading (unobservable) aligned.
TraceRun run_trace(const Trace& trace, glm::dvec3 bias, double gyro_noise, double accel_noise) {
    std::mt19937_64 rng(7);
    std::normal_distribution<double> n01(0.0, 1.0);
    ImuFusion f;
    std::vector<double> heading, tilt;
    const int64_t t0 = trace.samples.front().time_ns, t1 = trace.samples.back().time_ns;
    glm::dquat prev = trace.pose_at(t0).orientation, align{1, 0, 0, 0};
    for (int64_t t = t0; t <= t1; t += 1'000'000) {
        const glm::dquat q = trace.pose_at(t).orientation;
        glm::dquat d = glm::conjugate(prev) * q;
        if (d.w < 0) d = -d;
        const double s = glm::length(glm::dvec3(d.x, d.y, d.z));
        const glm::dvec3 rate =
            s > 1e-15 ? glm::dvec3(d.x, d.y, d.z) / s * (2.0 * std::atan2(s, d.w) / 1e-3)
                      : glm::dvec3(0.0);
        prev = q;
        const glm::dvec3 gyro = rate + bias + gyro_noise * glm::dvec3(n01(rng), n01(rng), n01(rng));
        const glm::dvec3 accel = glm::conjugate(q) * glm::dvec3(0, kG, 0) +
                                 accel_noise * glm::dvec3(n01(rng), n01(rng), n01(rng));
        f.update(t - t0, gyro, accel);
        if (t == t0) align = f.orientation() * glm::conjugate(q);  // a pure yaw
        if (t - t0 < 1'000'000'000) continue;
        heading.push_back(heading_deg(align * q, f.orientation()));
        tilt.push_back(tilt_deg(q, f.orientation()));
    }
    return {percentile(heading, 0.95), percentile(heading, 0.5), percentile(tilt, 0.95)};
}

const Trace& head_trace() {
    static const Trace t = [] {
        auto r = read_trace_csv(HMDNODE_SOURCE_DIR "/data/traces/corbillon2018_user1.csv");
        EXPECT_TRUE(r.ok()) << r.error().message;
        return r.ok() ? *r : Trace{};
    }();
    return t;
}

TEST(ImuFusion, RealHeadTraceNoiseFreeTracksHeadingAndTilt) {
    const Trace& t = head_trace();
    ASSERT_GT(t.samples.size(), 1000u);
    const TraceRun r = run_trace(t, glm::dvec3(0.0), 0.0, 0.0);
    std::printf("real head trace, noise-free: heading p50 %.3f p95 %.3f deg, tilt p95 %.3f deg\n",
                r.heading_p50, r.heading_p95, r.tilt_p95);
    EXPECT_LE(r.heading_p95, 0.5);
    EXPECT_LE(r.tilt_p95, 0.3);
}

TEST(ImuFusion, RealHeadTraceWithIndexNoiseAndResidualBias) {
    const Trace& t = head_trace();
    ASSERT_GT(t.samples.size(), 1000u);
    const double b = 0.01 * kPi / 180.0;  // 0.01 deg/s left by the factory calibration
    const TraceRun r = run_trace(t, glm::dvec3(b, b, -b), kIndexGyroNoise, kIndexAccelNoise);
    std::printf(
        "real head trace, noise + 0.01 deg/s bias: heading p50 %.3f p95 %.3f deg, tilt "
        "p95 %.3f deg\n",
        r.heading_p50, r.heading_p95, r.tilt_p95);
    EXPECT_LE(r.heading_p95, 2.0);
    EXPECT_LE(r.tilt_p95, 0.5);
}

// The old still-bias rule took any rate under 2.9 deg/s for bias and turned this 45 deg turn into
// 0.5 deg. A steady 1.5 deg/s is above the most a still window takes for bias (1 deg/s), however
// steady it is, so the whole turn comes out, with and without sensor noise.
TEST(ImuFusion, SlowTurnIsNotEatenAsBias) {
    for (const double noise : {0.0, 1.0}) {
        ImuFusion f;
        const double rate = 1.5 * kPi / 180.0;
        auto w = [rate](double t) {
            return t >= 2.0 && t < 32.0 ? glm::dvec3(0, rate, 0) : glm::dvec3(0);
        };
        run(w, glm::dquat(1, 0, 0, 0), 40.0, 1e9, glm::dvec3(0), noise * kIndexGyroNoise,
            noise * kIndexAccelNoise, f);
        const glm::dquat q = f.orientation();
        const double yaw = 2.0 * std::atan2(q.y, q.w) * 180.0 / kPi;
        std::printf("45 deg turn at 1.5 deg/s (noise %s): %.3f deg\n", noise > 0 ? "on" : "off",
                    yaw);
        EXPECT_NEAR(yaw, 45.0, 1.0);
    }
}

// A still device with the gyro bias a real Index shows at rest after its factory calibration
// (1.35 deg/s, mostly about the vertical: data/traces/compare-test-index.rec.gz, its first 8 s):
// the first still window takes it, so the heading holds (the former 1 deg/s limit on any still
// window left it unlearnt and the heading drifted by 1.26 deg/s on that recording).
TEST(ImuFusion, TheIndexsRestBiasIsLearntFromTheFirstStillWindow) {
    ImuFusion f;
    const glm::dvec3 bias(-0.0022, -0.0218, 0.0082);  // rad/s, head frame, as measured
    run([](double) { return glm::dvec3(0); }, glm::dquat(1, 0, 0, 0), 3.0, 1e9, bias, 0.0012, 0.02,
        f);
    EXPECT_TRUE(f.heading_bias_observed());
    EXPECT_LT(glm::length(f.gyro_bias() - bias), 2e-4);
    // 10 s more at rest (the run's clock goes on from 3 s): the heading holds.
    const glm::dquat held = f.orientation();
    std::mt19937_64 rng(5);
    std::normal_distribution<double> n01(0.0, 1.0);
    for (int i = 3001; i <= 13000; ++i)
        f.update(int64_t(i) * 1'000'000, bias + 0.0012 * glm::dvec3(n01(rng), n01(rng), n01(rng)),
                 glm::dvec3(0, kG, 0) + 0.02 * glm::dvec3(n01(rng), n01(rng), n01(rng)));
    EXPECT_LT(angle_deg(held, f.orientation()), 0.2);
}

// A bias about the vertical axis larger than still_max_bias_rad_s (3 deg/s) is not a bias any
// gyro has: it is not learnt, the heading drifts by it, and heading_bias_observed() says so.
TEST(ImuFusion, YawBiasBeyondTheStillLimitIsReportedUnobservedNotGuessed) {
    ImuFusion f;
    const double b = 4.0 * kPi / 180.0;  // 4 deg/s about the vertical
    run([](double) { return glm::dvec3(0); }, glm::dquat(1, 0, 0, 0), 10.0, 1e9,
        glm::dvec3(0, b, 0), 0.0, 0.0, f);
    EXPECT_FALSE(f.heading_bias_observed());
    EXPECT_NEAR(f.gyro_bias().y, 0.0, 1e-9);
    const glm::dquat q = f.orientation();
    EXPECT_NEAR(2.0 * std::atan2(q.y, q.w) * 180.0 / kPi, 40.0, 0.1);  // 4 deg/s for 10 s
}

// A fast yank beyond the gyro's full scale: the clipped samples are counted, no bias is learnt
// from the interval, and tilt re-aligns within a second of the end of the yank.
TEST(ImuFusion, SaturatedGyroIsCountedAndTiltRecovers) {
    ImuFusion f;
    const double clip = 500.0 * kPi / 180.0;
    glm::dquat truth(1, 0, 0, 0);
    uint64_t clipped = 0;
    for (int i = 0; i <= 6000; ++i) {
        const double t = i * 1e-3;
        // A 0.2 s pitch yank peaking at 800 deg/s from t = 2 s.
        const double true_rate =
            t >= 2.0 && t < 2.2 ? 800.0 * kPi / 180.0 * std::sin(kPi * (t - 2.0) / 0.2) : 0.0;
        if (i > 0)
            truth = glm::normalize(truth * glm::angleAxis(true_rate * 1e-3, glm::dvec3(1, 0, 0)));
        const bool sat = std::abs(true_rate) >= clip;
        clipped += sat;
        const glm::dvec3 gyro(std::clamp(true_rate, -clip, clip), 0, 0);
        f.update(int64_t(i) * 1'000'000, gyro, glm::conjugate(truth) * glm::dvec3(0, kG, 0),
                 {sat, false});
        if (t >= 3.2) {
            EXPECT_LT(tilt_deg(truth, f.orientation()), 0.5) << "at t = " << t;
        }
    }
    EXPECT_GT(clipped, 50u);
    EXPECT_EQ(f.saturated_gyro_samples(), clipped);
    EXPECT_LT(glm::length(f.gyro_bias()), 1e-3);
}

}  // namespace
}  // namespace hmdnode
