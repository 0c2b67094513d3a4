// Light + IMU fusion: an error-state Kalman filter (Sola 2017) over position, velocity,
// orientation, gyro bias, accelerometer bias and the world's gravity direction, propagated by
// every IMU sample and updated by optical pose solves (docs/tracking.md §10).
//
// Frames. The body frame is the frame the poses are of (for a lighthouse device: its head frame,
// `LighthouseSensors::model_from_head`); IMU samples come in its axes, as the report codecs give
// them (`DeviceSample::gyro`/`accel`: rad/s and m/s^2, specific force, +g up at rest), from an IMU
// whose origin lies at `PoseFilterConfig::imu_position` in it (the lever arm). The world is the
// base stations' (`world_up` says which way gravity points). Orientations are body-to-world.
//
// Times are on one device clock (the IMU samples' `device_time_ns`), ns. Measurements are late by
// nature (a light solve needs a sweep): the filter keeps its state after each of the last
// `history_samples` IMU samples, goes back to the one before a measurement, updates there and
// propagates forward again. One older than the last measurement applied (out of order) or than
// the history is rejected and counted; one newer than the newest IMU sample waits for it.
//
// Position states: `none` (no light yet: orientation only, from gyro and gravity, yaw arbitrary;
// position held at 0), `tracked` (a light update accepted recently, position sigma small: the only
// state whose pose is good), `coasting` (position from the IMU alone, confidence falling; or an
// initialisation no second solve has confirmed yet), `lost`
// (too long without light, or too uncertain: position held, orientation only, until a
// measurement re-initialises it).
//
// One thread. add_imu() is O(1) (an 18x18 covariance step); add_pose() costs one step per IMU
// sample since the measurement's time. No allocation after construction.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <optional>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

#include "hmdnode/hal/tracking/imu_fusion.hpp"

