// Mahony complementary filter: R. Mahony, T. Hamel, J.-M. Pflimlin, "Nonlinear Complementary
// Filters on the Special Orthogonal Group", IEEE TAC 53(5), 2008, §V "explicit complementary
// filter with bias correction" (eqs. 32): omega = gyro - b + kP e, db/dt = -kI e, e = a x v with v
// the estimated world-up in the body frame.
// Cost: O(1) time, no memory beyond the filter state.
// Departures: (1) gravity correction is gated when |a| is far from g (the paper assumes a ~ -g);
// (2) higher gains for a short initial period and an initial attitude taken from the first
// accelerometer sample (fast alignment); (3) when the device is still (|a| near g and the
// corrected rate small) the bias also relaxes toward the raw gyro with a time constant, which
// observes the yaw-axis bias the gravity error cannot; (4) the integral uses the sample's dt,
// clamped to max_dt_ns across gaps.
#include "hmdnode/hal/tracking/imu_fusion.hpp"

#include <algorithm>
#include <cmath>

namespace hmdnode {
namespace {

// Shortest rotation taking unit vector a onto unit vector b.
glm::dquat rotation_between(const glm::dvec3& a, const glm::dvec3& b) {
    const double c = glm::dot(a, b);
    if (c < -0.999999) {
        glm::dvec3 axis = glm::cross(glm::dvec3(1, 0, 0), a);
        if (glm::length(axis) < 1e-6) axis = glm::cross(glm::dvec3(0, 0, 1), a);
        return glm::angleAxis(3.14159265358979323846, glm::normalize(axis));
    }
    const glm::dvec3 axis = glm::cross(a, b);
    return glm::normalize(glm::dquat(1.0 + c, axis.x, axis.y, axis.z));
}

// q * exp(w dt / 2): body-frame angular velocity integration.
glm::dquat integrate(const glm::dquat& q, const glm::dvec3& w, double dt) {
    const double angle = glm::length(w) * dt;
    if (angle < 1e-12) return q;
    return glm::normalize(q * glm::angleAxis(angle, w / glm::length(w)));
}

}  // namespace

ImuFusion::ImuFusion(const ImuFusionConfig& config) : config_(config) {}

void ImuFusion::reset() {
    *this = ImuFusion(config_);
}

void ImuFusion::update(int64_t time_ns, const glm::dvec3& gyro, const glm::dvec3& accel) {
    const double a_norm = glm::length(accel);
    if (!initialized_) {
        initialized_ = true;
        first_ns_ = last_ns_ = time_ns;
        if (a_norm > 1e-6) q_ = rotation_between(accel / a_norm, glm::dvec3(0, 1, 0));
        omega_ = gyro - bias_;
        return;
    }
    const int64_t dt_ns = std::clamp<int64_t>(time_ns - last_ns_, 0, config_.max_dt_ns);
    last_ns_ = std::max(last_ns_, time_ns);
    const double dt = double(dt_ns) * 1e-9;
    const bool init_phase = time_ns - first_ns_ < config_.init_duration_ns;
    const double kp = init_phase ? config_.init_kp : config_.kp;
    const double ki = init_phase ? config_.init_ki : config_.ki;

    glm::dvec3 e(0.0);
    const double g = config_.gravity;
    if (a_norm > 1e-6 && std::abs(a_norm - g) <= config_.accel_gate * g) {
        const glm::dvec3 v = glm::conjugate(q_) * glm::dvec3(0, 1, 0);  // world up, head frame
        e = glm::cross(accel / a_norm, v);
    } else {
        ++gated_;
    }

    still_ =
        std::abs(a_norm - g) < 0.02 * g && glm::length(gyro - bias_) < config_.still_gyro_rad_s;
    bias_ -= ki * e * dt;
    if (still_) {
        const double tau = init_phase ? config_.still_bias_tau_s * 0.1 : config_.still_bias_tau_s;
        bias_ += (gyro - bias_) * std::min(1.0, dt / tau);
    }
    bias_ =
        glm::clamp(bias_, glm::dvec3(-config_.max_bias_rad_s), glm::dvec3(config_.max_bias_rad_s));

    omega_ = gyro - bias_;
    q_ = integrate(q_, omega_ + kp * e, dt);
}

}  // namespace hmdnode
