// Synthetic gaze from a head trace: fixations and saccades with eye-head coordination.
//
// Model (docs/trace-format.md, "Synthetic gaze", has the sources; docs/references.md, "Eye and
// head movement", their full citations):
//  - Fixations last a log-normal time (median 250 ms; fixation durations in scene viewing are
//    typically 200-400 ms, Rayner 1998, Henderson 2003). During one the gaze holds still in the
//    world: the eye counter-rotates the head (vestibulo-ocular reflex), so the eye in head drifts
//    opposite to a head turn. When that drift reaches the eye's comfortable range the fixation
//    ends early with a saccade.
//  - A saccade goes, in the head frame, from the current eye direction to the next target:
//    where the head will point lead_s from now (the eye leads the head into a turn, Freedman 2008)
//    plus a gaussian offset, its eccentricity clamped (gaze shifts beyond about 20-25 degrees are
//    made with the head, Stahl 1999). Its duration follows the main sequence D = 21 + 2.2 A ms
//    (A in degrees; Carpenter 1988, Baloh et al. 1975) and its profile is minimum-jerk
//    (s = 10 u^3 - 15 u^4 + 6 u^5), so its peak speed is 1.875 A / D.
//  - Blinks (confidence 0) form a Poisson process, 12 a minute of 150 ms.
// Cost: O(samples + saccades) time, the output trace as the only large memory; pose_at per sample
// (a binary search) when resampling or looking ahead.
#include "hmdnode/core/synthetic_gaze.hpp"

#include <algorithm>
#include <cmath>
#include <random>
#include <string>

#include "hmdnode/core/pose.hpp"
#include "hmdnode/core/time.hpp"

