// Six degrees of freedom for a lighthouse-tracked device (docs/tracking.md §12): the light events
// of lighthouse::LightDecoder grouped into one pose solve per rotor turn (lighthouse 2: 20 ms,
// every base station's turn; lighthouse 1: 34 ms, both base stations' two axes) by the solver of
// lighthouse_solver.hpp against a stored base-station setup (a state file of
// base_station_placement.hpp, or a recording's base-station poses from before its light), each
// solve fed to the light + IMU PoseFilter as a PoseMeasurement of the head frame with the solve's
// covariance (s^2 (J^T J)^-1 of its residual) carried through the head frame's offset, and every
// IMU sample fed to the filter at its rate. Learnt from libsurvive's Kalman tracker
// (survive_kalman_tracker.c: a solve per sweep set as a pose observation, its variance from the
// poser's residual, the IMU as the process input); the code is this project's own.
//
// Without a setup (or before a base station of the setup is seen) no solve is made: the filter is
// orientation only (PositionState::none) and its position is never good. With placement in the
// tracker (LightTrackingConfig::place, self_placement.cpp) the base stations the setup lacks are
// placed from the light of a still stretch of the device (its IMU says when), each once its
// calibration is known; the first placement defines the world when the setup is empty (the
// device's model frame there, levelled by the accelerometer: the world of `tracking place`), a
// later one takes the device's pose there from the base stations already placed. setup() is then
// the setup to store for the next start. Light times are the
// device's 48 MHz clock like the IMU's; a light time that a 32-bit wrap put on another turn of the
// clock than the newest IMU sample is moved onto the IMU's (the two unwrap from their own first
// ticks).
//
// One thread. add_imu: one filter step (O(1)); add_light: O(1) per event, a solve per window
// (lighthouse_solver.hpp's cost) and its late update (one filter step per IMU sample since).
#pragma once

#include <cstdint>
#include <deque>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "hmdnode/hal/codec/light_codec.hpp"
#include "hmdnode/hal/codec/lighthouse_config.hpp"
#include "hmdnode/hal/tracking/base_station_placement.hpp"
#include "hmdnode/hal/tracking/lighthouse_solver.hpp"
#include "hmdnode/hal/tracking/pose_filter.hpp"

namespace hmdnode {

// Placement in the tracker: when the device lies still (over every `window_s` of IMU samples the
// gyro's standard deviation and mean and the accelerometer's deviation under their bounds, as
// device_light_log.hpp's StillOptions; consecutive still windows joined) for min_still_s, the
// light of that stretch (its first max_light_s) places the base stations it saw that the setup
// lacks. The stretch's light is kept until a newer still stretch replaces it, so a base station
// whose calibration arrives after the device moved is placed from it then.
struct InTrackerPlacement {
    bool enabled = false;
    double window_s = 0.25;
    double max_gyro_sd_rad_s = 0.6 * 0.0174533;
    double max_gyro_mean_rad_s = 3.0 * 0.0174533;
    double max_accel_sd_m_s2 = 0.06;
    double min_still_s = 1.0;
    double max_light_s = 2.0;
    lighthouse::PlacementOptions placement;
};

class SelfPlacement;

struct LightTrackingConfig {
    LighthouseSensors sensors;  // model points and normals, the head frame in the model's
    std::vector<lighthouse::BaseStationPlacement> setup;  // empty: orientation only
    // The filter; world_up must be the setup's world's up (a libsurvive setup: +z), imu_position
    // the IMU's lever arm in the head frame (ImuCalibration::imu_position).
    PoseFilterConfig filter;
    lighthouse::SolverOptions solver;
    int64_t lh2_window_ns = 20'000'000;  // one rotor turn (50..54 Hz)
    int64_t lh1_window_ns = 34'000'000;  // both base stations' two axes (4 slots of 8.33 ms)
    int64_t warm_start_max_age_ns = 100'000'000;  // an older previous solve is not a warm start
    // A base station's light is used only once its calibration is known: decoded from its OOTX
    // frame, or, until that arrives, the one the setup stores (BaseStationPlacement::calibration,
    // from an earlier session; its id must match the frame's when it comes). The ideal planes
    // are 7..60 mrad off (docs/tracking.md §9), poses 10..100 mm. False: the ideal planes
    // meanwhile.
    bool require_calibration = true;
    // The solve's covariance is a fit to its own residual; what the angle model lacks (the base
    // stations' placement, a moving device's motion within the window) adds, per axis, this
    // much, plus the solve's speed (and turn rate) times motion_sigma_s.
    double added_position_sigma_m = 0.0015;
    double added_orientation_sigma_rad = 0.0015;
    double motion_sigma_s = 0.001;
    InTrackerPlacement place;  // off: only the setup's base stations are used
};

struct LightTrackingCounters {
    uint64_t imu_samples = 0;
    uint64_t events = 0;           // light events given
    uint64_t events_unplaced = 0;  // from base stations the setup does not hold
    uint64_t wrap_moved = 0;       // events moved onto the IMU's turn of the 32-bit clock
    uint64_t solves = 0;           // windows solved
    uint64_t solved = 0;           // of them, a pose
    uint64_t not_enough_data = 0, no_fit = 0;
    uint64_t uncalibrated_windows = 0;  // windows whose base stations had no calibration yet
    // Base stations in the windows solved, by the calibration they were solved with: the
    // setup's stored one (before the live frame) or the one decoded in this run.
    uint64_t stored_calibration_uses = 0, decoded_calibration_uses = 0;
    uint64_t accepted = 0, initialised = 0, gated = 0, refused = 0;  // the filter's answers
    double last_residual_rad = 0;                                    // of the last pose solved
    // |filter position at the solve's time, before it - the solve's| (m), of the last solve met
    // while tracked: how far the light + IMU prediction was from the light.
    double last_innovation_m = 0;
    uint64_t innovations = 0;  // solves met while tracked
    // Placement in the tracker: base stations placed, still stretches long enough to place
    // from, and the device time of the first placement (0: none yet).
    uint64_t placed_in_tracker = 0, still_stretches = 0;
    int64_t first_placement_ns = 0;
    std::string last_placement_note;  // the last placement's base stations not placed, and why
};

class LightTracking {
  public:
    explicit LightTracking(LightTrackingConfig config);
    ~LightTracking();

