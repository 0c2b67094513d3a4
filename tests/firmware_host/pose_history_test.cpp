#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <new>
#include <vector>

#include <gtest/gtest.h>

#include <glm/gtc/quaternion.hpp>

#include "hmdnode/core/percentile.hpp"
#include "hmdnode/core/time.hpp"
#include "hmdnode/core/trace.hpp"
#include "hmdnode/firmware_host/pose_history.hpp"

using namespace hmdnode;

// Counts every allocation of this test program, to prove that queries allocate nothing.
// (GCC 12 sees the replaced operator delete's free() inlined where GoogleTest's `new TestClass`
// calls the replaced operator new, whose malloc() it does not see, and warns of a mismatch that
// is not one: both are replaced, as the standard allows.)
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
namespace {
std::atomic<long> g_allocations{0};
}  // namespace
void* operator new(std::size_t n) {
    g_allocations.fetch_add(1, std::memory_order_relaxed);
    if (void* p = std::malloc(n ? n : 1)) return p;
    throw std::bad_alloc();
}
void operator delete(void* p) noexcept {
    std::free(p);
}
void operator delete(void* p, std::size_t) noexcept {
    std::free(p);
}

namespace {
glm::dquat yaw(double deg) {
    return glm::angleAxis(deg_to_rad(deg), glm::dvec3(0, 1, 0));
}
TrackerSample sample(int64_t t_ns, glm::dquat q) {
    TrackerSample s;
    s.time_ns = t_ns;
    s.arrival_ns = t_ns;
    s.has_orientation = true;
    s.orientation = q;
    return s;
}
}  // namespace

TEST(PoseHistory, SlerpsBetweenSamples) {
    PoseHistory h;
    h.push(sample(0, yaw(0)));
    h.push(sample(10 * kNsPerMs, yaw(10)));
    PoseQuery kind;
    Pose p = h.pose_at(4 * kNsPerMs, &kind);
    EXPECT_EQ(kind, PoseQuery::Interpolated);
    EXPECT_NEAR(angle_between_deg(p.orientation, yaw(4)), 0.0, 1e-9);
}

// A lighthouse device's samples carry no position while it is not tracked (docs/tracking.md §12):
// the last one is held, with no velocity, instead of the origin.
TEST(PoseHistory, ASampleWithoutAPositionHoldsTheLastOne) {
    PoseHistory h;
    for (int i = 0; i < 50; ++i) {
        TrackerSample s = sample(i * kNsPerMs, yaw(0));
        s.position = glm::dvec3(0.001 * i, 1.5, 0.0);  // 1 m/s along x
        h.push(s);
    }
    for (int i = 50; i < 100; ++i) h.push(sample(i * kNsPerMs, yaw(0)));
    const Pose p = h.pose_at(99 * kNsPerMs);
    EXPECT_NEAR(glm::length(p.position - glm::dvec3(0.049, 1.5, 0.0)), 0.0, 1e-12);
    const MotionEstimate m = h.motion();
    EXPECT_TRUE(m.has_position);
    EXPECT_LT(glm::length(m.linear_velocity), 1e-9);  // the fit window holds only held samples
    // An orientation-only tracker never gets one.
    PoseHistory o;
    o.push(sample(0, yaw(0)));
    o.push(sample(kNsPerMs, yaw(1)));
    EXPECT_FALSE(o.newest().position.has_value());
}

TEST(PoseHistory, SignFlippedSamplesCauseNoJump) {
    PoseHistory h;
    for (int i = 0; i <= 10; ++i) h.push(sample(i * kNsPerMs, (i % 2 ? -1.0 : 1.0) * yaw(i)));
    for (int64_t t = 0; t <= 10 * kNsPerMs; t += kNsPerMs / 4) {
        Pose p = h.pose_at(t);
        EXPECT_NEAR(angle_between_deg(p.orientation, yaw(ns_to_ms(t))), 0.0, 1e-9) << t;
    }
    EXPECT_NEAR(rad_to_deg(glm::length(h.angular_velocity())), 1000.0, 1e-6);  // 1 deg per ms
}

TEST(PoseHistory, ExtrapolatesAConstantTurnExactlyAndBoundsTheHorizon) {
    PoseHistoryConfig cfg;
    cfg.max_extrapolation_ns = 30 * kNsPerMs;
    PoseHistory h(cfg);
    for (int i = 0; i <= 50; ++i) h.push(sample(i * kNsPerMs, yaw(0.1 * i)));  // 100 deg/s
    PoseQuery kind;
    Pose p = h.pose_at(70 * kNsPerMs, &kind);
    EXPECT_EQ(kind, PoseQuery::Extrapolated);
    EXPECT_NEAR(angle_between_deg(p.orientation, yaw(7.0)), 0.0, 1e-6);
    p = h.pose_at(500 * kNsPerMs, &kind);
    EXPECT_EQ(kind, PoseQuery::ClampedNew);
    EXPECT_NEAR(angle_between_deg(p.orientation, yaw(8.0)), 0.0, 1e-6);  // held at +30 ms
}