namespace hmdnode {
namespace {

constexpr glm::dvec3 kForward{0.0, 0.0, -1.0};

// Head-frame direction from yaw (positive to the left, about +Y) and pitch (positive up), radians.
glm::dvec3 from_yaw_pitch(double yaw, double pitch) {
    return {-std::sin(yaw) * std::cos(pitch), std::sin(pitch), -std::cos(yaw) * std::cos(pitch)};
}

// The direction `d` turned towards the forward so that its eccentricity is at most max_rad.
glm::dvec3 clamp_eccentricity(const glm::dvec3& d, double max_rad) {
    const double ecc = std::acos(std::clamp(glm::dot(d, kForward), -1.0, 1.0));
    if (ecc <= max_rad) return d;
    glm::dvec3 axis = glm::cross(kForward, d);
    if (glm::length(axis) < 1e-12) axis = glm::dvec3(0, 1, 0);
    return glm::angleAxis(max_rad, glm::normalize(axis)) * kForward;
}

double min_jerk(double u) {
    u = std::clamp(u, 0.0, 1.0);
    return u * u * u * (10.0 + u * (-15.0 + 6.0 * u));
}

Status check(const SyntheticGazeParams& p) {
    auto positive = [](double v) { return std::isfinite(v) && v > 0.0; };
    auto non_negative = [](double v) { return std::isfinite(v) && v >= 0.0; };
    const std::pair<const char*, bool> checks[] = {
        {"rate_hz >= 0", non_negative(p.rate_hz)},
        {"fixation_median_ms > 0", positive(p.fixation_median_ms)},
        {"fixation_log_sigma >= 0", non_negative(p.fixation_log_sigma)},
        {"0 < fixation_min_ms <= fixation_max_ms",
         positive(p.fixation_min_ms) && p.fixation_min_ms <= p.fixation_max_ms},
        {"saccade_intercept_ms > 0", positive(p.saccade_intercept_ms)},
        {"saccade_slope_ms_per_deg >= 0", non_negative(p.saccade_slope_ms_per_deg)},
        {"lead_s >= 0", non_negative(p.lead_s)},
        {"target sigmas >= 0",
         non_negative(p.target_sigma_yaw_deg) && non_negative(p.target_sigma_pitch_deg)},
        {"0 < target_max_deg <= eye_range_deg <= 90", positive(p.target_max_deg) &&
                                                          p.target_max_deg <= p.eye_range_deg &&
                                                          p.eye_range_deg <= 90.0},
        {"blinks_per_min >= 0", non_negative(p.blinks_per_min)},
        {"blink_ms >= 0", non_negative(p.blink_ms)},
    };
    for (const auto& [what, ok] : checks)
        if (!ok) return make_error(std::string("synthetic gaze: parameter out of range: ") + what);
    return {};
}

}  // namespace

double gaze_eccentricity_deg(const glm::dvec3& head_dir) {
    const double n = glm::length(head_dir);
    if (!(n > 0.0)) return 0.0;
    return rad_to_deg(std::acos(std::clamp(glm::dot(head_dir / n, kForward), -1.0, 1.0)));
}

Result<SyntheticGaze> synthesize_gaze(const Trace& head, const SyntheticGazeParams& p) {
    if (head.samples.size() < 2) return make_error("synthetic gaze: the trace needs two samples");
    if (Status st = check(p); !st.ok()) return st.error();

    SyntheticGaze out;
    out.trace.comments = head.comments;
    if (p.rate_hz > 0.0) {
        const bool has_p = head.samples.front().position.has_value();
        const double step = 1e9 / p.rate_hz;
        for (double t = double(head.start_ns()); t <= double(head.end_ns()); t += step) {
            const Pose pose = head.pose_at(int64_t(t));
            TraceSample s;
            s.time_ns = int64_t(t);
            s.orientation = pose.orientation;
            if (has_p) s.position = pose.position;
            if (!out.trace.samples.empty())
                s.orientation =
                    same_hemisphere(s.orientation, out.trace.samples.back().orientation);
            out.trace.samples.push_back(s);
        }
    } else {
        out.trace.samples = head.samples;
    }

    std::mt19937_64 rng(p.seed);
    std::normal_distribution<double> unit_normal(0.0, 1.0);
    auto fixation_ns = [&] {
        const double ms =
            std::clamp(p.fixation_median_ms * std::exp(p.fixation_log_sigma * unit_normal(rng)),
                       p.fixation_min_ms, p.fixation_max_ms);
        return int64_t(ms * double(kNsPerMs));
    };
    auto q_at = [&](int64_t t) { return head.pose_at(t).orientation; };
    const double range = deg_to_rad(p.eye_range_deg);
    const double target_max = deg_to_rad(p.target_max_deg);
    const int64_t lead_ns = s_to_ns(p.lead_s);

    // Blink intervals, drawn up front from their own stream so the eye movements do not depend
    // on the blink rate.
    std::mt19937_64 blink_rng(p.seed ^ 0x9e3779b97f4a7c15ULL);
    std::vector<std::pair<int64_t, int64_t>> blinks;
    if (p.blinks_per_min > 0.0) {
        std::exponential_distribution<double> gap(p.blinks_per_min / 60.0);
        for (double t = double(head.start_ns()) + gap(blink_rng) * 1e9; t < double(head.end_ns());
             t += gap(blink_rng) * 1e9 + p.blink_ms * 1e6)
            blinks.emplace_back(int64_t(t), int64_t(t + p.blink_ms * 1e6));
    }
    out.blinks = blinks.size();

    // The state: a fixation (gaze fixed in the world) or a saccade (eye in head moving).
    bool in_saccade = false;
    glm::dvec3 world_gaze = q_at(head.start_ns()) * kForward;
    int64_t fix_end = head.start_ns() + fixation_ns();
    glm::dvec3 sac_from{0.0}, sac_axis{0, 1, 0};
    double sac_angle = 0.0;
    int64_t sac_start = 0, sac_dur = 0;

    auto start_saccade = [&](int64_t ts) {
        const glm::dquat q = q_at(ts);
        const glm::dvec3 eye = glm::normalize(glm::inverse(q) * world_gaze);
        // Where the head will point lead_ns from now, seen from the head now.
        const glm::dvec3 lead = glm::normalize(glm::inverse(q) * (q_at(ts + lead_ns) * kForward));
        const double yaw =
            std::atan2(-lead.x, -lead.z) + deg_to_rad(p.target_sigma_yaw_deg) * unit_normal(rng);
        const double pitch = std::asin(std::clamp(lead.y, -1.0, 1.0)) +
                             deg_to_rad(p.target_sigma_pitch_deg) * unit_normal(rng);
        const glm::dvec3 target =
            clamp_eccentricity(from_yaw_pitch(yaw, std::clamp(pitch, -1.5, 1.5)), target_max);
        const double angle = std::acos(std::clamp(glm::dot(eye, target), -1.0, 1.0));
        glm::dvec3 axis = glm::cross(eye, target);
        if (angle < 1e-9 || glm::length(axis) < 1e-12) {  // already there: a new fixation
            world_gaze = q * target;
            fix_end = ts + fixation_ns();
            return;
        }
        in_saccade = true;
        sac_from = eye;
        sac_axis = glm::normalize(axis);
        sac_angle = angle;
        sac_start = ts;
        const double a_deg = rad_to_deg(angle);
        sac_dur = int64_t((p.saccade_intercept_ms + p.saccade_slope_ms_per_deg * a_deg) *
                          double(kNsPerMs));
        out.saccades.push_back(SyntheticSaccade{ts, sac_dur, a_deg});
    };

    size_t blink = 0;
    for (TraceSample& s : out.trace.samples) {
        const int64_t t = s.time_ns;
        for (;;) {
            if (in_saccade) {
                if (t < sac_start + sac_dur) break;
                const int64_t land = sac_start + sac_dur;  // lands: fixation in the world
                world_gaze = q_at(land) * (glm::angleAxis(sac_angle, sac_axis) * sac_from);
                in_saccade = false;
                fix_end = land + fixation_ns();
                continue;
            }
            if (t >= fix_end) {
                start_saccade(fix_end);
                continue;
            }
            const glm::dvec3 eye = glm::inverse(s.orientation) * world_gaze;
            if (std::acos(std::clamp(glm::dot(glm::normalize(eye), kForward), -1.0, 1.0)) > range) {
                start_saccade(t);  // the eye reached its range: a resetting saccade now
                continue;
            }
            break;
        }
        glm::dvec3 eye;
        if (in_saccade) {
            const double u = double(t - sac_start) / double(sac_dur);
            eye = glm::angleAxis(sac_angle * min_jerk(u), sac_axis) * sac_from;
        } else {
            eye = glm::inverse(s.orientation) * world_gaze;
        }
        while (blink < blinks.size() && blinks[blink].second <= t) ++blink;
        const bool blinking = blink < blinks.size() && blinks[blink].first <= t;
        s.gaze = TraceGaze{glm::normalize(eye), blinking ? 0.0 : 1.0};
    }

    char buf[512];
    std::snprintf(buf, sizeof buf,
                  "gaze: SYNTHETIC, not measured (hmdnode trace add-gaze --seed %llu%s): "
                  "fixations log-normal median %g ms, saccades D = %g + %g A ms minimum-jerk, "
                  "eye leads head by %g s, target sigma %g/%g deg clamped to %g deg, eye range "
                  "%g deg, %g blinks/min of %g ms (docs/trace-format.md, Synthetic gaze)",
                  static_cast<unsigned long long>(p.seed),
                  p.rate_hz > 0.0 ? (" --rate " + std::to_string(int(p.rate_hz))).c_str() : "",
                  p.fixation_median_ms, p.saccade_intercept_ms, p.saccade_slope_ms_per_deg,
                  p.lead_s, p.target_sigma_yaw_deg, p.target_sigma_pitch_deg, p.target_max_deg,
                  p.eye_range_deg, p.blinks_per_min, p.blink_ms);
    std::erase_if(out.trace.comments,
                  [](const std::string& c) { return c.rfind("gaze: SYNTHETIC", 0) == 0; });
    out.trace.comments.push_back(buf);
    return out;
}

}  // namespace hmdnode
