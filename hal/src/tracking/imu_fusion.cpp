// Mahony complementary filter: R. Mahony, T. Hamel, J.-M. Pflimlin, "Nonlinear Complementary
// Filters on the Special Orthogonal Group", IEEE TAC 53(5), 2008, §V "explicit complementary
// filter with bias correction" (eqs. 32): omega = gyro - b + kP e, db/dt = -kI e, e = a x v with v
// the estimated world-up in the body frame. Since e is perpendicular to the measured gravity, the
// integral only ever learns the bias about the horizontal (tilt) axes, which gravity observes.
// Cost: O(1) time per sample; the stillness window is a fixed ring of block sums (no allocation).
// Departures: (1) gravity correction is gated when |a| is far from g or the accelerometer clips
// (the paper assumes a ~ -g); (2) higher gains for a short initial period and an initial attitude
// taken from the first accelerometer sample (fast alignment); (3) a stillness detector over a
// window of blocks (zero-velocity detection as in pedestrian INS, e.g. Skog et al., "Zero-velocity
// detection -- an algorithm evaluation", IEEE TBME 2010): the window is still when the gyro and
// accelerometer per-axis standard deviations are at the noise floor, no block's mean rate departs
// from the window's (a rate change), the gravity direction of its
// first and last blocks agree, |a| is near g and |mean gyro| is within the largest bias a sensor
// can have (the first still window) or within the drift a bias can have from the one learnt (later
// windows); then the bias relaxes toward the window's mean gyro, which observes the vertical-axis
// bias too. A slow turn after a still period is not eaten; a steady turn without tremor from the
// start cannot be told from bias (documented, docs/tracking.md §3); (4) a gyro sample at full scale
// is integrated as read (a lower bound of the true rate), counted, and followed by a recovery
// period with the fast gravity gain and no bias learning; (5) the integral uses the sample's dt,
// clamped to max_dt_ns across gaps.
#include "hmdnode/hal/tracking/imu_fusion.hpp"

#include <algorithm>
#include <cassert>
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

ImuFusion::ImuFusion(const ImuFusionConfig& config) : config_(config) {
    config_.still_blocks = std::clamp(config_.still_blocks, 2, kMaxBlocks);
    // Gains and gates are the caller's (code, not a file): non-negative, and the periods that
    // divide or bound a window positive.
    assert(config.kp >= 0.0 && config.ki >= 0.0 && config.init_kp >= 0.0 && config.init_ki >= 0.0);
    assert(config.gravity > 0.0 && config.kp_rate_scale_rad_s > 0.0 && config.accel_gate >= 0.0);
    assert(config.still_block_ns > 0 && config.max_dt_ns >= 0 && config.max_bias_rad_s >= 0.0);
}

void ImuFusion::reset() {
    *this = ImuFusion(config_);
}

// Ends the current block; a block with gated or saturated samples (n < 0) breaks the window.
void ImuFusion::close_block(bool init_phase) {
    const Block b = cur_;
    cur_ = Block{};
    if (b.n <= 0) {
        blocks_filled_ = 0;
        still_ = false;
        return;
    }
    assert(block_head_ >= 0 && block_head_ < kMaxBlocks);
    blocks_[size_t(block_head_)] = b;
    block_head_ = (block_head_ + 1) % kMaxBlocks;
    blocks_filled_ = std::min(blocks_filled_ + 1, config_.still_blocks);
    still_ = false;
    if (blocks_filled_ < config_.still_blocks) return;

    assert(blocks_filled_ == config_.still_blocks && config_.still_blocks <= kMaxBlocks);
    Block w;
    const int first = (block_head_ - config_.still_blocks + kMaxBlocks) % kMaxBlocks;
    const int last = (block_head_ - 1 + kMaxBlocks) % kMaxBlocks;
    for (int k = 0; k < config_.still_blocks; ++k) {
        const Block& x = blocks_[size_t((first + k) % kMaxBlocks)];
        w.n += x.n;
        w.g_sum += x.g_sum;
        w.g_sq += x.g_sq;
        w.a_sum += x.a_sum;
        w.a_sq += x.a_sq;
    }
    assert(w.n > 0);  // only blocks with samples (n > 0) enter the ring
    const double n = double(w.n);
    const glm::dvec3 g_mean = w.g_sum / n, a_mean = w.a_sum / n;
    const glm::dvec3 g_var = glm::max(w.g_sq / n - g_mean * g_mean, glm::dvec3(0.0));
    const glm::dvec3 a_var = glm::max(w.a_sq / n - a_mean * a_mean, glm::dvec3(0.0));
    double spread = 0.0;  // a change of rate between blocks (the start or end of a slow turn)
    for (int k = 0; k < config_.still_blocks; ++k) {
        const Block& x = blocks_[size_t((first + k) % kMaxBlocks)];
        spread = std::max(spread, glm::length(x.g_sum / double(x.n) - g_mean));
    }
    const double g_std_max = std::sqrt(std::max({g_var.x, g_var.y, g_var.z}));
    const double a_std_max = std::sqrt(std::max({a_var.x, a_var.y, a_var.z}));
    const glm::dvec3 a_first = blocks_[size_t(first)].a_sum, a_last = blocks_[size_t(last)].a_sum;
    const double la = glm::length(a_first), lb = glm::length(a_last);
    const double tilt_change =
        la > 0 && lb > 0 ? std::acos(std::clamp(glm::dot(a_first, a_last) / (la * lb), -1.0, 1.0))
                         : 1.0;
    still_ =
        g_std_max <= config_.still_gyro_std_rad_s && spread <= config_.still_block_spread_rad_s &&
        a_std_max <= config_.still_accel_std_m_s2 && tilt_change <= config_.still_tilt_change_rad &&
        std::abs(glm::length(a_mean) - config_.gravity) < 0.02 * config_.gravity &&
        glm::length(g_mean) <= config_.still_max_bias_rad_s &&
        (still_ns_ == 0 || std::abs(glm::dot(g_mean - bias_, a_mean / glm::length(a_mean))) <=
                               config_.still_max_bias_change_rad_s);
    if (!still_) return;
    const double block_s = double(config_.still_block_ns) * 1e-9;
    const double tau = init_phase ? config_.still_bias_tau_s * 0.1 : config_.still_bias_tau_s;
    // The first still window's mean is already the bias to within noise / sqrt(samples): take it.
    bias_ += (g_mean - bias_) * (still_ns_ == 0 ? 1.0 : std::min(1.0, block_s / tau));
    still_ns_ += config_.still_block_ns;
}

