// Error-state Kalman filter of light + IMU: J. Sola, "Quaternion kinematics for the error-state
// Kalman filter", arXiv:1711.02508, 2017. Nominal state: IMU position p and velocity v (world),
// orientation q (body-to-world), gyro bias bg and accelerometer bias ba (body), gravity g (world);
// error state [dp dv dtheta dbg dba dg] (18), dtheta the local (body-frame) angle error,
// q_true = q (x) Exp(dtheta). Propagation: §5.3 (nominal kinematics with the body-frame IMU
// readings, gravity a state as there) and §5.4 (the discrete error-state transition F_x and the
// noise impulses Q_i), noise as continuous densities times dt, the gyro's grown by a term
// proportional to the rate (scale error). Update: §6.1 (K = P H^T S^-1, Joseph form), injection
// §6.2, reset §6.3 (G = I - [dtheta/2]x on the angle block). Measurements: the body origin's
// position p - R l (l the IMU's position in the body frame: the lever arm, so the accelerometer
// needs no centripetal term) and orientation (residual Log(q^-1 z_q)), gated by the squared
// Mahalanobis distance (chi-square, 6 dof); the accelerometer as gravity while no position is
// tracked. Late measurements: a ring of the states after each IMU sample; the filter restarts from
// the one before the measurement and propagates forward again.
// Cost: one step is two 18x18 products (~12k multiply-adds); a pose update a 6x6 Cholesky and
// 18x6 products; add_pose() re-propagates every IMU sample after the measurement. Memory: the
// ring, history_samples x ~2.8 kB, allocated once.
#include "hmdnode/hal/tracking/pose_filter.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/Dense>

namespace hmdnode {
namespace {

using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;
using Quat = Eigen::Quaterniond;
constexpr int kN = 18;  // error-state dimension
using MatN = Eigen::Matrix<double, kN, kN>;
using VecN = Eigen::Matrix<double, kN, 1>;
constexpr int kP = 0, kV = 3, kTh = 6, kBg = 9, kBa = 12, kGr = 15;

Vec3 eig(const glm::dvec3& v) {
    return {v.x, v.y, v.z};
}
glm::dvec3 to_glm(const Vec3& v) {
    return {v.x(), v.y(), v.z()};
}
glm::dquat to_glm(const Quat& q) {
    return {q.w(), q.x(), q.y(), q.z()};
}
Mat3 skew(const Vec3& v) {
    Mat3 m;
    m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
    return m;
}
// Exp: rotation vector -> unit quaternion (Sola eq. 101).
Quat exp_q(const Vec3& th) {
    const double a = th.norm();
    if (a < 1e-12) return Quat(1, 0.5 * th.x(), 0.5 * th.y(), 0.5 * th.z()).normalized();
    const Vec3 u = th / a * std::sin(0.5 * a);
    return Quat(std::cos(0.5 * a), u.x(), u.y(), u.z());
}
// Log: unit quaternion -> rotation vector (shortest).
Vec3 log_q(Quat q) {
    if (q.w() < 0) q.coeffs() = -q.coeffs();
    const Vec3 v = q.vec();
    const double s = v.norm();
    if (s < 1e-12) return 2.0 * v;
    return v / s * (2.0 * std::atan2(s, q.w()));
}

struct Sample {
    int64_t t = 0;
    Vec3 gyro = Vec3::Zero(), accel = Vec3::Zero();
    ImuSampleFlags flags;
};

struct State {
    int64_t t = 0;
    Vec3 p = Vec3::Zero(), v = Vec3::Zero();  // the IMU's position and velocity, world
    Quat q = Quat::Identity();
    Vec3 bg = Vec3::Zero(), ba = Vec3::Zero();
    Vec3 g = Vec3::Zero();  // gravity in the world (the light's world need not be level)
    MatN P = MatN::Identity();
    Vec3 omega = Vec3::Zero();  // the last bias-corrected gyro, body
    Vec3 held = Vec3::Zero();   // the body origin while no position is tracked
    bool tracking = false;      // position propagated and updated
    bool ever_tracked = false;
    int confirmations = 0;  // accepted updates since the last initialisation
    int64_t last_update_t = 0;
};

struct Entry {
    Sample s;
    State x;
};

// The rotation taking unit vector a onto unit vector b.
Quat rotation_between(const Vec3& a, const Vec3& b) {
    return Quat::FromTwoVectors(a, b);
}

// The position block of an orientation-only state: held, uncorrelated.
void hold_position(State& x) {
    x.P.block<6, kN>(kP, 0).setZero();
    x.P.block<kN, 6>(0, kP).setZero();
    x.P.block<6, 6>(kP, kP).setIdentity();
    x.v.setZero();
}

}  // namespace

struct PoseFilter::Impl {
    PoseFilterConfig cfg;
    Vec3 lever = Vec3::Zero();
    Vec3 up = Vec3::UnitY();
    std::vector<Entry> ring;
    int head = -1;  // newest
    int count = 0;
    std::vector<PoseMeasurement> pending;
    int64_t last_measurement_t = std::numeric_limits<int64_t>::min();
    PoseFilterCounters counters;

