// Pose maths on GLM (conventions in the header): shortest-path slerp, rotation vectors (the
// quaternion exponential and logarithm), angular velocity by finite difference, and the
// registration error (rotation angle plus the parallax of the position error at a viewing
// distance). Every function O(1), no allocation.
#include "hmdnode/core/pose.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>

namespace hmdnode {

glm::dquat same_hemisphere(const glm::dquat& q, const glm::dquat& ref) {
    return glm::dot(q, ref) < 0.0 ? -q : q;
}

glm::dquat slerp_shortest(const glm::dquat& a, const glm::dquat& b_in, double t) {
    glm::dquat b = same_hemisphere(b_in, a);
    double d = std::clamp(glm::dot(a, b), -1.0, 1.0);
    // note: near-parallel inputs fall back to normalized lerp, where slerp's sin() ratio is
    // unstable.
    if (d > 0.9999995) return glm::normalize(a * (1.0 - t) + b * t);
    double theta = std::acos(d);
    double s = std::sin(theta);
    return glm::normalize(a * (std::sin((1.0 - t) * theta) / s) + b * (std::sin(t * theta) / s));
}

double angle_between_rad(const glm::dquat& a, const glm::dquat& b) {
    // The angle of a^-1 b; |dot| folds the double cover. atan2 form keeps precision at small
    // angles.
    glm::dquat d = glm::conjugate(a) * b;
    double v = std::sqrt(d.x * d.x + d.y * d.y + d.z * d.z);
    return 2.0 * std::atan2(v, std::abs(d.w));
}

glm::dquat quat_from_rotation_vector(const glm::dvec3& v) {
    double angle = glm::length(v);
    if (angle < 1e-12) return glm::normalize(glm::dquat(1.0, v.x * 0.5, v.y * 0.5, v.z * 0.5));
    glm::dvec3 axis = v / angle;
    double s = std::sin(angle * 0.5);
    return glm::dquat(std::cos(angle * 0.5), axis.x * s, axis.y * s, axis.z * s);
}

glm::dvec3 rotation_vector(const glm::dquat& q_in) {
    glm::dquat q = q_in.w < 0.0 ? -q_in : q_in;
    double v = std::sqrt(q.x * q.x + q.y * q.y + q.z * q.z);
    if (v < 1e-12) return glm::dvec3(q.x, q.y, q.z) * 2.0;
    double angle = 2.0 * std::atan2(v, q.w);
    return glm::dvec3(q.x, q.y, q.z) * (angle / v);
}

glm::dvec3 angular_velocity(const glm::dquat& q0, const glm::dquat& q1, double dt_s) {
    if (dt_s <= 0.0) return glm::dvec3(0.0);
    glm::dquat delta = same_hemisphere(q1, q0) * glm::conjugate(q0);  // world-frame delta
    return rotation_vector(delta) / dt_s;
}

glm::dquat integrate(const glm::dquat& q, const glm::dvec3& omega_world, double dt_s) {
    return glm::normalize(quat_from_rotation_vector(omega_world * dt_s) * q);
}

glm::dvec3 forward_of(const glm::dquat& q) {
    return q * glm::dvec3(0.0, 0.0, -1.0);
}

double registration_error_deg(const Pose& shown, const Pose& truth, double distance_m) {
    assert(distance_m > 0.0);
    const double rotation = angle_between_deg(shown.orientation, truth.orientation);
    const glm::dvec3 gaze = forward_of(truth.orientation);
    const glm::dvec3 dp = shown.position - truth.position;
    const glm::dvec3 dp_perp = dp - glm::dot(dp, gaze) * gaze;
    return rotation + rad_to_deg(std::atan(glm::length(dp_perp) / distance_m));
}

Pose interpolate(const Pose& a, const Pose& b, int64_t t_ns) {
    Pose out = a;
    out.time_ns = t_ns;
    if (b.time_ns <= a.time_ns) return out;
    double t = std::clamp(double(t_ns - a.time_ns) / double(b.time_ns - a.time_ns), 0.0, 1.0);
    out.orientation = slerp_shortest(a.orientation, b.orientation, t);
    out.position = glm::mix(a.position, b.position, t);
    if (a.angular_velocity && b.angular_velocity)
        out.angular_velocity = glm::mix(*a.angular_velocity, *b.angular_velocity, t);
    if (a.linear_velocity && b.linear_velocity)
        out.linear_velocity = glm::mix(*a.linear_velocity, *b.linear_velocity, t);
    return out;
}

}  // namespace hmdnode
