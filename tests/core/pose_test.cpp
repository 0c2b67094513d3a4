#include <gtest/gtest.h>

#include <glm/gtc/quaternion.hpp>

#include "hmdnode/core/pose.hpp"
#include "hmdnode/core/stereo.hpp"

using namespace hmdnode;

namespace {
glm::dquat yaw(double deg) {
    return glm::angleAxis(deg_to_rad(deg), glm::dvec3(0, 1, 0));
}
}  // namespace

TEST(Pose, AngleBetweenIgnoresDoubleCover) {
    glm::dquat a = yaw(10), b = yaw(40);
    EXPECT_NEAR(angle_between_deg(a, b), 30.0, 1e-9);
    EXPECT_NEAR(angle_between_deg(a, -b), 30.0, 1e-9);
    EXPECT_NEAR(angle_between_deg(a, -a), 0.0, 1e-9);
}

TEST(Pose, SlerpTakesTheShortPathAcrossASignFlip) {
    glm::dquat a = yaw(10), b = -yaw(30);  // b is the same rotation as yaw(30), opposite sign
    glm::dquat m = slerp_shortest(a, b, 0.5);
    EXPECT_NEAR(angle_between_deg(m, yaw(20)), 0.0, 1e-9);
    EXPECT_NEAR(angle_between_deg(slerp_shortest(a, b, 0.25), yaw(15)), 0.0, 1e-9);
}

TEST(Pose, AngularVelocityRoundTripsThroughIntegration) {
    glm::dquat q0 = glm::normalize(glm::dquat(0.9, 0.1, -0.3, 0.2));
    glm::dvec3 w(0.3, -1.2, 0.7);  // rad/s, world
    glm::dquat q1 = integrate(q0, w, 0.02);
    glm::dvec3 got = angular_velocity(q0, -q1, 0.02);
    EXPECT_NEAR(got.x, w.x, 1e-9);
    EXPECT_NEAR(got.y, w.y, 1e-9);
    EXPECT_NEAR(got.z, w.z, 1e-9);
}

TEST(Pose, YawNinetyTurnsForwardToMinusX) {
    glm::dvec3 f = forward_of(yaw(90));
    EXPECT_NEAR(f.x, -1.0, 1e-12);
    EXPECT_NEAR(f.z, 0.0, 1e-12);
}

TEST(Stereo, ProjectionMapsFrustumEdgesToClipEdges) {
    EyeFov fov{-1.2, 0.8, 1.0, -0.9};
    glm::mat4 p = eye_projection(fov, 0.1, 50.0);
    auto ndc = [&](glm::dvec3 v) {
        glm::vec4 c = p * glm::vec4(glm::vec3(v), 1.0f);
        return glm::dvec3(c) / double(c.w);
    };
    EXPECT_NEAR(ndc({0.8 * 2, 0, -2}).x, 1.0, 1e-5);    // right edge
    EXPECT_NEAR(ndc({-1.2 * 2, 0, -2}).x, -1.0, 1e-5);  // left edge
    EXPECT_NEAR(ndc({0, 1.0 * 2, -2}).y, -1.0, 1e-5);   // top edge is -1 in Vulkan
    EXPECT_NEAR(ndc({0, -0.9 * 2, -2}).y, 1.0, 1e-5);
    EXPECT_NEAR(ndc({0, 0, -0.1}).z, 0.0, 1e-5);
    EXPECT_NEAR(ndc({0, 0, -50}).z, 1.0, 1e-5);
}

TEST(Stereo, EyesAreOffsetByTheIpdAlongTheHeadsXAxis) {
    StereoRig rig = StereoRig::typical();
    rig.ipd_m = 0.064;
    Pose head;
    head.orientation = yaw(90);  // head x axis now points to world -Z
    head.position = {1, 1.6, 2};
    for (int eye = 0; eye < 2; ++eye) {
        glm::dmat4 world = glm::inverse(glm::dmat4(eye_view_matrix(rig, head, eye)));
        glm::dvec3 pos(world[3]);
        EXPECT_NEAR(pos.x, 1.0, 1e-5);
        EXPECT_NEAR(pos.z, 2.0 + (eye == 0 ? 0.032 : -0.032), 1e-5);
    }
}
