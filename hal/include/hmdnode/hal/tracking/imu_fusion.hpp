// IMU fusion for IMU-only trackers: a Mahony complementary filter (gyro integration, gravity
// correction from the accelerometer, gyro-bias estimation by the integral term), plus bias
// learning while the device is still, which also observes the yaw bias gravity cannot.
//
// Frames (docs/DESIGN.md, docs/tracker-protocol.md): the head frame is x right, y up, z backward
// (-z forward); the world frame is y up. The accelerometer gives specific force, so a device at
// rest reads +g along world up. orientation() is head-to-world; yaw starts at 0.
//
// One thread; update() is O(1) and allocation-free.
#pragma once

#include <cstdint>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

namespace hmdnode {

struct ImuFusionConfig {
    double kp = 1.0;        // rad/s of correction per unit of (normalised) gravity error
    double ki = 0.05;       // rad/s^2 of bias change per unit error (integral term)
    double init_kp = 10.0;  // gains for the first init_duration_ns: fast initial alignment
    double init_ki = 0.5;
    int64_t init_duration_ns = 500'000'000;
    double gravity = 9.80665;        // m/s^2
    double accel_gate = 0.10;        // no gravity correction when | |a| - g | > gate * g
    double still_gyro_rad_s = 0.05;  // still: |gyro - bias| below this and |a| within 2 % of g
    double still_bias_tau_s = 2.0;   // bias follows the raw gyro with this time constant when still
    double max_bias_rad_s = 0.2;     // bias estimate clamp (per axis)
    int64_t max_dt_ns = 50'000'000;  // a longer gap is integrated as this (sample loss)
};

class ImuFusion {
  public:
    explicit ImuFusion(const ImuFusionConfig& config = {});

    void reset();

    // One sample: time on any monotonic clock (ns), gyro in rad/s and accel in m/s^2, head frame.
    // The first sample aligns the orientation to gravity (yaw 0).
    void update(int64_t time_ns, const glm::dvec3& gyro, const glm::dvec3& accel);

    bool initialized() const { return initialized_; }
    glm::dquat orientation() const { return q_; }           // head-to-world
    glm::dvec3 angular_velocity() const { return omega_; }  // bias-corrected gyro, head frame
    glm::dvec3 gyro_bias() const { return bias_; }
    bool still() const { return still_; }
    uint64_t gated_samples() const { return gated_; }  // samples with no gravity correction

  private:
    ImuFusionConfig config_;
    bool initialized_ = false;
    int64_t first_ns_ = 0;
    int64_t last_ns_ = 0;
    glm::dquat q_{1, 0, 0, 0};
    glm::dvec3 bias_{0.0};
    glm::dvec3 omega_{0.0};
    bool still_ = false;
    uint64_t gated_ = 0;
};

}  // namespace hmdnode