TEST(PoseHistory, UsesTheGyroWhenTheTrackerHasOne) {
    PoseHistory h;
    TrackerSample s = sample(0, yaw(90));
    s.gyro = glm::dvec3(deg_to_rad(-20.0), 0, 0);  // head frame: pitch down at 20 deg/s
    h.push(s);
    glm::dvec3 w = h.angular_velocity();
    // Head x axis after a 90 deg yaw is world -Z.
    EXPECT_NEAR(w.z, deg_to_rad(20.0), 1e-12);
    EXPECT_NEAR(w.x, 0.0, 1e-12);
}

TEST(PoseHistory, IgnoresOutOfOrderSamplesAndWrapsAround) {
    PoseHistoryConfig cfg;
    cfg.capacity = 8;
    PoseHistory h(cfg);
    for (int i = 0; i < 20; ++i) EXPECT_TRUE(h.push(sample(i * kNsPerMs, yaw(i))));
    EXPECT_FALSE(h.push(sample(5 * kNsPerMs, yaw(0))));
    EXPECT_EQ(h.size(), 8u);
    EXPECT_EQ(h.oldest_time_ns(), 12 * kNsPerMs);
    EXPECT_NEAR(angle_between_deg(h.pose_at(15500 * kNsPerUs).orientation, yaw(15.5)), 0.0, 1e-9);
}

namespace {
double yaw_deg_of(const glm::dquat& q) {
    const glm::dvec3 r = rotation_vector(q);
    return rad_to_deg(r.y);
}
}  // namespace

TEST(PoseHistory, BoundsTheOvershootOfAFlickThatStopsAbruptly) {
    // 1000 deg/s for 150 ms at 1 kHz, then the head stops dead at 150 deg.
    PoseHistoryConfig cfg;
    PoseHistoryConfig old = cfg;
    old.prediction.model = PredictionModel::ConstantVelocity;
    PoseHistory h(cfg), h_old(old);
    const int64_t horizon = 30 * kNsPerMs;
    double worst = 0.0, worst_old = 0.0;
    for (int i = 0; i <= 300; ++i) {
        const glm::dquat q = yaw(std::min(i, 150) * 1.0);
        h.push(sample(i * kNsPerMs, q));
        h_old.push(sample(i * kNsPerMs, q));
        const double truth = std::min(i * kNsPerMs + horizon, 150 * kNsPerMs) / double(kNsPerMs);
        worst = std::max(worst, yaw_deg_of(h.pose_at(i * kNsPerMs + horizon).orientation) - truth);
        worst_old = std::max(worst_old,
                             yaw_deg_of(h_old.pose_at(i * kNsPerMs + horizon).orientation) - truth);
    }
    EXPECT_LE(worst, cfg.prediction.max_rotation_deg + 1e-9);
    EXPECT_GT(worst_old, 25.0);  // the former predictor runs on for most of the horizon
}

TEST(PoseHistory, BoundsThePredictedRotation) {
    PoseHistory h;
    for (int i = 0; i <= 20; ++i) h.push(sample(i * kNsPerMs, yaw(2.0 * i)));  // 2000 deg/s
    Pose p = h.pose_at(40 * kNsPerMs);                                         // 40 deg ahead
    EXPECT_NEAR(angle_between_deg(p.orientation, yaw(40.0 + 10.0)), 0.0, 1e-9);
}

TEST(PoseHistory, ClampsTheExtrapolatedAcceleration) {
    // theta = 1/2 a t^2 about a fixed axis, a = 20000 deg/s^2: the parabola fit is exact.
    const double a = 20000.0;
    auto theta = [&](double t_s) { return 0.5 * a * t_s * t_s; };
    PoseHistoryConfig cfg;
    cfg.prediction.accel_gain = 1.0;
    cfg.prediction.max_angular_accel_deg_s2 = 5000.0;
    cfg.prediction.max_rotation_deg = 0.0;
    cfg.prediction.window_knee_deg_s = 0.0;
    PoseHistoryConfig free_cfg = cfg;
    free_cfg.prediction.max_angular_accel_deg_s2 = 0.0;
    PoseHistory h(cfg), h_free(free_cfg);
    for (int i = 0; i <= 100; ++i) {
        h.push(sample(i * kNsPerMs, yaw(theta(i * 1e-3))));
        h_free.push(sample(i * kNsPerMs, yaw(theta(i * 1e-3))));
    }
    const double t = 0.1, dt = 0.01, w = a * t;  // w = 2000 deg/s at the newest sample
    EXPECT_NEAR(rad_to_deg(glm::length(h.motion().angular_acceleration)), a, 1e-3);
    EXPECT_NEAR(yaw_deg_of(h_free.pose_at(s_to_ns(t + dt)).orientation), theta(t + dt), 1e-6);
    EXPECT_NEAR(yaw_deg_of(h.pose_at(s_to_ns(t + dt)).orientation),
                theta(t) + w * dt + 0.5 * 5000.0 * dt * dt, 1e-6);
}

