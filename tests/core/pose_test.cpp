#include <algorithm>
#include <cmath>

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

TEST(Pose, RegistrationErrorEqualsTheAngleWhenPositionsAgree) {
    Pose shown, truth;
    shown.orientation = glm::normalize(glm::dquat(0.9, 0.1, -0.3, 0.2));
    truth.orientation = glm::normalize(glm::dquat(0.8, 0.2, -0.1, 0.4));
    shown.position = truth.position = {1.0, 1.6, -2.0};
    EXPECT_EQ(registration_error_deg(shown, truth, 1.0),
              angle_between_deg(shown.orientation, truth.orientation));
}

TEST(Pose, RegistrationErrorAddsTheParallaxOfThePerpendicularOffset) {
    Pose shown, truth;  // truth looks down -Z
    shown.position = {0.1, 0.0, 0.0};
    EXPECT_NEAR(registration_error_deg(shown, truth, 1.0), rad_to_deg(std::atan(0.1)), 1e-12);
    EXPECT_NEAR(registration_error_deg(shown, truth, 2.0), rad_to_deg(std::atan(0.05)), 1e-12);
    shown.position = {0.0, 0.0, -0.5};  // along the gaze: no parallax term
    EXPECT_NEAR(registration_error_deg(shown, truth, 1.0), 0.0, 1e-12);
    // Yaw 90: the gaze is world -X, so Y and Z offsets are perpendicular, X is along it; roll and
    // the 5-degree yaw difference add as the rotation angle.
    truth.orientation = yaw(90);
    shown.orientation = yaw(95);
    shown.position = {0.7, 0.2, 0.3};
    EXPECT_NEAR(registration_error_deg(shown, truth, 2.0),
                5.0 + rad_to_deg(std::atan(std::sqrt(0.13) / 2.0)), 1e-9);
}

TEST(Pose, RegistrationErrorBoundsTheDisplacementOfAPointAhead) {
    // A point distance_m straight ahead of the true head, seen from the shown pose: its direction
    // in the head frame moves by at most the registration error (offsets perpendicular to gaze).
    const double d = 1.5;
    for (int i = 0; i < 200; ++i) {
        Pose truth, shown;
        truth.orientation = glm::normalize(
            glm::dquat(1.0, 0.3 * std::sin(i), 0.2 * std::cos(3 * i), 0.1 * std::sin(7 * i)));
        shown.orientation = integrate(truth.orientation, glm::dvec3(0.02 * std::cos(i), 0.03, 0.0),
                                      std::sin(5 * i));
        const glm::dvec3 g = forward_of(truth.orientation);
        glm::dvec3 off(0.05 * std::sin(2 * i), 0.04 * std::cos(i), 0.03 * std::sin(11 * i));
        off -= glm::dot(off, g) * g;
        truth.position = {0.0, 1.6, 0.0};
        shown.position = truth.position + off;
        const glm::dvec3 point = truth.position + d * g;
        const glm::dvec3 seen = glm::conjugate(shown.orientation) * (point - shown.position);
        const double moved = rad_to_deg(
            std::acos(std::clamp(glm::dot(glm::normalize(seen), glm::dvec3(0, 0, -1)), -1.0, 1.0)));
        EXPECT_LE(moved, registration_error_deg(shown, truth, d) + 1e-9) << i;
    }
}
