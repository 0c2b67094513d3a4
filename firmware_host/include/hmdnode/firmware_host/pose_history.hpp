// Pose history: the last tracker samples, queryable by host time. Inside the history a query
// slerps between neighbours; beyond the newest sample it extrapolates with the angular velocity
// (gyro when the tracker has one, else a finite difference over a window), bounded in time.
//
// Threads: frame thread only. Fixed capacity; push() and queries neither allocate nor lock.
#pragma once

#include <cstdint>
#include <vector>

#include "hmdnode/core/pose.hpp"
#include "hmdnode/hal/tracker.hpp"

namespace hmdnode {

struct PoseHistoryConfig {
    size_t capacity = 4096;                     // samples kept (4 s at 1 kHz)
    int64_t max_extrapolation_ns = 50'000'000;  // beyond newest + this, the pose is held
    int64_t velocity_window_ns = 20'000'000;    // finite-difference span for angular velocity
};

enum class PoseQuery { Empty, Interpolated, Extrapolated, ClampedOld, ClampedNew };

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

    // World-frame angular velocity (rad/s) at the newest sample.
    glm::dvec3 angular_velocity() const;

    // The pose at t_ns (see the file comment). out_kind says how it was obtained.
    Pose pose_at(int64_t t_ns, PoseQuery* out_kind = nullptr) const;

  private:
    const TrackerSample& at(size_t i) const {
        return ring_[(head_ + ring_.size() - count_ + i) % ring_.size()];
    }
    Pose to_pose(const TrackerSample& s) const;

    PoseHistoryConfig config_;
    std::vector<TrackerSample> ring_;
    size_t head_ = 0;  // next write slot
    size_t count_ = 0;
};

}  // namespace hmdnode
