// Pose history with slerp inside and bounded, damped prediction beyond (docs/prediction.md).
//
// Sources: the history and its slerp/extrapolate split follow Monado's m_relation_history and
// m_predict and OpenHMD; the prediction follows LaValle, Yershova, Katsev, Antonov, "Head tracking
// for the Oculus Rift", IEEE ICRA 2014: constant-velocity prediction is exact for steady turns but
// overshoots when the head stops, while constant acceleration is noisy; so the acceleration is
// fitted, clamped and extrapolated in part, and a deceleration is followed only until the motion
// stops.
//
// Model (Damped). With tau_i = t_i - t_newest <= 0 over the fit window, the world-frame rotation
// vectors r_i = log(q_i q_newest^-1) (and the displacements p_i - p_newest) are fitted through the
// origin by least squares: r(tau) = w tau + 1/2 a tau^2 (linear only with fewer than two older
// samples). The window shrinks with the speed of a first fit over the long window, as the One-Euro
// filter (G. Casiez, N. Roussel, D. Vogel, "1 Euro filter: a simple speed-based low-pass filter for
// noisy input in interactive systems", ACM CHI 2012) lowers its smoothing with speed: long against
// noise at rest, short against lag in fast turns. A steady turn gives a = 0 and is predicted
// exactly. The prediction over dt is
//   a' = clamp(a, a_max) * (a'.w < 0 ? decel_gain : accel_gain),
//   s  = min(dt, |w| / -(a'.w_hat))  when slowing down, else dt   (stop, never reverse),
//   r  = w s + 1/2 a' s^2, |r| <= max_rotation   (translation: |d| <= max_translation),
// applied as exp(r/2) q_newest. With a gyro, w is the gyro (to world) and a the least-squares slope
// of the gyro over the window.
//
// Cost: push O(1); pose_at O(log n + k), angular_velocity and motion O(k), k = samples in the fit
// window (at most 21 at 1 kHz; two passes); running sums only, no temporary memory.
#include "hmdnode/firmware_host/pose_history.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>

#include "hmdnode/core/time.hpp"

namespace hmdnode {
namespace pose_history_detail {

// Least-squares sums for v(tau) = w tau + b tau^2 through the origin (b = a/2).
struct OriginFit {
    double s2 = 0, s3 = 0, s4 = 0;
    glm::dvec3 s1v{0.0}, s2v{0.0};
    int n = 0;

    void add(double tau, const glm::dvec3& v) {
        const double t2 = tau * tau;
        s2 += t2;
        s3 += t2 * tau;
        s4 += t2 * t2;
        s1v += tau * v;
        s2v += t2 * v;
        ++n;
    }
    void solve(bool quadratic, glm::dvec3* out_w, glm::dvec3* out_a) const {
        *out_w = glm::dvec3(0.0);
        *out_a = glm::dvec3(0.0);
        if (n == 0 || s2 <= 0.0) return;
        const double det = s2 * s4 - s3 * s3;
        // note: two older samples at nearly the same tau make the quadratic ill-conditioned.
        if (quadratic && n >= 2 && det > 1e-9 * s2 * s4) {
            *out_w = (s4 * s1v - s3 * s2v) / det;
            *out_a = 2.0 * (s2 * s2v - s3 * s1v) / det;
        } else {
            *out_w = s1v / s2;
        }
    }
};

// Least-squares slope of v(tau) with an intercept (the gyro's rate of change).
struct SlopeFit {
    double s0 = 0, s1 = 0, s2 = 0;
    glm::dvec3 v0{0.0}, v1{0.0};

