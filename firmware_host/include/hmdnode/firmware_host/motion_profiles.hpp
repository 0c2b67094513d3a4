// Synthetic head motions for latency measurement (`hmdnode latency`, docs/latency.md): yaw-only
// orientation traces sampled at a fixed rate, with closed-form angle and speed so that a test can
// check them exactly. Pure functions, any thread; O(duration * rate) time and memory.
//
// step ("head flicks"): a cycle of hold, turn up by `amplitude`, hold, turn back. Each turn has a
// raised-cosine velocity profile over T = turn_s:
//     yaw(t) = A (t/T - sin(2 pi t/T) / (2 pi)),   yaw'(t) = (A/T) (1 - cos(2 pi t/T)),
// so speed and acceleration are continuous, and the peak speed is 2A/T (at t = T/2; 1000 deg/s
// for the defaults 30 deg in 60 ms).
// sine-sweep: yaw(t) = A sin(phi(t)) with the frequency swept linearly from f0 to f1 over the
// duration D: phi(t) = 2 pi (f0 t + (f1 - f0) t^2 / (2 D)); peak speed A 2 pi f1 (251 deg/s for
// the defaults 20 deg, 0.2 -> 2 Hz), reached near the end.
#pragma once

#include <string>

#include "hmdnode/core/result.hpp"
#include "hmdnode/core/trace.hpp"

namespace hmdnode {

struct StepProfile {
    double amplitude_deg = 30.0;  // size of each turn
    double turn_s = 0.060;        // duration of each turn
    double hold_s = 0.5;          // still time before each turn (the cycle starts with a hold)
};

struct SineSweepProfile {
    double amplitude_deg = 20.0;
    double f0_hz = 0.2;  // frequency at t = 0
    double f1_hz = 2.0;  // frequency at t = duration
};

// Yaw (degrees, about +Y) and its rate (deg/s) of a profile at t seconds from its start.
struct YawState {
    double yaw_deg = 0.0;
    double rate_dps = 0.0;
};
YawState step_yaw(const StepProfile& p, double t_s);
YawState sine_sweep_yaw(const SineSweepProfile& p, double duration_s, double t_s);

// The trace of a profile: samples at k / rate_hz for k = 0 .. duration_s * rate_hz (both ends
// included), orientation = rotation by yaw about +Y, no position and no IMU (the simulated
// tracker's resampling keeps orientations only), a comment naming the profile and its formula.
// Requires duration_s > 0, rate_hz > 0 and valid parameters (asserted).
Trace make_step_trace(const StepProfile& p, double duration_s, double rate_hz = 1000.0);
Trace make_sine_sweep_trace(const SineSweepProfile& p, double duration_s, double rate_hz = 1000.0);

// By name: "step" or "sine-sweep" with the default parameters; an error for any other name.
Result<Trace> make_motion_profile(const std::string& name, double duration_s,
                                  double rate_hz = 1000.0);

}  // namespace hmdnode