TEST(PoseHistory, FollowsADecelerationToAStopAndNoFurther) {
    // w = 200 deg/s at the newest sample, slowing at 20000 deg/s^2: it stops 1 deg later, 10 ms on.
    PoseHistoryConfig cfg;
    cfg.prediction.decel_gain = 1.0;
    cfg.prediction.max_angular_accel_deg_s2 = 0.0;
    cfg.prediction.window_knee_deg_s = 0.0;
    PoseHistory h(cfg);
    auto theta = [](double t_s) { return 200.0 * t_s - 0.5 * 20000.0 * t_s * t_s; };
    for (int i = -20; i <= 0; ++i)
        h.push(sample(100 * kNsPerMs + i * kNsPerMs, yaw(theta(i * 1e-3))));
    EXPECT_NEAR(yaw_deg_of(h.pose_at(105 * kNsPerMs).orientation), theta(0.005), 1e-6);
    Pose stopped = h.pose_at(130 * kNsPerMs);
    EXPECT_NEAR(yaw_deg_of(stopped.orientation), 1.0, 1e-6);
    EXPECT_NEAR(glm::length(*stopped.angular_velocity), 0.0, 1e-12);
}

TEST(PoseHistory, PredictsAConstantLinearMotionExactly) {
    const glm::dvec3 v(0.3, -0.1, 1.2), p0(1.0, 1.6, -2.0);  // m/s, m
    PoseHistory h;
    for (int i = 0; i <= 30; ++i) {
        TrackerSample s = sample(i * kNsPerMs, yaw(0.05 * i));
        s.position = p0 + v * (i * 1e-3);
        h.push(s);
    }
    PoseQuery kind;
    Pose p = h.pose_at(45 * kNsPerMs, &kind);
    EXPECT_EQ(kind, PoseQuery::Extrapolated);
    const glm::dvec3 want = p0 + v * 0.045;
    EXPECT_NEAR(glm::length(p.position - want), 0.0, 1e-9);
    ASSERT_TRUE(p.linear_velocity.has_value());
    EXPECT_NEAR(glm::length(*p.linear_velocity - v), 0.0, 1e-9);
    EXPECT_NEAR(angle_between_deg(p.orientation, yaw(0.05 * 45)), 0.0, 1e-9);
    // Inside the history the velocity comes with the interpolated pose.
    ASSERT_TRUE(h.pose_at(10 * kNsPerMs).linear_velocity.has_value());
}

TEST(PoseHistory, HoldsThePositionWhenSamplesCarryNone) {
    PoseHistory h;
    for (int i = 0; i <= 10; ++i) h.push(sample(i * kNsPerMs, yaw(i)));
    Pose p = h.pose_at(20 * kNsPerMs);
    EXPECT_EQ(p.position, glm::dvec3(0.0));
    EXPECT_FALSE(p.linear_velocity.has_value());
    // Only the newest carries one: nothing to fit, so it is held there.
    TrackerSample s = sample(11 * kNsPerMs, yaw(11));
    s.position = glm::dvec3(0.5, 1.7, 0.0);
    h.push(s);
    p = h.pose_at(20 * kNsPerMs);
    EXPECT_EQ(p.position, *s.position);
    ASSERT_TRUE(p.linear_velocity.has_value());
    EXPECT_EQ(*p.linear_velocity, glm::dvec3(0.0));
}

TEST(PoseHistory, QueriesDoNotAllocate) {
    PoseHistory h;  // the ring is allocated here, once
    for (int i = 0; i < 5000; ++i) {
        TrackerSample s = sample(i * kNsPerMs, yaw(0.01 * i * i));
        s.position = glm::dvec3(0.001 * i, 1.6, 0.0);
        h.push(s);
    }
    const long before = g_allocations.load();
    double sink = 0.0;
    for (int64_t t = 4000 * kNsPerMs; t < 5050 * kNsPerMs; t += kNsPerMs / 3) {
        Pose p = h.pose_at(t);
        sink += p.orientation.w + p.position.x + glm::length(h.angular_velocity());
        TrackerSample s = sample(5000 * kNsPerMs + t, yaw(1.0));
        h.push(s);  // push is allocation-free too
    }
    EXPECT_EQ(g_allocations.load() - before, 0);
    EXPECT_TRUE(std::isfinite(sink));
}