    explicit Impl(const PoseFilterConfig& c) : cfg(c) {
        assert(cfg.history_samples >= 2 && cfg.pending_measurements >= 1);
        lever = eig(cfg.imu_position);
        up = eig(cfg.world_up).normalized();
        ring.resize(size_t(cfg.history_samples));
        pending.reserve(size_t(cfg.pending_measurements));
    }
    void reset() {
        head = -1;
        count = 0;
        pending.clear();
        last_measurement_t = std::numeric_limits<int64_t>::min();
        counters = {};
    }
    Entry& at(int i) {  // i-th oldest
        assert(i >= 0 && i < count);
        const int n = int(ring.size());
        return ring[size_t((head - count + 1 + i + 2 * n) % n)];
    }
    const Entry& at(int i) const { return const_cast<Impl*>(this)->at(i); }
    // The newest entry at or before t (-1: before the oldest).
    int find(int64_t t) const {
        int lo = 0, hi = count - 1, best = -1;
        while (lo <= hi) {
            const int mid = (lo + hi) / 2;
            if (at(mid).s.t <= t) {
                best = mid;
                lo = mid + 1;
            } else {
                hi = mid - 1;
            }
        }
        return best;
    }
    void push(const Entry& e) {
        head = (head + 1) % int(ring.size());
        ring[size_t(head)] = e;
        count = std::min(count + 1, int(ring.size()));
    }