void ImuFusion::update(int64_t time_ns, const glm::dvec3& gyro, const glm::dvec3& accel,
                       ImuSampleFlags flags) {
    const double a_norm = glm::length(accel);
    if (flags.gyro_saturated) {
        ++saturated_gyro_;
        recover_until_ns_ = time_ns + config_.saturation_recovery_ns;
    }
    if (flags.accel_saturated) ++saturated_accel_;
    if (!initialized_) {
        initialized_ = true;
        first_ns_ = last_ns_ = block_start_ns_ = time_ns;
        if (a_norm > 1e-6) q_ = rotation_between(accel / a_norm, glm::dvec3(0, 1, 0));
        omega_ = gyro - bias_;
        return;
    }
    const int64_t raw_dt_ns = time_ns - last_ns_;
    const int64_t dt_ns = std::clamp<int64_t>(raw_dt_ns, 0, config_.max_dt_ns);
    last_ns_ = std::max(last_ns_, time_ns);
    const double dt = double(dt_ns) * 1e-9;
    const bool init_phase = time_ns - first_ns_ < config_.init_duration_ns;
    const bool recovering = time_ns < recover_until_ns_;
    // Under rotation the accelerometer reads centripetal and tangential acceleration too (the IMU
    // sits off the rotation axis) and a timing error turns into tilt: the gravity gain falls with
    // the rate, kp / (1 + (|w| / w0)^2).
    const double w_ratio = glm::length(gyro - bias_) / config_.kp_rate_scale_rad_s;
    const double kp =
        (init_phase || recovering ? config_.init_kp : config_.kp) / (1.0 + w_ratio * w_ratio);
    const double ki = recovering ? 0.0 : init_phase ? config_.init_ki : config_.ki;

    glm::dvec3 e(0.0);
    const double g = config_.gravity;
    const bool gravity_ok =
        !flags.accel_saturated && a_norm > 1e-6 && std::abs(a_norm - g) <= config_.accel_gate * g;
    if (gravity_ok) {
        const glm::dvec3 v = glm::conjugate(q_) * glm::dvec3(0, 1, 0);  // world up, head frame
        e = glm::cross(accel / a_norm, v);
    } else {
        ++gated_;
    }

    // Stillness window: a gap longer than a block, a gated or a saturated sample breaks it.
    if (raw_dt_ns > config_.still_block_ns || raw_dt_ns < 0) {
        cur_.n = -1;
        block_start_ns_ = time_ns;
    }
    if (!gravity_ok || flags.gyro_saturated || recovering) cur_.n = -1;
    if (cur_.n >= 0) {
        ++cur_.n;
        cur_.g_sum += gyro;
        cur_.g_sq += gyro * gyro;
        cur_.a_sum += accel;
        cur_.a_sq += accel * accel;
    }
    if (time_ns - block_start_ns_ >= config_.still_block_ns) {
        block_start_ns_ += config_.still_block_ns;
        if (time_ns - block_start_ns_ >= config_.still_block_ns) block_start_ns_ = time_ns;
        close_block(init_phase);
    }

    bias_ -= ki * e * dt;
    bias_ =
        glm::clamp(bias_, glm::dvec3(-config_.max_bias_rad_s), glm::dvec3(config_.max_bias_rad_s));

    omega_ = gyro - bias_;
    q_ = integrate(q_, omega_ + kp * e, dt);
    assert(dt >= 0.0 && kp >= 0.0 && ki >= 0.0);
}

}  // namespace hmdnode