    void add(double tau, const glm::dvec3& v) {
        s0 += 1.0;
        s1 += tau;
        s2 += tau * tau;
        v0 += v;
        v1 += tau * v;
    }
    glm::dvec3 slope() const {
        const double det = s0 * s2 - s1 * s1;
        if (s0 < 2.0 || det <= 1e-12 * s2 * s0) return glm::dvec3(0.0);
        return (s0 * v1 - s1 * v0) / det;
    }
};

glm::dvec3 clamp_length(const glm::dvec3& v, double max_len) {
    if (max_len <= 0.0) return v;
    const double len = glm::length(v);
    return len > max_len ? v * (max_len / len) : v;
}

// Displacement and final velocity after dt_s from velocity w and fitted acceleration a (module
// comment: clamp, gains, stop on deceleration, bound).
struct Step {
    glm::dvec3 displacement{0.0};
    glm::dvec3 velocity{0.0};
};
Step extrapolate(const glm::dvec3& w, const glm::dvec3& a_fit, double dt_s, double a_max,
                 double accel_gain, double decel_gain, double max_displacement) {
    // Forward in time (a look-ahead), with gains that scale the fitted acceleration down.
    assert(dt_s >= 0.0 && accel_gain >= 0.0 && decel_gain >= 0.0);
    glm::dvec3 a = clamp_length(a_fit, a_max);
    const double along = glm::dot(a, w);
    a *= along < 0.0 ? decel_gain : accel_gain;
    double s = dt_s;
    bool stopped = false;
    const double speed = glm::length(w);
    const double a_along = speed > 0.0 ? glm::dot(a, w) / speed : 0.0;
    if (a_along < 0.0 && speed / -a_along < s) {
        s = speed / -a_along;
        stopped = true;
    }
    assert(s >= 0.0 && s <= dt_s);  // a stop only shortens the step
    Step out;
    out.displacement = clamp_length(w * s + 0.5 * s * s * a, max_displacement);
    out.velocity = stopped ? glm::dvec3(0.0) : w + s * a;
    return out;
}

}  // namespace pose_history_detail
using namespace pose_history_detail;

PoseHistory::PoseHistory(const PoseHistoryConfig& config)
    : config_(config), ring_(config.capacity) {
    assert(config.capacity >= 2);
    assert(config.prediction.min_fit_window_ns <= config.prediction.fit_window_ns);
    assert(config.max_extrapolation_ns >= 0 && config.velocity_window_ns >= 0);
}

bool PoseHistory::push(const TrackerSample& sample) {
    if (!sample.has_orientation) return false;
    if (count_ > 0 && sample.time_ns <= newest().time_ns) return false;
    TrackerSample s = sample;
    if (count_ > 0) s.orientation = same_hemisphere(s.orientation, newest().orientation);
    if (s.position)
        held_position_ = s.position;
    else if (held_position_)
        s.position = held_position_;  // not tracked just now: the last position held
    ring_[head_] = s;
    head_ = (head_ + 1) % ring_.size();
    count_ = std::min(count_ + 1, ring_.size());
    // The history stays in increasing time: the newest sample is the one just pushed, after
    // the one before it.
    assert(newest().time_ns == sample.time_ns &&
           (count_ < 2 || at(count_ - 2).time_ns < sample.time_ns));
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

glm::dvec3 PoseHistory::finite_difference_velocity() const {
    if (count_ < 2) return glm::dvec3(0.0);
    const TrackerSample& n = newest();
    // The newest sample at least velocity_window_ns older than the newest (or the oldest we have).
    size_t i = count_ - 2;
    while (i > 0 && n.time_ns - at(i).time_ns < config_.velocity_window_ns) --i;
    const TrackerSample& o = at(i);
    return hmdnode::angular_velocity(o.orientation, n.orientation, ns_to_s(n.time_ns - o.time_ns));
}

OriginFit PoseHistory::fit(int64_t window_ns, OriginFit* out_pos, SlopeFit* out_gyro) const {
    const TrackerSample& n = newest();
    const glm::dquat inv_n = glm::conjugate(n.orientation);
    OriginFit rot;
    if (out_gyro && n.gyro) out_gyro->add(0.0, n.orientation * *n.gyro);
    bool positions = out_pos && n.position.has_value();
    [[maybe_unused]] int64_t previous_age = 0;
    for (size_t k = count_ - 1; k-- > 0;) {
        const TrackerSample& s = at(k);
        const int64_t age = n.time_ns - s.time_ns;
        assert(age > previous_age);  // older samples, in order, from the newest back
        previous_age = age;
        if (age > window_ns && rot.n >= 2) break;
        const double tau = -ns_to_s(age);
        rot.add(tau, rotation_vector(s.orientation * inv_n));
        if (out_gyro && n.gyro && s.gyro) out_gyro->add(tau, s.orientation * *s.gyro);
        positions = positions && s.position.has_value();
        if (positions) out_pos->add(tau, *s.position - *n.position);
    }
    return rot;
}

MotionEstimate PoseHistory::motion() const {
    MotionEstimate m;
    if (count_ == 0) return m;
    const TrackerSample& n = newest();
    m.has_position = n.position.has_value();
    if (config_.prediction.model == PredictionModel::ConstantVelocity) {
        m.angular_velocity = n.gyro ? n.orientation * *n.gyro : finite_difference_velocity();
        return m;
    }
    const PredictionConfig& pc = config_.prediction;
    int64_t window = pc.fit_window_ns;
    if (pc.window_knee_deg_s > 0.0 && !n.gyro) {
        // One-Euro-like (Casiez et al. 2012): a long window at rest against noise, a short one
        // in fast motion against lag. The speed comes from a fit over the long window.
        glm::dvec3 w0, a0;
        fit(window, nullptr, nullptr).solve(pc.fit_acceleration, &w0, &a0);
        const double speed = rad_to_deg(glm::length(w0));
        window = pc.min_fit_window_ns + int64_t(double(window - pc.min_fit_window_ns) /
                                                (1.0 + speed / pc.window_knee_deg_s));
    }
    OriginFit pos;
    SlopeFit gyro;
    const OriginFit rot = fit(window, &pos, &gyro);
    rot.solve(config_.prediction.fit_acceleration, &m.angular_velocity, &m.angular_acceleration);
    if (n.gyro) {
        m.angular_velocity = n.orientation * *n.gyro;
        m.angular_acceleration = gyro.slope();
    }
    if (m.has_position)
        pos.solve(config_.prediction.fit_acceleration, &m.linear_velocity, &m.linear_acceleration);
    return m;
}

glm::dvec3 PoseHistory::angular_velocity() const {
    return motion().angular_velocity;
}

Pose PoseHistory::predict(int64_t dt_ns) const {
    const TrackerSample& n = newest();
    const PredictionConfig& pc = config_.prediction;
    const MotionEstimate m = motion();
    const double dt = ns_to_s(dt_ns);
    Pose out = to_pose(n);
    if (pc.model == PredictionModel::ConstantVelocity) {
        out.orientation = integrate(n.orientation, m.angular_velocity, dt);
        out.angular_velocity = m.angular_velocity;
        return out;
    }
    const Step r = extrapolate(m.angular_velocity, m.angular_acceleration, dt,
                               deg_to_rad(pc.max_angular_accel_deg_s2), pc.accel_gain,
                               pc.decel_gain, deg_to_rad(pc.max_rotation_deg));
    out.orientation = glm::normalize(quat_from_rotation_vector(r.displacement) * n.orientation);
    out.angular_velocity = r.velocity;
    if (m.has_position) {
        const Step p =
            extrapolate(m.linear_velocity, m.linear_acceleration, dt, pc.max_linear_accel_m_s2,
                        pc.accel_gain, pc.decel_gain, pc.max_translation_m);
        out.position += p.displacement;
        out.linear_velocity = p.velocity;
    }
    return out;
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
        // t lies in (at(lo - 1), at(lo)]: the oldest sample is before t (the branch above).
        assert(lo >= 1 && at(lo - 1).time_ns < t_ns && t_ns <= at(lo).time_ns);
        out = interpolate(to_pose(at(lo - 1)), to_pose(at(lo)), t_ns);
    } else {
        const int64_t ahead = t_ns - newest().time_ns;
        assert(ahead > 0);
        kind =
            ahead > config_.max_extrapolation_ns ? PoseQuery::ClampedNew : PoseQuery::Extrapolated;
        out = predict(std::min(ahead, config_.max_extrapolation_ns));
    }
    out.time_ns = t_ns;
    if (!out.angular_velocity && count_ > 0) {
        const MotionEstimate m = motion();
        out.angular_velocity = m.angular_velocity;
        if (m.has_position && config_.prediction.model == PredictionModel::Damped)
            out.linear_velocity = m.linear_velocity;
    }
    if (out_kind) *out_kind = kind;
    return out;
}

}  // namespace hmdnode
