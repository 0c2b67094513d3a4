// Pose maths on GLM (double precision). Conventions: right-handed, +Y up, -Z forward, metres,
// unit quaternions (glm::dquat is w,x,y,z). q and -q are the same rotation (double cover): every
// function here treats them as equal.
#pragma once

#include <cstdint>
#include <optional>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

namespace hmdnode {

struct Pose {
    int64_t time_ns = 0;                         // host time the pose is valid at
    glm::dquat orientation{1.0, 0.0, 0.0, 0.0};  // head-to-world rotation
    glm::dvec3 position{0.0};                    // metres, world
    std::optional<glm::dvec3> angular_velocity;  // rad/s, world frame
    std::optional<glm::dvec3> linear_velocity;   // m/s, world frame
};

constexpr double kPi = 3.14159265358979323846;
constexpr double deg_to_rad(double d) {
    return d * kPi / 180.0;
}
constexpr double rad_to_deg(double r) {
    return r * 180.0 / kPi;
}

// q or -q, whichever lies in the same hemisphere as ref (dot >= 0).
glm::dquat same_hemisphere(const glm::dquat& q, const glm::dquat& ref);

// Shortest-path spherical interpolation, t in [0,1]; handles q/-q and nearly equal inputs.
glm::dquat slerp_shortest(const glm::dquat& a, const glm::dquat& b, double t);

// Rotation angle (radians, in [0, pi]) between two orientations, double-cover aware.
double angle_between_rad(const glm::dquat& a, const glm::dquat& b);
inline double angle_between_deg(const glm::dquat& a, const glm::dquat& b) {
    return rad_to_deg(angle_between_rad(a, b));
}

// Registration error (degrees) of showing the world for pose `shown` to a head at `truth`: the
// rotation angle between the orientations (angle_between_deg, roll included) plus the visual
// angle, at distance_m straight ahead of the true head, of the position error perpendicular to the
// true gaze: rad_to_deg(atan(|dp_perp| / distance_m)). By the triangle inequality on the sphere it
// bounds how far a point distance_m ahead appears displaced; the parallax term is exact when the
// position error along the gaze is zero, and first-order in it otherwise (a point brought closer
// by dp_par moves by atan(|dp_perp| / (distance_m - dp_par))). With equal positions it equals
// angle_between_deg exactly. distance_m > 0. O(1).
double registration_error_deg(const Pose& shown, const Pose& truth, double distance_m);

// World-frame angular velocity (rad/s) that rotates q0 into q1 in dt_s seconds:
// q1 = exp(omega*dt/2) * q0. Double-cover aware.
glm::dvec3 angular_velocity(const glm::dquat& q0, const glm::dquat& q1, double dt_s);

// Integrates a constant world-frame angular velocity over dt_s: exp(omega*dt/2) * q.
glm::dquat integrate(const glm::dquat& q, const glm::dvec3& omega_world, double dt_s);

// Rotation vector (axis * angle, radians) <-> quaternion.
glm::dquat quat_from_rotation_vector(const glm::dvec3& v);
glm::dvec3 rotation_vector(const glm::dquat& q);

// Forward (-Z of the head frame) in world coordinates.
glm::dvec3 forward_of(const glm::dquat& q);

// Interpolates two poses to time t_ns (slerp / lerp; clamps outside [a.time_ns, b.time_ns]).
Pose interpolate(const Pose& a, const Pose& b, int64_t t_ns);

}  // namespace hmdnode