namespace hmdnode {

// A pose solve of the body frame (what the optical solver gives).
struct PoseMeasurement {
    int64_t device_time_ns = 0;            // when the light saw the device, IMU clock
    glm::dvec3 position{0.0};              // m, world: the body frame's origin
    glm::dquat orientation{1, 0, 0, 0};    // body-to-world
    double position_sigma_m = 0.003;       // per axis (e.g. from the solve's residual)
    double orientation_sigma_rad = 0.003;  // per axis
    // Row-major covariance of [position (world, m); orientation error (rotation vector in the body
    // frame, rad)]; replaces the two sigmas when set. Must be symmetric positive definite.
    std::optional<std::array<double, 36>> covariance;
};

struct PoseFilterConfig {
    double gravity = 9.80665;      // m/s^2
    glm::dvec3 world_up{0, 1, 0};  // unit; libsurvive's world is z up
    glm::dvec3 imu_position{0.0};  // the IMU's origin in the body frame, m
    // IMU white noise densities and bias random walks (continuous time).
    double gyro_noise = 2e-4;  // rad/s/sqrt(Hz)
    // What the IMU model lacks, as white noise: gyro scale and axis errors grow with the rate,
    // accelerometer scale, axis, clipping and filtering errors with the motion. Set on the one
    // real light + IMU recording at hand (docs/tracking.md §10): ten times less of either made the
    // filter gate good solves in fast motion and lose the position there; the sensors' own white
    // noise (the still Vive: 5e-5 rad/s and 8e-4 m/s^2 per sqrt(Hz)) is far below both.
    double gyro_rate_noise = 0.02;    // rad/s/sqrt(Hz) per rad/s of |w|
    double accel_noise = 0.2;         // m/s^2/sqrt(Hz)
    double gyro_bias_walk = 1e-4;     // rad/s^2/sqrt(Hz)
    double accel_bias_walk = 1e-3;    // m/s^3/sqrt(Hz)
    bool estimate_accel_bias = true;  // false: the accel bias stays 0 (not a state)
    // Gravity in the world as a state (Sola 2017 §5.3: the light's world, from the base stations,
    // is level only to their accelerometers'): its direction within world_tilt_sigma_rad of -up.
    bool estimate_world_tilt = true;
    double world_tilt_sigma_rad = 0.05;
    double initial_gyro_bias_sigma = 0.03;  // rad/s
    double initial_accel_bias_sigma = 0.1;  // m/s^2
    double initial_velocity_sigma = 0.5;    // m/s, at (re-)initialisation
    // A sample at full scale lost an unknown part of the motion: its variance grows by this
    // rate (or acceleration) error over its interval.
    double saturated_gyro_sigma = 5.0;    // rad/s
    double saturated_accel_sigma = 20.0;  // m/s^2
    // Gravity updates (orientation-only states): accelerometer direction, sigma per axis, inflated
    // by (1 + (|w| / gravity_rate_scale)^2); none when | |a| - g | > accel_gate * g.
    double gravity_sigma = 1.0;       // m/s^2
    double gravity_rate_scale = 1.0;  // rad/s
    double accel_gate = 0.02;
    // Gating: squared Mahalanobis distance of a pose residual (6 dof) at most this (chi-square
    // quantile 0.9999: a consistent filter rejects one good solve in 10,000).
    double gate_chi2 = 27.86;
    // Initialisation: the measured tilt against a near-still accelerometer's, at most this.
    double init_tilt_tolerance_rad = 0.25;
    // Confidence: 1 until stale_after_ns without an accepted update, 0 at lost_after_ns; times 1
    // below good_position_sigma_m (per-axis RMS of the body origin), 0 at lost_position_sigma_m.
    int64_t stale_after_ns = 100'000'000;
    int64_t lost_after_ns = 500'000'000;
    double good_position_sigma_m = 0.01;
    double lost_position_sigma_m = 0.05;
    int64_t max_dt_ns = 50'000'000;  // a longer IMU gap is integrated as this
    int history_samples = 256;       // states kept for late measurements
    int pending_measurements = 8;    // measurements ahead of the IMU, waiting
};

enum class PositionState : uint8_t { none, tracked, coasting, lost };
const char* to_string(PositionState s);

// The filter's estimate of the body frame at one device time.
struct FilterPose {
    int64_t device_time_ns = 0;
    glm::dvec3 position{0.0};            // m, world (held when not tracked)
    glm::dquat orientation{1, 0, 0, 0};  // body-to-world
    glm::dvec3 linear_velocity{0.0};     // m/s, world, of the body origin (0 when held)
    glm::dvec3 angular_velocity{0.0};    // rad/s, world (bias-corrected gyro)
    PositionState state = PositionState::none;
    double confidence = 0;             // 0..1 (0 unless a position has been tracked)
    double position_sigma_m = 0;       // per-axis RMS; infinite when held
    double orientation_sigma_rad = 0;  // per-axis RMS
    bool good() const { return state == PositionState::tracked; }
};

enum class MeasurementResult : uint8_t {
    accepted,       // updated the filter
    initialised,    // (re-)initialised position and orientation
    gated,          // Mahalanobis distance beyond the gate
    tilt_mismatch,  // an initialisation whose tilt the accelerometer contradicts
    out_of_order,   // older than the last measurement applied
    too_late,       // older than the IMU history
    pending,        // ahead of the IMU: applied when the IMU reaches it
    invalid,        // not finite, not a unit quaternion, or a bad covariance
};

struct PoseFilterCounters {
    uint64_t imu_samples = 0;
    uint64_t imu_out_of_order = 0;  // not after the previous sample: dropped
    uint64_t imu_gaps = 0;          // intervals beyond max_dt_ns
    uint64_t measurements = 0;      // add_pose calls
    uint64_t accepted = 0;
    uint64_t initialisations = 0;  // first, after lost, or replacing an unconfirmed one
    uint64_t gated = 0;
    uint64_t tilt_mismatch = 0;
    uint64_t out_of_order = 0;
    uint64_t too_late = 0;
    uint64_t pending_dropped = 0;  // a full pending queue dropped its oldest
    uint64_t invalid = 0;
    uint64_t lost = 0;             // transitions to the lost state
    double last_mahalanobis2 = 0;  // of the last measurement tested against the gate
};

class PoseFilter {
  public:
    explicit PoseFilter(const PoseFilterConfig& config = {});
    ~PoseFilter();
    PoseFilter(const PoseFilter&) = delete;
    PoseFilter& operator=(const PoseFilter&) = delete;

    void reset();

    // One IMU sample (body axes; see the top). The first aligns the orientation to gravity.
    void add_imu(int64_t device_time_ns, const glm::dvec3& gyro, const glm::dvec3& accel,
                 ImuSampleFlags flags = {});
    // One pose solve. Its result is also counted.
    MeasurementResult add_pose(const PoseMeasurement& m);

    bool initialized() const;  // an IMU sample has arrived
    FilterPose pose() const;   // at the newest IMU sample
    // At any device time: from the newest state at or before it (the oldest kept, before the
    // history), extrapolated at constant angular and linear velocity (the renderer's late warp).
    FilterPose predict(int64_t device_time_ns) const;
    glm::dvec3 gyro_bias() const;   // rad/s, body
    glm::dvec3 accel_bias() const;  // m/s^2, body
    glm::dvec3 gravity() const;     // m/s^2, world (pointing down)
    const PoseFilterCounters& counters() const;
    const PoseFilterConfig& config() const;

  private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace hmdnode
