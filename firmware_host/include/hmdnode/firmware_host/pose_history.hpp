// Pose history: the last tracker samples, queryable by host time. Inside the history a query
// slerps between neighbours; beyond the newest sample it predicts (docs/prediction.md): velocity
// and acceleration from a least-squares fit over a window that shortens with speed (the gyro's
// rate when the tracker has one), the acceleration clamped and extrapolated only in part, a
// deceleration followed to a stop and no further, the look-ahead bounded in time and the predicted
// rotation and translation bounded in size. Position is predicted the same way when the samples
// carry one. A sample without a position after ones with it (a lighthouse device whose position
// is not tracked just then gives none, docs/tracking.md §12) holds the last position, so the view
// neither jumps to the origin nor moves on.
//
// Threads: frame thread only. Fixed capacity; push() and queries neither allocate nor lock.
#pragma once

#include <cassert>
#include <cstdint>
#include <optional>
#include <vector>

#include "hmdnode/core/pose.hpp"
#include "hmdnode/hal/tracker.hpp"

namespace hmdnode {
namespace pose_history_detail {
struct OriginFit;
struct SlopeFit;
}  // namespace pose_history_detail

enum class PredictionModel {
    ConstantVelocity,  // the former predictor: finite difference over velocity_window_ns (or the
                       // gyro), integrated unchanged over the look-ahead; kept for comparison
    Damped,            // fitted velocity and acceleration, damped and bounded (the default)
};

// Defaults measured on a real head trace (docs/prediction.md: corbillon2018_user1, 1 kHz and
// native 59 Hz, 8 and 17 ms horizons); a limit of 0 is off.
struct PredictionConfig {
    PredictionModel model = PredictionModel::Damped;
    int64_t fit_window_ns = 20'000'000;  // the fit window at rest (at least the two samples before
                                         // the newest are always fitted)
    int64_t min_fit_window_ns = 3'000'000;  // the window in fast motion: it shrinks from
    double window_knee_deg_s = 25.0;        // fit_window_ns as 1 / (1 + speed / knee); 0 = fixed
    bool fit_acceleration = true;  // fit a parabola (velocity and acceleration), else a line
    double accel_gain = 0.0;       // share of the fitted acceleration extrapolated when speeding up
    double decel_gain = 0.25;      // share extrapolated when slowing down; the motion then stops at
                                   // zero speed, never reverses
    double max_angular_accel_deg_s2 = 5'000.0;  // clamp on the fitted angular acceleration
    double max_rotation_deg = 10.0;             // bound on the rotation of one prediction
    double max_linear_accel_m_s2 = 30.0;        // clamp on the fitted linear acceleration
    double max_translation_m = 0.05;            // bound on the translation of one prediction
};

struct PoseHistoryConfig {
    size_t capacity = 4096;                     // samples kept (4 s at 1 kHz)
    int64_t max_extrapolation_ns = 50'000'000;  // beyond newest + this, the pose is held
    int64_t velocity_window_ns = 20'000'000;    // finite-difference span (ConstantVelocity model)
    PredictionConfig prediction;
};

enum class PoseQuery { Empty, Interpolated, Extrapolated, ClampedOld, ClampedNew };

// The motion at the newest sample, fitted over PredictionConfig::fit_window_ns (world frame).
struct MotionEstimate {
    glm::dvec3 angular_velocity{0.0};      // rad/s
    glm::dvec3 angular_acceleration{0.0};  // rad/s^2, unclamped
    bool has_position = false;             // the newest sample carries a position
    glm::dvec3 linear_velocity{0.0};       // m/s (zero when has_position is false)
    glm::dvec3 linear_acceleration{0.0};   // m/s^2, unclamped
};

class PoseHistory {
  public:
    explicit PoseHistory(const PoseHistoryConfig& config = {});

    // Samples must come in increasing time; an older or equal time is ignored (returns false).
    bool push(const TrackerSample& sample);

    bool empty() const { return count_ == 0; }
    size_t size() const { return count_; }
    int64_t newest_time_ns() const;
    int64_t oldest_time_ns() const;
    const TrackerSample& newest() const;
    const PoseHistoryConfig& config() const { return config_; }

    // World-frame angular velocity (rad/s) at the newest sample: the gyro when the newest sample
    // has one, else the fitted velocity (Damped) or the finite difference (ConstantVelocity).
    glm::dvec3 angular_velocity() const;

    // Velocity and acceleration at the newest sample. O(samples in the fit window).
    MotionEstimate motion() const;

    // The pose at t_ns (see the file comment). out_kind says how it was obtained. Beyond the
    // newest sample the pose carries the predicted angular velocity, and the predicted linear
    // velocity when the samples carry positions. O(log n + samples in the fit window).
    Pose pose_at(int64_t t_ns, PoseQuery* out_kind = nullptr) const;

  private:
    const TrackerSample& at(size_t i) const {
        assert(i < count_ && count_ <= ring_.size());
        return ring_[(head_ + ring_.size() - count_ + i) % ring_.size()];
    }
    Pose to_pose(const TrackerSample& s) const;
    glm::dvec3 finite_difference_velocity() const;
    Pose predict(int64_t dt_ns) const;
    pose_history_detail::OriginFit fit(int64_t window_ns, pose_history_detail::OriginFit* out_pos,
                                       pose_history_detail::SlopeFit* out_gyro) const;

    PoseHistoryConfig config_;
    std::vector<TrackerSample> ring_;
    size_t head_ = 0;  // next write slot
    size_t count_ = 0;
    std::optional<glm::dvec3> held_position_;  // the last position pushed (see the top)
};

}  // namespace hmdnode
