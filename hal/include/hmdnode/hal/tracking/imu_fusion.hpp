// IMU fusion for IMU-only trackers: a Mahony complementary filter (gyro integration, gravity
// correction from the accelerometer, tilt-axis gyro-bias estimation by the integral term), plus
// bias learning gated on true stillness (a window whose gyro and accelerometer sit at the noise
// floor, whose gravity direction does not move, and whose mean rate is within the bias a sensor
// can have), and saturation handling (clipped samples counted, no bias learning from them, fast
// tilt re-alignment after them).
//
// What it cannot know: the gyro bias about the world vertical is unobservable while the device
// moves (gravity does not see it); only a still window observes it. The first still window may set
// a bias up to still_max_bias_rad_s (a sensor's uncalibrated bias); later ones move it by at most
// still_max_bias_change_rad_s (temperature drift), so a slow turn after a still period is not
// eaten. A constant turn with no tremor from the very start, slower than still_max_bias_rad_s,
// is indistinguishable from a still device with that bias.
// heading_bias_observed() says whether a still window has measured it.
//
// Frames (docs/DESIGN.md, docs/tracker-protocol.md): the head frame is x right, y up, z backward
// (-z forward); the world frame is y up. The accelerometer gives specific force, so a device at
// rest reads +g along world up. orientation() is head-to-world; yaw starts at 0.
//
// One thread; update() is O(1) and allocation-free.
#pragma once

#include <array>
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
    double gravity = 9.80665;  // m/s^2
    // No gravity correction when | |a| - g | > gate * g. 2 %: in head motion of several g, 0.1 g
    // across gravity moves the "up" it pulls toward by 5.7 deg (the former 10 % gate cost 1.9 deg
    // of tilt p95 on data/traces/compare-test-index.rec.gz); at rest |a| is within 0.4 % of g.
    double accel_gate = 0.02;
    // w0: the gravity gain is kp / (1 + (|w| / w0)^2): under rotation the accelerometer also reads
    // the centripetal and tangential acceleration of an IMU off the rotation axis.
    double kp_rate_scale_rad_s = 1.0;
    // Stillness: blocks of still_block_ns; the last still_blocks of them form the window.
    int64_t still_block_ns = 100'000'000;
    int still_blocks = 10;                    // 1 s window
    double still_gyro_std_rad_s = 0.006;      // per-axis std over the window, at most (noise floor)
    double still_accel_std_m_s2 = 0.06;       // per-axis std over the window, at most
    double still_block_spread_rad_s = 0.002;  // a block's mean gyro vs the window's, at most
    double still_tilt_change_rad = 0.003;     // gravity direction, first vs last block, at most
    // The first still window's |mean gyro| above this is motion, not bias (3 deg/s: a real Index
    // reads 1.35 deg/s at rest after its factory calibration, data/traces/compare-test-index).
    double still_max_bias_rad_s = 0.05;
    // Once a still window has set the bias, one whose mean departs from it by more than this is a
    // slow turn, not bias (0.2 deg/s: bias drifts with temperature, slowly).
    double still_max_bias_change_rad_s = 0.0035;
    double still_bias_tau_s = 1.0;  // bias follows the still window's mean gyro
    double max_bias_rad_s = 0.05;   // bias estimate clamp (per axis)
    // After a saturated gyro sample the orientation has lost an unknown rotation: the initial
    // (fast) gravity gain re-aligns tilt for this long, and no bias is learnt meanwhile.
    int64_t saturation_recovery_ns = 500'000'000;
    int64_t max_dt_ns = 50'000'000;  // a longer gap is integrated as this (sample loss)
};

// Per-sample flags from the codec: a reading at its sensor's full-scale limit on any axis.
struct ImuSampleFlags {
    bool gyro_saturated = false;
    bool accel_saturated = false;
};

class ImuFusion {
  public:
    explicit ImuFusion(const ImuFusionConfig& config = {});

    void reset();

    // One sample: time on any monotonic clock (ns), gyro in rad/s and accel in m/s^2, head frame.
    // The first sample aligns the orientation to gravity (yaw 0).
    void update(int64_t time_ns, const glm::dvec3& gyro, const glm::dvec3& accel,
                ImuSampleFlags flags = {});

    bool initialized() const { return initialized_; }
    glm::dquat orientation() const { return q_; }           // head-to-world
    glm::dvec3 angular_velocity() const { return omega_; }  // bias-corrected gyro, head frame
    glm::dvec3 gyro_bias() const { return bias_; }
    bool still() const { return still_; }
    uint64_t gated_samples() const { return gated_; }  // samples with no gravity correction
    uint64_t saturated_gyro_samples() const { return saturated_gyro_; }
    uint64_t saturated_accel_samples() const { return saturated_accel_; }
    int64_t still_ns() const { return still_ns_; }  // time spent in still windows
    // Whether a still window has measured the bias about the vertical axis (for at least
    // still_bias_tau_s). Until then heading drifts by whatever that bias is: unobservable.
    bool heading_bias_observed() const {
        return double(still_ns_) * 1e-9 >= config_.still_bias_tau_s;
    }

  private:
    struct Block {
        int n = 0;
        glm::dvec3 g_sum{0.0}, g_sq{0.0}, a_sum{0.0}, a_sq{0.0};
    };
    void close_block(bool init_phase);

    ImuFusionConfig config_;
    bool initialized_ = false;
    int64_t first_ns_ = 0;
    int64_t last_ns_ = 0;
    glm::dquat q_{1, 0, 0, 0};
    glm::dvec3 bias_{0.0};
    glm::dvec3 omega_{0.0};
    bool still_ = false;
    uint64_t gated_ = 0;
    uint64_t saturated_gyro_ = 0;
    uint64_t saturated_accel_ = 0;
    int64_t recover_until_ns_ = 0;
    int64_t still_ns_ = 0;
    // Stillness window: a ring of completed blocks and the block being filled.
    static constexpr int kMaxBlocks = 32;
    std::array<Block, kMaxBlocks> blocks_{};
    int blocks_filled_ = 0;  // consecutive usable blocks in the ring (capped at still_blocks)
    int block_head_ = 0;     // next ring slot
    Block cur_{};
    int64_t block_start_ns_ = 0;
};

}  // namespace hmdnode
