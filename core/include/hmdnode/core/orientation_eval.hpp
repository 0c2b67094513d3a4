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
// Cost: O((720 + rounds) * n) for n reference samples in the window, plus, when the offset is
// fitted, O((2000 * max_time_offset_s + 60) * (n log m + 3 n)) for an estimate of m samples; O(n)
// memory.
#pragma once

#include <cstdint>
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

// Percentiles of values (any order), as core/percentile.hpp defines them (nearest rank).
ErrorPercentiles error_percentiles(std::vector<double> values);

}  // namespace hmdnode
