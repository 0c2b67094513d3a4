// Pose history with slerp inside and bounded constant-angular-velocity extrapolation beyond, as the
// public runtimes do (Monado's m_relation_history, OpenHMD). Query cost O(log n), push O(1).
#include "hmdnode/firmware_host/pose_history.hpp"

#include <algorithm>
#include <cassert>

#include "hmdnode/core/time.hpp"

namespace hmdnode {

PoseHistory::PoseHistory(const PoseHistoryConfig& config)
    : config_(config), ring_(config.capacity) {
    assert(config.capacity >= 2);
}

bool PoseHistory::push(const TrackerSample& sample) {
    if (!sample.has_orientation) return false;
    if (count_ > 0 && sample.time_ns <= newest().time_ns) return false;
    TrackerSample s = sample;
    if (count_ > 0) s.orientation = same_hemisphere(s.orientation, newest().orientation);
    ring_[head_] = s;
    head_ = (head_ + 1) % ring_.size();
    count_ = std::min(count_ + 1, ring_.size());
    return true;
}

const TrackerSample& PoseHistory::newest() const {
    assert(count_ > 0);
    return at(count_ - 1);
}
int64_t PoseHistory::newest_time_ns() const {
    return count_ ? newest().time_ns : 0;
}
int64_t PoseHistory::oldest_time_ns() const {
    return count_ ? at(0).time_ns : 0;
}

Pose PoseHistory::to_pose(const TrackerSample& s) const {
    Pose p;
    p.time_ns = s.time_ns;
    p.orientation = s.orientation;
    if (s.position) p.position = *s.position;
    return p;
}

glm::dvec3 PoseHistory::angular_velocity() const {
    if (count_ == 0) return glm::dvec3(0.0);
    const TrackerSample& n = newest();
    if (n.gyro) return n.orientation * *n.gyro;  // head frame -> world frame
    if (count_ < 2) return glm::dvec3(0.0);
    // The newest sample at least velocity_window_ns older than the newest (or the oldest we have).
    size_t i = count_ - 2;
    while (i > 0 && n.time_ns - at(i).time_ns < config_.velocity_window_ns) --i;
    const TrackerSample& o = at(i);
    return hmdnode::angular_velocity(o.orientation, n.orientation, ns_to_s(n.time_ns - o.time_ns));
}

Pose PoseHistory::pose_at(int64_t t_ns, PoseQuery* out_kind) const {
    PoseQuery kind;
    Pose out;
    if (count_ == 0) {
        kind = PoseQuery::Empty;
        out.time_ns = t_ns;
    } else if (t_ns <= at(0).time_ns) {
        kind = t_ns == at(0).time_ns ? PoseQuery::Interpolated : PoseQuery::ClampedOld;
        out = to_pose(at(0));
    } else if (t_ns <= newest().time_ns) {
        // Binary search for the first sample at or after t.
        size_t lo = 0, hi = count_ - 1;
        while (lo < hi) {
            size_t mid = (lo + hi) / 2;
            if (at(mid).time_ns < t_ns)
                lo = mid + 1;
            else
                hi = mid;
        }
        kind = PoseQuery::Interpolated;
        out = interpolate(to_pose(at(lo - 1)), to_pose(at(lo)), t_ns);
    } else {
        const TrackerSample& n = newest();
        const int64_t dt = std::min(t_ns - n.time_ns, config_.max_extrapolation_ns);
        kind = t_ns - n.time_ns > config_.max_extrapolation_ns ? PoseQuery::ClampedNew
                                                               : PoseQuery::Extrapolated;
        out = to_pose(n);
        const glm::dvec3 w = angular_velocity();
        out.orientation = integrate(n.orientation, w, ns_to_s(dt));
        out.angular_velocity = w;
    }
    out.time_ns = t_ns;
    if (!out.angular_velocity && count_ > 0) out.angular_velocity = angular_velocity();
    if (out_kind) *out_kind = kind;
    return out;
}

}  // namespace hmdnode
