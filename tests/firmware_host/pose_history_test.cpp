#include <gtest/gtest.h>

#include <glm/gtc/quaternion.hpp>

#include "hmdnode/core/time.hpp"
#include "hmdnode/firmware_host/pose_history.hpp"

using namespace hmdnode;

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
