// Synthetic yaw-only head motions (step flicks, linear sine sweep); formulas in
// motion_profiles.hpp. O(duration * rate) time and memory, no state.
#include "hmdnode/firmware_host/motion_profiles.hpp"

#include <cassert>
#include <cmath>
#include <cstdio>

#include "hmdnode/core/pose.hpp"

namespace hmdnode {

namespace {

Trace make_yaw_trace(double duration_s, double rate_hz, const std::string& comment,
                     const auto& yaw_at) {
    assert(duration_s > 0.0 && rate_hz > 0.0);
    const int64_t n = int64_t(std::floor(duration_s * rate_hz + 1e-9));
    Trace t;
    t.comments.push_back(" hmdnode synthetic head motion: " + comment);
    t.samples.reserve(size_t(n + 1));
    const glm::dvec3 up(0.0, 1.0, 0.0);
    for (int64_t k = 0; k <= n; ++k) {
        const double ts = double(k) / rate_hz;
        const YawState y = yaw_at(ts);
        TraceSample s;
        s.time_ns = int64_t(std::llround(ts * 1e9));
        s.orientation = glm::angleAxis(deg_to_rad(y.yaw_deg), up);
        if (!t.samples.empty())
            s.orientation = same_hemisphere(s.orientation, t.samples.back().orientation);
        t.samples.push_back(s);
    }
    return t;
}

}  // namespace

YawState step_yaw(const StepProfile& p, double t_s) {
    assert(p.turn_s > 0.0 && p.hold_s >= 0.0);
    const double half = p.hold_s + p.turn_s;  // hold, then one turn
    const double cycle = 2.0 * half;
    const double tc = std::fmod(std::max(t_s, 0.0), cycle);
    const bool back = tc >= half;                         // second half: the turn back
    const double u = (back ? tc - half : tc) - p.hold_s;  // time into the turn
    const double base = back ? p.amplitude_deg : 0.0;
    const double sign = back ? -1.0 : 1.0;
    if (u <= 0.0) return {base, 0.0};
    const double x = u / p.turn_s, w = 2.0 * kPi * x;
    YawState s;
    s.yaw_deg = base + sign * p.amplitude_deg * (x - std::sin(w) / (2.0 * kPi));
    s.rate_dps = sign * p.amplitude_deg / p.turn_s * (1.0 - std::cos(w));
    return s;
}

YawState sine_sweep_yaw(const SineSweepProfile& p, double duration_s, double t_s) {
    assert(duration_s > 0.0);
    const double df = p.f1_hz - p.f0_hz;
    const double phase = 2.0 * kPi * (p.f0_hz * t_s + df * t_s * t_s / (2.0 * duration_s));
    const double freq = p.f0_hz + df * t_s / duration_s;
    return {p.amplitude_deg * std::sin(phase),
            p.amplitude_deg * 2.0 * kPi * freq * std::cos(phase)};
}

Trace make_step_trace(const StepProfile& p, double duration_s, double rate_hz) {
    char c[160];
    std::snprintf(c, sizeof c,
                  "step: yaw turns of %g deg in %g ms (raised-cosine speed, peak %g deg/s), "
                  "%g s holds",
                  p.amplitude_deg, p.turn_s * 1e3, 2.0 * p.amplitude_deg / p.turn_s, p.hold_s);
    return make_yaw_trace(duration_s, rate_hz, c, [&](double t) { return step_yaw(p, t); });
}

Trace make_sine_sweep_trace(const SineSweepProfile& p, double duration_s, double rate_hz) {
    char c[160];
    std::snprintf(c, sizeof c,
                  "sine-sweep: yaw = %g deg * sin(phase), frequency %g -> %g Hz linearly over %g s",
                  p.amplitude_deg, p.f0_hz, p.f1_hz, duration_s);
    return make_yaw_trace(duration_s, rate_hz, c,
                          [&](double t) { return sine_sweep_yaw(p, duration_s, t); });
}

Result<Trace> make_motion_profile(const std::string& name, double duration_s, double rate_hz) {
    if (!(duration_s > 0.0) || !(rate_hz > 0.0))
        return make_error("motion profile: duration and rate must be positive");
    if (name == "step") return make_step_trace(StepProfile{}, duration_s, rate_hz);
    if (name == "sine-sweep") return make_sine_sweep_trace(SineSweepProfile{}, duration_s, rate_hz);
    return make_error("unknown motion profile \"" + name + "\" (step, sine-sweep)");
}

}  // namespace hmdnode
