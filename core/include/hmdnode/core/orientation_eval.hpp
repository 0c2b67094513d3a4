// Orientation error of an estimated trace against a reference trace (`hmdnode tracking eval`).
//
// The two traces may sit in different world frames (the fusion starts at yaw 0 with y up; an
// optical tracker has its own world) and describe different body frames (the IMU's, the head's,
// a tracked object's): ref(t) ~ W * est(t) * B with two constant rotations. They are fitted over
// the evaluated window by least squares on the chordal distance (sum of 1 - <ref, W est B>^2),
// alternating W = mean of ref conj(est B) and B = mean of conj(W est) ref, each the Markley et al.
// (2007) quaternion mean (the principal eigenvector of sum q q^T, by power iteration), from the 24
// rotations of the cube as starting B (30 rounds each; the best then refined until B moves less
// than 1e-11 rad a round, at most 5000 rounds), so no starting guess is needed.
// The error of a reference sample is the rotation E = ref conj(W est B) (the estimate slerped at
// the reference's time), expressed in the estimate's world: its angle, its tilt (how far it moves
// the estimate's world up, +y) and its heading (its twist about +y).
// Time offset: the estimate is compared at t - offset with the reference at t (estimate time +
// offset = reference time). Given, or fitted jointly with W and B (fit_time_offset): the chordal
// cost is evaluated on a 1 ms grid over +-max_time_offset_s (W, B refitted a few rounds from the
// zero offset's fit at each), then minimised by golden-section search around the best grid step to
// 1 us; the samples are then re-evaluated at that offset with the full fit.
// Reference glitches (leave_out_reference_glitches): a step between consecutive reference samples
// whose rotation exceeds the estimate's own rotation over the same interval (its gyro, integrated)
// by more than max(glitch_min_step_deg, median + 20 robust sigmas of that excess over the window)
// is a jump the gyro does not see. A step followed, within glitch_max_excursion_s, by one after
// which the reference agrees with the estimate again (measured across the two) closes an
// excursion: the samples between are left out of the fit and the figures, and counted. A step
// that does not come back is counted and reported, not left out (either side may be the wrong one).
// Time offset observability: when the chordal cost over the whole search range does not reach
// twice its minimum, the motion moves the error less than the error's own floor (a still device):
// the offset cannot be told from the data, the search's result is not used (the given offset, 0)
// and no wider search can help. Its scale, reported: the error at the zero offset's fit (rms, rad)
// over the reference's rotation rate (rms over 50 ms spans, rad/s).
// Cost: O((720 + rounds) * n) for n reference samples in the window, plus, when the offset is
// fitted, O((2000 * max_time_offset_s + 60) * (n log m + 3 n)) for an estimate of m samples; O(n)
// memory.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

#include "hmdnode/core/result.hpp"
#include "hmdnode/core/trace.hpp"

namespace hmdnode {

struct OrientationEvalOptions {
    double start_s = 0.0;        // window start, seconds after the reference's first sample
    double duration_s = 0.0;     // window length; 0: to the end
    double time_offset_s = 0.0;  // estimate time + offset = reference time (when not fitted)
    bool fit_time_offset = false;
    double max_time_offset_s = 0.25;  // the fitted offset's search range, +-
    bool leave_out_reference_glitches = true;
    double glitch_min_step_deg = 1.0;     // a step's excess over the estimate's rotation, at least
    double glitch_max_excursion_s = 1.0;  // the longest excursion left out
    double max_offset_sigma_s = 0.050;    // above: the offset is not observable
};

// What the reference's glitch check found (orientation_eval.hpp, top).
struct ReferenceGlitches {
    size_t steps = 0;             // steps the estimate does not see
    size_t excursions = 0;        // of them, pairs closing an excursion
    size_t samples_left_out = 0;  // reference samples inside the excursions
    size_t unreturned_steps = 0;  // steps not followed by a return within the excursion limit
    double threshold_deg = 0.0;   // the step threshold used
    double worst_step_deg = 0.0;  // the largest step's excess (deg)
    double worst_reference_rate_deg_s = 0.0;  // the reference's rate over that step
    double worst_estimate_rate_deg_s = 0.0;   // the estimate's over the same interval
    int64_t worst_at_ns = 0;                  // the step's first sample
    std::vector<int64_t> unreturned_at_ns;    // their first samples' times
};

struct ErrorPercentiles {
    double p50 = 0.0, p95 = 0.0, max = 0.0;  // degrees, core/percentile.hpp
};

struct OrientationEval {
    glm::dquat world_alignment{1, 0, 0, 0};          // W: estimate world -> reference world
    glm::dquat body_alignment{1, 0, 0, 0};           // B: reference body -> estimate body
    int64_t window_start_ns = 0, window_end_ns = 0;  // on the traces' timeline
    int64_t time_offset_ns = 0;                      // the offset used (given or fitted)
    bool time_offset_at_range_limit = false;         // fitted at the edge of the search: look wider
    // With fit_time_offset: whether the motion lets the offset be observed (see the top), and the
    // figures that say it; when not, time_offset_ns is the given offset (0), not the fit.
    bool time_offset_observable = true;
    double time_offset_sigma_ms = 0.0;      // rms error / rms rotation rate at the zero offset
    double reference_rate_rms_deg_s = 0.0;  // over 50 ms spans
    double unobservable_fit_ms = 0.0;       // what the search found when not observable
    ReferenceGlitches glitches;
    // Per reference sample in the window and inside the estimate's time span:
    std::vector<int64_t> time_ns;
    std::vector<double> error_deg, tilt_deg, heading_deg;
    ErrorPercentiles error, tilt, heading;
    size_t samples = 0;
};

// Errors: a window with fewer than 10 reference samples inside the estimate's span (the message
// gives both spans), a negative start or duration, a non-finite offset or a search range <= 0.
Result<OrientationEval> evaluate_orientation(const Trace& reference, const Trace& estimate,
                                             const OrientationEvalOptions& options = {});

// The trace's time base: the text of its comment `time_base ...` (docs/trace-format.md), or
// nullopt when it has none (a trace from elsewhere, or written before the comment existed).
std::optional<std::string> trace_time_base(const Trace& trace);

// Percentiles of values (any order), as core/percentile.hpp defines them (nearest rank).
ErrorPercentiles error_percentiles(std::vector<double> values);

}  // namespace hmdnode