    bool has_setup() const { return !setup_.empty(); }
    // The base stations used: the configured setup and those placed in the tracker since.
    const std::vector<lighthouse::BaseStationPlacement>& setup() const { return setup_; }

    // One IMU sample (head axes, device clock; DeviceSample's units).
    void add_imu(int64_t device_time_ns, const glm::dvec3& gyro, const glm::dvec3& accel,
                 ImuSampleFlags flags = {});
    // Light events in the decoder's order; `decoder` gives the base stations' calibrations and
    // ids (a setup entry whose id differs from the decoded one is a swapped base station: not
    // used). A window is solved when the first event past its end arrives.
    void add_light(std::span<const lighthouse::LightEvent> events,
                   const lighthouse::LightDecoder& decoder);

    FilterPose pose() const { return filter_.pose(); }  // at the newest IMU sample
    FilterPose predict(int64_t device_time_ns) const { return filter_.predict(device_time_ns); }
    // The filter's position state is tracked: position and confidence may be used.
    bool position_good() const { return filter_.pose().good(); }
    // "position lost": lost after having been tracked (PoseFilterCounters::lost counts them).
    bool position_lost() const { return filter_.pose().state == PositionState::lost; }
    const LightTrackingCounters& counters() const { return counters_; }
    const PoseFilter& filter() const { return filter_; }
    const std::optional<lighthouse::PoseSolve>& last_solve() const { return last_solve_; }
    // The calibration a setup's base station was last solved with (none before its first
    // window, or when it has none).
    lighthouse::CalibrationSource calibration_source(lighthouse::Generation g,
                                                     uint8_t base_station) const;

  private:
    void solve_window(int64_t end_ns, int64_t window_ns, const lighthouse::LightDecoder& decoder);
    void take_placements(const lighthouse::LightDecoder& decoder);
    PoseMeasurement head_measurement(const lighthouse::PoseSolve& s) const;

    LightTrackingConfig config_;
    std::vector<lighthouse::BaseStationPlacement> setup_;
    std::unique_ptr<SelfPlacement> placer_;  // with config_.place.enabled
    bool place_due_ = false;                 // a still window closed: placed at the next light
    lighthouse::SensorLayout layout_;
    PoseFilter filter_;
    LightTrackingCounters counters_;
    std::deque<lighthouse::LightEvent> window_;
    bool have_window_end_ = false;
    int64_t window_end_ns_ = 0;
    bool have_imu_ = false;
    int64_t last_imu_ns_ = 0;
    std::optional<lighthouse::RigidPose> warm_;
    int64_t warm_ns_ = 0;
    std::optional<lighthouse::PoseSolve> last_solve_;
    std::vector<lighthouse::CalibrationSource> sources_;  // per setup entry, of the last window
};

}  // namespace hmdnode
