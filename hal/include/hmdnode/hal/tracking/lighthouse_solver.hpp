// The optical pose of a lighthouse-tracked device from the angles its sensors measured
// (docs/tracking.md §10): a perspective-n-point seed per base station (Lu, Hager & Mjolsness's
// orthogonal iteration on the ideal directions of the sensors with both planes), refined by
// Levenberg-Marquardt on the calibrated angle residuals (lh2_predict_angle / lh1_predict_angle)
// over every placed base station seen, with outlier rejection (|residual| > k * robust sigma,
// then re-solved) and the sensors whose normal faces away from a base station left out. Learnt
// from libsurvive's posers (poser_mpfit.c: the newest angle per sensor, base station and plane
// in a time window, 8 angles required; poser_barycentric_svd.c / poser_epnp.c as the seed;
// survive_reproject*.c the models); the code is this project's own.
//
// Pure functions over the caller's data: no I/O, no threads, no state between calls.
// Cost per solve: O(n) per Levenberg-Marquardt iteration (n angles, each model evaluated 4
// times, a 12x12 solve), <= 30 iterations per round, <= 4 rounds, twice when the velocity model
// runs; a cold start adds the seed, 24 starts of <= 50 orthogonal iterations of O(m) on a base
// station's m sensors, <= 4 tries, for <= 2 base stations. Temporary memory O(n).
//
// For the light + IMU filter: a solve gives the pose of the device's model frame in the world
// at `device_time_ns` (device clock), its covariance, residual and counts (PoseSolve); a pose is
// only there when `outcome == solved`.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

#include "hmdnode/hal/codec/light_codec.hpp"

namespace hmdnode::lighthouse {

// A rigid transform: a point p of the source frame is at orientation * p + position in the target.
struct RigidPose {
    glm::dvec3 position{0.0};
    glm::dquat orientation{1, 0, 0, 0};
};

// The device's photodiodes in its model (tracking-reference) frame, metres; unit normals.
struct SensorLayout {
    std::vector<glm::dvec3> points;
    std::vector<glm::dvec3> normals;
};

// A base station whose pose in the world is known (placed or stored).
struct PlacedBaseStation {
    Generation generation = Generation::lh2;
    uint8_t base_station = 0;      // as LightEvent's: lighthouse-2 channel, lighthouse-1 number
    RigidPose world_from_station;  // the station's frame: x right, y up, looking along -z
    std::optional<BaseStationCalibration> calibration;  // none yet: the ideal planes
};

struct SolverOptions {
    size_t min_angles = 8;   // angles needed after every rejection (libsurvive's required-meas)
    size_t min_sensors = 4;  // distinct sensors among them
    // A cold start (no warm pose) needs a base station with this many sensors seen on both
    // planes (axes) for its seed.
    size_t min_seed_sensors = 4;
    // A sensor is used for a base station only while the angle between its normal and the
    // direction to the station is below this (pi / 2: facing away is not seen).
    double max_incidence_rad = 1.5707963267948966;
    double outlier_k = 4.0;                // reject |residual| > k * max(robust sigma, sigma_floor)
    double sigma_floor_rad = 2e-4;         // the angles' noise floor (calibrated models: ~0.1 mrad)
    int outlier_rounds = 3;                // re-solves after rejections
    int max_iterations = 30;               // Levenberg-Marquardt steps per round
    double max_residual_rad = 0.01;        // RMS above this after all rounds: no pose (no_fit)
    double max_warm_residual_rad = 0.003;  // a warm start worse than this is re-seeded cold
    // Where the static fit's RMS exceeds velocity_above_rms_rad (the angles of a moving device
    // are hit at different times of the window), solve a constant linear and angular velocity
    // over the window's times with the pose (as libsurvive's mpfit-model-velocity), under a weak
    // prior (the sigmas below). Not for a still device: there the velocities absorb the model's
    // small per-base-station errors (measured: docs/tracking.md §10).
    bool model_velocity = true;
    double velocity_above_rms_rad = 4e-4;
    double velocity_prior_m_s = 5.0;
    double angular_velocity_prior_rad_s = 20.0;
};

enum class SolveOutcome : uint8_t {
    solved,
    not_enough_data,  // too few angles / sensors / placed base stations, or unobservable
    no_fit,           // the least squares did not reach max_residual_rad
};
const char* solve_outcome_name(SolveOutcome o);  // "solved", "not enough data", "no fit"

// One solve. The pose is only set when outcome == solved; never a pose otherwise.
struct PoseSolve {
    SolveOutcome outcome = SolveOutcome::not_enough_data;
    std::string message;                         // why not, with the counts; empty when solved
    std::optional<RigidPose> world_from_device;  // the device's model frame in the world
    // The time the pose is of: with model_velocity the mean device time of the window's angles
    // from placed base stations (the velocity model's reference); without, of the angles used.
    int64_t device_time_ns = 0;
    bool moving = false;               // solved with the velocity model
    glm::dvec3 velocity{0.0};          // m/s, world (when moving; else zero)
    glm::dvec3 angular_velocity{0.0};  // rad/s, world axes
    double residual_rms_rad = 0;       // of the angles used
    // Covariance of the pose error, row-major 6x6 over [position (m, world), rotation vector
    // (rad, world axes, applied on the left)]: s^2 (J^T J)^-1, s^2 = max(SSR / (used - 6),
    // sigma_floor^2).
    std::array<double, 36> covariance{};
    size_t angles = 0;             // distinct (base station, sensor, plane) angles in the window
    size_t used = 0;               // in the final fit
    size_t rejected_outliers = 0;  // by the k-sigma rule
    size_t facing_away = 0;        // angles of sensors facing away from their base station
    size_t unplaced = 0;           // angles from base stations not placed (not used)
    size_t base_stations = 0;      // placed base stations with angles in the final fit
    int iterations = 0;            // Levenberg-Marquardt steps, all rounds
    bool cold_seed = false;        // seeded by PnP (else from the warm start)
    bool ok() const { return outcome == SolveOutcome::solved; }
};

// One measured angle: the newest of a window per (system, base station, sensor, plane).
struct AngleSample {
    Generation generation = Generation::lh2;
    uint8_t base_station = 0;
    uint8_t sensor = 0;
    uint8_t plane = 0;  // lighthouse 2: plane; lighthouse 1: axis
    double angle = 0;
    int64_t device_time_ns = 0;
};
// The newest event per (system, base station, sensor, plane) of `window`, in key order.
std::vector<AngleSample> newest_angles(std::span<const LightEvent> window);
// The median angle per key (and the median time), of keys with >= min_count events: a still
// period's angles with their noise averaged down.
std::vector<AngleSample> median_angles(std::span<const LightEvent> window, size_t min_count = 3);

// The device's pose from a window of light events (e.g. the last one or two rotor turns; a
// sensor beyond the layout is ignored and counted as not used). `warm_start`: the previous pose,
// which skips the seed when it fits. Thread: any (pure).
PoseSolve solve_device_pose(const SensorLayout& layout, std::span<const PlacedBaseStation> stations,
                            std::span<const LightEvent> window,
                            const std::optional<RigidPose>& warm_start = std::nullopt,
                            const SolverOptions& options = {});
// The same over angles already gathered.
PoseSolve solve_device_pose(const SensorLayout& layout, std::span<const PlacedBaseStation> stations,
                            std::span<const AngleSample> angles,
                            const std::optional<RigidPose>& warm_start = std::nullopt,
                            const SolverOptions& options = {});

}  // namespace hmdnode::lighthouse