    void propagate(State& x, const Sample& s, double dt) const;
    void gravity_update(State& x, const Sample& s) const;
    template <int M>
    bool update(State& x, const Eigen::Matrix<double, M, kN>& H,
                const Eigen::Matrix<double, M, 1>& y, const Eigen::Matrix<double, M, M>& R,
                double gate, double* d2) const;
    void inject(State& x, const VecN& dx) const;
    void initialise(State& x, const PoseMeasurement& m, const Eigen::Matrix<double, 6, 6>& R) const;
    void check_lost(State& x) const;
    void step(State& x, const Sample& s, double dt) const {
        propagate(x, s, dt);
        if (!x.tracking) gravity_update(x, s);
        check_lost(x);
    }
    MeasurementResult apply(const PoseMeasurement& m);
    void apply_pending();
    double body_position_sigma(const State& x) const;
    FilterPose output(const State& x, int64_t t) const;
};

// Sola §5.3-5.4: nominal integration with the readings over (t - dt, t], then P = F P F^T + Q.
void PoseFilter::Impl::propagate(State& x, const Sample& s, double dt) const {
    const Vec3 w = s.gyro - x.bg;
    const Vec3 a = s.accel - x.ba;
    const Mat3 R = x.q.toRotationMatrix();
    const Quat dq = exp_q(w * dt);
    if (x.tracking) {
        const Vec3 acc = R * a + x.g;
        x.p += x.v * dt + 0.5 * acc * dt * dt;
        x.v += acc * dt;
    }
    x.q = (x.q * dq).normalized();
    x.omega = w;
    MatN F = MatN::Identity();
    if (x.tracking) {
        F.block<3, 3>(kP, kV) = Mat3::Identity() * dt;
        F.block<3, 3>(kV, kTh) = -R * skew(a) * dt;
        F.block<3, 3>(kV, kBa) = -R * dt;
        F.block<3, 3>(kV, kGr) = Mat3::Identity() * dt;
    }
    F.block<3, 3>(kTh, kTh) = dq.toRotationMatrix().transpose();
    F.block<3, 3>(kTh, kBg) = -Mat3::Identity() * dt;
    x.P = (F * x.P * F.transpose()).eval();
    const auto sq = [](double v) { return v * v; };
    double th_var = (sq(cfg.gyro_noise) + sq(cfg.gyro_rate_noise * w.norm())) * dt;
    double v_var = sq(cfg.accel_noise) * dt;
    if (s.flags.gyro_saturated) th_var += sq(cfg.saturated_gyro_sigma * dt);
    if (s.flags.accel_saturated) v_var += sq(cfg.saturated_accel_sigma * dt);
    x.P.block<3, 3>(kTh, kTh).diagonal().array() += th_var;
    if (x.tracking) x.P.block<3, 3>(kV, kV).diagonal().array() += v_var;
    x.P.block<3, 3>(kBg, kBg).diagonal().array() += sq(cfg.gyro_bias_walk) * dt;
    if (cfg.estimate_accel_bias)
        x.P.block<3, 3>(kBa, kBa).diagonal().array() += sq(cfg.accel_bias_walk) * dt;
    x.t = s.t;
}

// Sola §6.1-6.3 for an M-dimensional residual y = z - h(x) with Jacobian H: gated by y^T S^-1 y
// (gate <= 0: no gate), Joseph-form covariance, injection and reset. False when gated.
template <int M>
bool PoseFilter::Impl::update(State& x, const Eigen::Matrix<double, M, kN>& H,
                              const Eigen::Matrix<double, M, 1>& y,
                              const Eigen::Matrix<double, M, M>& R, double gate, double* d2) const {
    const Eigen::Matrix<double, M, M> S = H * x.P * H.transpose() + R;
    const Eigen::LLT<Eigen::Matrix<double, M, M>> llt(S);
    if (llt.info() != Eigen::Success) return false;
    const double m2 = y.dot(llt.solve(y));
    if (d2) *d2 = m2;
    if (gate > 0 && !(m2 <= gate)) return false;
    const Eigen::Matrix<double, kN, M> K = llt.solve(H * x.P).transpose();
    const VecN dx = K * y;
    const MatN IKH = MatN::Identity() - K * H;
    x.P = (IKH * x.P * IKH.transpose() + K * R * K.transpose()).eval();
    inject(x, dx);
    return true;
}

void PoseFilter::Impl::inject(State& x, const VecN& dx) const {
    if (x.tracking) {
        x.p += dx.segment<3>(kP);
        x.v += dx.segment<3>(kV);
    }
    const Vec3 dth = dx.segment<3>(kTh);
    x.q = (x.q * exp_q(dth)).normalized();
    x.bg += dx.segment<3>(kBg);
    if (cfg.estimate_accel_bias) x.ba += dx.segment<3>(kBa);
    if (cfg.estimate_world_tilt) x.g += dx.segment<3>(kGr);
    MatN G = MatN::Identity();
    G.block<3, 3>(kTh, kTh) -= skew(0.5 * dth);
    x.P = (G * x.P * G.transpose()).eval();
    x.P = (0.5 * (x.P + x.P.transpose())).eval();
}

// The accelerometer as gravity (specific force R^T g up at rest), direction and magnitude,
// while the position is not tracked: it observes tilt and the tilt-axis gyro bias.
void PoseFilter::Impl::gravity_update(State& x, const Sample& s) const {
    if (s.flags.accel_saturated) return;
    const Vec3 a = s.accel - x.ba;
    if (std::abs(a.norm() - cfg.gravity) > cfg.accel_gate * cfg.gravity) return;
    const double r = x.omega.norm() / cfg.gravity_rate_scale;
    const double sigma = cfg.gravity_sigma * (1.0 + r * r);
    // The world of an orientation-only state is gravity's own: g is not updated here (H_g = 0).
    const Vec3 h = -(x.q.toRotationMatrix().transpose() * x.g);
    Eigen::Matrix<double, 3, kN> H = Eigen::Matrix<double, 3, kN>::Zero();
    H.block<3, 3>(0, kTh) = skew(h);
    if (cfg.estimate_accel_bias) H.block<3, 3>(0, kBa) = Mat3::Identity();
    const Vec3 y = a - h;
    const Mat3 R = Mat3::Identity() * sigma * sigma;
    update<3>(x, H, y, R, 0, nullptr);
}

// Position, velocity and orientation from a measurement (the biases and their covariance kept).
void PoseFilter::Impl::initialise(State& x, const PoseMeasurement& m,
                                  const Eigen::Matrix<double, 6, 6>& Rm) const {
    const Quat zq(m.orientation.w, m.orientation.x, m.orientation.y, m.orientation.z);
    x.q = zq.normalized();
    const Mat3 R = x.q.toRotationMatrix();
    x.p = eig(m.position) + R * lever;
    x.v.setZero();
    // [dp; dtheta] = A [dz_p; dz_theta]: the IMU lies at z_p + R Exp(dtheta) l.
    Eigen::Matrix<double, 6, 6> A = Eigen::Matrix<double, 6, 6>::Identity();
    A.block<3, 3>(0, 3) = -R * skew(lever);
    x.P.block<9, kN>(0, 0).setZero();
    x.P.block<kN, 9>(0, 0).setZero();
    const Eigen::Matrix<double, 6, 6> C = A * Rm * A.transpose();
    x.P.block<3, 3>(kP, kP) = C.block<3, 3>(0, 0);
    x.P.block<3, 3>(kP, kTh) = C.block<3, 3>(0, 3);
    x.P.block<3, 3>(kTh, kP) = C.block<3, 3>(3, 0);
    x.P.block<3, 3>(kTh, kTh) = C.block<3, 3>(3, 3);
    x.P.block<3, 3>(kV, kV) =
        Mat3::Identity() * cfg.initial_velocity_sigma * cfg.initial_velocity_sigma;
    x.tracking = true;
    x.ever_tracked = true;
    x.confirmations = 0;
    x.last_update_t = m.device_time_ns;
}

double PoseFilter::Impl::body_position_sigma(const State& x) const {
    if (!x.tracking) return std::numeric_limits<double>::infinity();
    Eigen::Matrix<double, 3, 6> J;
    J.block<3, 3>(0, 0) = Mat3::Identity();
    J.block<3, 3>(0, 3) = x.q.toRotationMatrix() * skew(lever);
    Eigen::Matrix<double, 6, 6> Ppt;
    Ppt << x.P.block<3, 3>(kP, kP), x.P.block<3, 3>(kP, kTh), x.P.block<3, 3>(kTh, kP),
        x.P.block<3, 3>(kTh, kTh);
    return std::sqrt(std::max(0.0, (J * Ppt * J.transpose()).trace() / 3.0));
}

// Too long without light, or too uncertain: hold the body origin where it is, orientation only.
void PoseFilter::Impl::check_lost(State& x) const {
    if (!x.tracking) return;
    // An initialisation not yet confirmed has an unknown velocity: only time loses it.
    if (x.t - x.last_update_t <= cfg.lost_after_ns &&
        (x.confirmations == 0 || body_position_sigma(x) <= cfg.lost_position_sigma_m))
        return;
    x.held = x.p - x.q.toRotationMatrix() * lever;
    x.tracking = false;
    hold_position(x);
}

FilterPose PoseFilter::Impl::output(const State& x, int64_t t) const {
    const double dt = double(t - x.t) * 1e-9;
    FilterPose o;
    o.device_time_ns = t;
    const Quat q = (x.q * exp_q(x.omega * dt)).normalized();
    const Mat3 R = q.toRotationMatrix();
    o.orientation = to_glm(q);
    o.angular_velocity = to_glm(R * x.omega);
    o.orientation_sigma_rad = std::sqrt(std::max(0.0, x.P.block<3, 3>(kTh, kTh).trace() / 3.0));
    if (!x.tracking) {
        o.position = to_glm(x.held);
        o.state = x.ever_tracked ? PositionState::lost : PositionState::none;
        o.position_sigma_m = std::numeric_limits<double>::infinity();
        return o;
    }
    o.position = to_glm(x.p + x.v * dt - R * lever);
    o.linear_velocity = to_glm(x.v - R * x.omega.cross(lever));
    o.position_sigma_m = body_position_sigma(x);
    const int64_t age = std::max<int64_t>(0, t - x.last_update_t);
    const double tf = age <= cfg.stale_after_ns
                          ? 1.0
                          : std::clamp(double(cfg.lost_after_ns - age) /
                                           double(cfg.lost_after_ns - cfg.stale_after_ns),
                                       0.0, 1.0);
    const double sf = std::clamp((cfg.lost_position_sigma_m - o.position_sigma_m) /
                                     (cfg.lost_position_sigma_m - cfg.good_position_sigma_m),
                                 0.0, 1.0);
    o.confidence = tf * sf;
    const bool lost = age > cfg.lost_after_ns ||
                      (x.confirmations > 0 && o.position_sigma_m > cfg.lost_position_sigma_m);
    if (lost) {
        o.state = PositionState::lost;
        o.confidence = 0;
    } else if (x.confirmations >= 1 && age <= cfg.stale_after_ns &&
               o.position_sigma_m <= cfg.good_position_sigma_m) {
        o.state = PositionState::tracked;
    } else {
        o.state = PositionState::coasting;
    }
    return o;
}

namespace {

// The measurement's covariance, or why it is unusable.
bool measurement_covariance(const PoseMeasurement& m, Eigen::Matrix<double, 6, 6>* out) {
    const glm::dquat& q = m.orientation;
    const double n = std::sqrt(q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z);
    if (!std::isfinite(m.position.x) || !std::isfinite(m.position.y) ||
        !std::isfinite(m.position.z) || !std::isfinite(n) || std::abs(n - 1.0) > 0.01)
        return false;
    if (m.covariance) {
        for (int i = 0; i < 36; ++i) {
            const double v = (*m.covariance)[size_t(i)];
            if (!std::isfinite(v)) return false;
            (*out)(i / 6, i % 6) = v;
        }
        if (!out->isApprox(out->transpose(), 1e-9)) return false;
        Eigen::LLT<Eigen::Matrix<double, 6, 6>> llt(*out);
        return llt.info() == Eigen::Success;
    }
    if (!(m.position_sigma_m > 0) || !(m.orientation_sigma_rad > 0) ||
        !std::isfinite(m.position_sigma_m) || !std::isfinite(m.orientation_sigma_rad))
        return false;
    out->setZero();
    out->diagonal() << Vec3::Constant(m.position_sigma_m * m.position_sigma_m),
        Vec3::Constant(m.orientation_sigma_rad * m.orientation_sigma_rad);
    return true;
}

}  // namespace

// A measurement at or before the newest IMU sample: from the state before it, step to its time
// with the next sample's readings, update (or initialise), then propagate forward again.
MeasurementResult PoseFilter::Impl::apply(const PoseMeasurement& m) {
    Eigen::Matrix<double, 6, 6> Rm;
    if (!measurement_covariance(m, &Rm)) return MeasurementResult::invalid;
    if (m.device_time_ns < last_measurement_t) return MeasurementResult::out_of_order;
    const int k = find(m.device_time_ns);
    if (k < 0) return MeasurementResult::too_late;
    State x = at(k).x;
    const bool has_next = k + 1 < count;
    const Sample& next = has_next ? at(k + 1).s : at(k).s;
    if (has_next) {
        propagate(x, next, double(m.device_time_ns - x.t) * 1e-9);
        x.t = m.device_time_ns;
    }
    const Quat zq =
        Quat(m.orientation.w, m.orientation.x, m.orientation.y, m.orientation.z).normalized();
    MeasurementResult result = MeasurementResult::accepted;
    bool init = !x.tracking;
    if (!init) {
        const Mat3 R = x.q.toRotationMatrix();
        Eigen::Matrix<double, 6, kN> H = Eigen::Matrix<double, 6, kN>::Zero();
        H.block<3, 3>(0, kP) = Mat3::Identity();
        H.block<3, 3>(0, kTh) = R * skew(lever);
        H.block<3, 3>(3, kTh) = Mat3::Identity();
        Eigen::Matrix<double, 6, 1> y;
        y.segment<3>(0) = eig(m.position) - (x.p - R * lever);
        y.segment<3>(3) = log_q(x.q.conjugate() * zq);
        if (update<6>(x, H, y, Rm, cfg.gate_chi2, &counters.last_mahalanobis2)) {
            ++x.confirmations;
            x.last_update_t = m.device_time_ns;
        } else if (x.confirmations == 0) {
            init = true;  // an unconfirmed initialisation the next solve contradicts: replace it
        } else {
            return MeasurementResult::gated;
        }
    }
    if (init) {
        // The accelerometer, when near still, must agree with the measured tilt.
        const Vec3 a = next.accel - x.ba;
        if (!next.flags.accel_saturated && (next.gyro - x.bg).norm() < 0.5 &&
            std::abs(a.norm() - cfg.gravity) <= cfg.accel_gate * cfg.gravity) {
            const Vec3 up_body = zq.toRotationMatrix().transpose() * up;
            if (std::acos(std::clamp(up_body.dot(a.normalized()), -1.0, 1.0)) >
                cfg.init_tilt_tolerance_rad)
                return MeasurementResult::tilt_mismatch;
        }
        initialise(x, m, Rm);
        result = MeasurementResult::initialised;
    }
    last_measurement_t = m.device_time_ns;
    // Forward again: the rest of the next sample's interval, then every later sample.
    if (has_next) {
        step(x, next, double(next.t - m.device_time_ns) * 1e-9);
        at(k + 1).x = x;
        for (int i = k + 2; i < count; ++i) {
            Entry& e = at(i);
            step(x, e.s, double(std::min<int64_t>(e.s.t - x.t, cfg.max_dt_ns)) * 1e-9);
            x.t = e.s.t;
            e.x = x;
        }
    } else {
        at(k).x = x;
    }
    return result;
}

void PoseFilter::Impl::apply_pending() {
    if (pending.empty() || count == 0) return;
    std::sort(pending.begin(), pending.end(),
              [](const PoseMeasurement& a, const PoseMeasurement& b) {
                  return a.device_time_ns < b.device_time_ns;
              });
    const int64_t newest = at(count - 1).s.t;
    size_t done = 0;
    while (done < pending.size() && pending[done].device_time_ns <= newest) {
        const MeasurementResult r = apply(pending[done]);
        switch (r) {
            case MeasurementResult::accepted:
                ++counters.accepted;
                break;
            case MeasurementResult::initialised:
                ++counters.initialisations;
                break;
            case MeasurementResult::gated:
                ++counters.gated;
                break;
            case MeasurementResult::tilt_mismatch:
                ++counters.tilt_mismatch;
                break;
            case MeasurementResult::out_of_order:
                ++counters.out_of_order;
                break;
            case MeasurementResult::too_late:
                ++counters.too_late;
                break;
            case MeasurementResult::invalid:
                ++counters.invalid;
                break;
            case MeasurementResult::pending:
                break;
        }
        ++done;
    }
    pending.erase(pending.begin(), pending.begin() + long(done));
}

// ---- PoseFilter
// ----------------------------------------------------------------------------------

const char* to_string(PositionState s) {
    switch (s) {
        case PositionState::none:
            return "none";
        case PositionState::tracked:
            return "tracked";
        case PositionState::coasting:
            return "coasting";
        case PositionState::lost:
            return "lost";
    }
    return "?";
}

PoseFilter::PoseFilter(const PoseFilterConfig& config) : impl_(std::make_unique<Impl>(config)) {}
PoseFilter::~PoseFilter() = default;

void PoseFilter::reset() {
    impl_->reset();
}

void PoseFilter::add_imu(int64_t t, const glm::dvec3& gyro, const glm::dvec3& accel,
                         ImuSampleFlags flags) {
    Impl& d = *impl_;
    const Sample s{t, eig(gyro), eig(accel), flags};
    if (!s.gyro.allFinite() || !s.accel.allFinite()) {
        ++d.counters.imu_out_of_order;
        return;
    }
    if (d.count == 0) {
        State x;
        x.t = t;
        const double sq_bg = d.cfg.initial_gyro_bias_sigma * d.cfg.initial_gyro_bias_sigma;
        const double sq_ba = d.cfg.estimate_accel_bias
                                 ? d.cfg.initial_accel_bias_sigma * d.cfg.initial_accel_bias_sigma
                                 : 0.0;
        x.P.setZero();
        x.P.diagonal().head<15>() << Vec3::Ones(), Vec3::Ones(), Vec3::Constant(0.01),
            Vec3::Constant(sq_bg), Vec3::Constant(sq_ba);
        x.g = -d.cfg.gravity * d.up;
        if (d.cfg.estimate_world_tilt) {  // level within the stated tilt; |g| known to 0.1 %
            const double st = d.cfg.world_tilt_sigma_rad * d.cfg.gravity, sv = 1e-3 * d.cfg.gravity;
            const Mat3 uu = d.up * d.up.transpose();
            x.P.block<3, 3>(kGr, kGr) = st * st * (Mat3::Identity() - uu) + sv * sv * uu;
        }
        if (s.accel.norm() > 0.5 * d.cfg.gravity && !flags.accel_saturated)
            x.q = rotation_between(s.accel.normalized(), d.up);
        x.omega = s.gyro;
        d.push({s, x});
        ++d.counters.imu_samples;
        return;
    }
    const State& prev = d.at(d.count - 1).x;
    if (t <= prev.t) {
        ++d.counters.imu_out_of_order;
        return;
    }
    ++d.counters.imu_samples;
    int64_t dt = t - prev.t;
    if (dt > d.cfg.max_dt_ns) {
        ++d.counters.imu_gaps;
        dt = d.cfg.max_dt_ns;
    }
    State x = prev;
    const bool was_tracking = x.tracking;
    d.step(x, s, double(dt) * 1e-9);
    x.t = t;
    if (was_tracking && !x.tracking) ++d.counters.lost;
    d.push({s, x});
    d.apply_pending();
}

MeasurementResult PoseFilter::add_pose(const PoseMeasurement& m) {
    Impl& d = *impl_;
    ++d.counters.measurements;
    if (d.count == 0 || m.device_time_ns > d.at(d.count - 1).s.t) {
        if (d.pending.size() >= size_t(d.cfg.pending_measurements)) {
            d.pending.erase(d.pending.begin());
            ++d.counters.pending_dropped;
        }
        d.pending.push_back(m);
        return MeasurementResult::pending;
    }
    const MeasurementResult r = d.apply(m);
    switch (r) {
        case MeasurementResult::accepted:
            ++d.counters.accepted;
            break;
        case MeasurementResult::initialised:
            ++d.counters.initialisations;
            break;
        case MeasurementResult::gated:
            ++d.counters.gated;
            break;
        case MeasurementResult::tilt_mismatch:
            ++d.counters.tilt_mismatch;
            break;
        case MeasurementResult::out_of_order:
            ++d.counters.out_of_order;
            break;
        case MeasurementResult::too_late:
            ++d.counters.too_late;
            break;
        case MeasurementResult::invalid:
            ++d.counters.invalid;
            break;
        case MeasurementResult::pending:
            break;
    }
    return r;
}

bool PoseFilter::initialized() const {
    return impl_->count > 0;
}

FilterPose PoseFilter::pose() const {
    if (impl_->count == 0) return {};
    const State& x = impl_->at(impl_->count - 1).x;
    return impl_->output(x, x.t);
}

FilterPose PoseFilter::predict(int64_t t) const {
    const Impl& d = *impl_;
    if (d.count == 0) return {};
    const int k = std::max(0, d.find(t));
    return d.output(d.at(k).x, t);
}

glm::dvec3 PoseFilter::gyro_bias() const {
    return impl_->count ? to_glm(impl_->at(impl_->count - 1).x.bg) : glm::dvec3(0.0);
}
glm::dvec3 PoseFilter::accel_bias() const {
    return impl_->count ? to_glm(impl_->at(impl_->count - 1).x.ba) : glm::dvec3(0.0);
}
glm::dvec3 PoseFilter::gravity() const {
    return impl_->count ? to_glm(impl_->at(impl_->count - 1).x.g)
                        : -impl_->cfg.gravity * to_glm(impl_->up);
}
const PoseFilterCounters& PoseFilter::counters() const {
    return impl_->counters;
}
const PoseFilterConfig& PoseFilter::config() const {
    return impl_->cfg;
}

}  // namespace hmdnode
