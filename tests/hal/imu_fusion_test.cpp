// IMU fusion against synthetic motion with known truth: the true orientation is integrated
// finely from a known body rate; the gyro reads that rate plus a bias and noise, the accelerometer
// reads gravity in the head frame plus noise.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <random>

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
    const glm::dvec3 bias(0.02, -0.015, 0.01);
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
    const glm::dvec3 bias(0.01, 0.012, -0.008);  // y: the yaw axis when level
    auto rate = [](double) { return glm::dvec3(0); };
    RunResult warm = run(rate, glm::dquat(1, 0, 0, 0), 10.0, 1e9, bias, 0.002, 0.02, f);
    EXPECT_NEAR(warm.bias.y, bias.y, 0.001);
    const glm::dquat held = f.orientation();
    run(rate, glm::dquat(1, 0, 0, 0), 10.0, 0.0, bias, 0.002, 0.02, f);
    EXPECT_LT(angle_deg(held, f.orientation()), 0.3);  // < 0.03 deg/s of drift
    EXPECT_TRUE(f.still());
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

}  // namespace
}  // namespace hmdnode