namespace {
// Replays a trace into a PoseHistory as the runtime sees it (1 kHz slerp resampling, as
// `--resample 1000`, or the native samples) and, every 11.1 ms frame, predicts `horizon` beyond
// the frame time; errors against the trace's own slerped truth. out_overshoot: the largest amount a
// prediction went past the truth in the direction it predicted (degrees).
std::vector<double> prediction_errors_deg(const Trace& trace, bool resample_1khz,
                                          const PoseHistoryConfig& cfg, int64_t horizon,
                                          double* out_overshoot) {
    *out_overshoot = 0.0;
    PoseHistory h(cfg);
    std::vector<double> err;
    err.reserve(size_t(ns_to_s(trace.end_ns() - trace.start_ns()) * 90.0) + 1);
    size_t next = 0;
    double next_resample = double(trace.start_ns());
    auto push_until = [&](int64_t t) {
        if (resample_1khz) {
            for (; next_resample <= double(t); next_resample += 1e6)
                h.push(sample(int64_t(next_resample),
                              trace.pose_at(int64_t(next_resample)).orientation));
        } else {
            for (; next < trace.samples.size() && trace.samples[next].time_ns <= t; ++next)
                h.push(sample(trace.samples[next].time_ns, trace.samples[next].orientation));
        }
    };
    for (double f = double(trace.start_ns() + 100 * kNsPerMs);
         f + double(horizon) <= trace.end_ns(); f += 1e9 / 90.0) {
        const int64_t t = int64_t(f);
        push_until(t);
        const glm::dquat predicted = h.pose_at(t + horizon).orientation;
        const glm::dquat truth = trace.pose_at(t + horizon).orientation;
        err.push_back(angle_between_deg(predicted, truth));
        const glm::dquat inv_newest = glm::conjugate(h.newest().orientation);
        const glm::dvec3 r = rotation_vector(predicted * inv_newest);
        const glm::dvec3 r_true = rotation_vector(same_hemisphere(truth, predicted) * inv_newest);
        if (glm::length(r) > 0.0)
            *out_overshoot =
                std::max(*out_overshoot, rad_to_deg(glm::dot(r - r_true, glm::normalize(r))));
    }
    return err;
}
}  // namespace

TEST(PoseHistory, BeatsConstantVelocityOnARealHeadTrace) {
    // docs/prediction.md prints these figures (this test's output).
    Result<Trace> trace = read_trace_csv(HMDNODE_SOURCE_DIR "/data/traces/corbillon2018_user1.csv");
    ASSERT_TRUE(trace.ok()) << trace.error().message;
    PoseHistoryConfig fresh, old;
    old.prediction.model = PredictionModel::ConstantVelocity;
    for (bool khz : {true, false}) {
        for (int64_t horizon : {8 * kNsPerMs, 17 * kNsPerMs}) {
            double over_old = 0.0, over_new = 0.0;
            const std::vector<double> e_old =
                prediction_errors_deg(*trace, khz, old, horizon, &over_old);
            const std::vector<double> e_new =
                prediction_errors_deg(*trace, khz, fresh, horizon, &over_new);
            const double old_p99 = percentile(e_old, 0.99), new_p99 = percentile(e_new, 0.99);
            const double old_max = *std::max_element(e_old.begin(), e_old.end());
            const double new_max = *std::max_element(e_new.begin(), e_new.end());
            std::printf(
                "%s %2.0f ms | old p50 %.3f p95 %.3f p99 %.3f max %.2f over %.2f | new p50 "
                "%.3f p95 %.3f p99 %.3f max %.2f over %.2f (deg, %zu frames)\n",
                khz ? "1 kHz " : "native", ns_to_ms(horizon), percentile(e_old, 0.5),
                percentile(e_old, 0.95), old_p99, old_max, over_old, percentile(e_new, 0.5),
                percentile(e_new, 0.95), new_p99, new_max, over_new, e_new.size());
            EXPECT_LT(new_p99, old_p99) << khz << " " << horizon;
            EXPECT_LT(new_max, old_max) << khz << " " << horizon;
            if (khz && horizon == 8 * kNsPerMs) {
                EXPECT_LE(new_p99, 0.3);  // the late-warp target
            }
        }
    }
}
