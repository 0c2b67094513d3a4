// Synthetic gaze for a head trace: a documented model of where the eyes look, for testing the
// gaze-driven LOD where no eye-tracker recording exists. It is NOT a measurement; the trace it
// writes says so in its comments (docs/trace-format.md, "Synthetic gaze").
//
// Pure function of the head trace and the parameters (the seed included): any thread may call it.
#pragma once

#include <cstdint>
#include <vector>

#include "hmdnode/core/result.hpp"
#include "hmdnode/core/trace.hpp"

namespace hmdnode {

struct SyntheticGazeParams {
    uint64_t seed = 1;
    double rate_hz = 0.0;  // 0: gaze at the head trace's own sample times; else resampled to this
    // Fixation durations: log-normal, median and sigma of ln(duration), clamped.
    double fixation_median_ms = 250.0;
    double fixation_log_sigma = 0.5;
    double fixation_min_ms = 80.0;
    double fixation_max_ms = 1500.0;
    // Saccade duration from its amplitude A (the main sequence): D = intercept + slope * A.
    double saccade_intercept_ms = 21.0;
    double saccade_slope_ms_per_deg = 2.2;
    // Next fixation, eye in head: where the head will point `lead_s` from now (the eye leads the
    // head), plus a gaussian offset (yaw, pitch), its eccentricity clamped to target_max_deg.
    double lead_s = 0.2;
    double target_sigma_yaw_deg = 8.0;
    double target_sigma_pitch_deg = 5.0;
    double target_max_deg = 25.0;
    // During a fixation the gaze holds still in the world (the eyes counter-rotate the head, the
    // vestibulo-ocular reflex); when that takes the eye this far from the head forward, the
    // fixation ends with a saccade.
    double eye_range_deg = 35.0;
    // Blinks (gaze not valid, confidence 0): a Poisson process of this rate, each this long.
    double blinks_per_min = 12.0;
    double blink_ms = 150.0;
};

// One saccade of the model, as made (head frame amplitude).
struct SyntheticSaccade {
    int64_t start_ns = 0;
    int64_t duration_ns = 0;
    double amplitude_deg = 0.0;  // angle between the eye-in-head directions at its start and end
};

struct SyntheticGaze {
    Trace trace;  // the head trace (resampled when rate_hz > 0) with the gaze group
    std::vector<SyntheticSaccade> saccades;
    size_t blinks = 0;
};

// The head trace with synthetic gaze added (an existing gaze group is replaced). Errors: fewer
// than two samples, a parameter out of range (named).
Result<SyntheticGaze> synthesize_gaze(const Trace& head, const SyntheticGazeParams& params);

// Eccentricity of a head-frame direction: its angle from the head forward (0,0,-1), degrees.
double gaze_eccentricity_deg(const glm::dvec3& head_dir);

}  // namespace hmdnode
