// Position error of an estimated trace against a reference trace (`hmdnode tracking eval`), on
// the reference samples of an orientation evaluation (orientation_eval.hpp: its window, its
// glitches left out). The two traces' positions may be of different points of the body (a lever
// arm l, in the estimate's body frame) and their worlds differ by a rotation W and a translation
// w: ref_p(t) ~ W (est_p(t - offset) + R_est(t - offset) l) + w. Fitted by least squares,
// alternating W, w given l (Horn 1987: the closed-form absolute orientation, the principal
// eigenvector of his 4x4 matrix by power iteration) and l, w given W (a 6x6 normal system), 30
// rounds; W fixed to the orientation fit's when not fitted. Time offset: the orientation fit's,
// or fitted on a 1 ms grid over +-max_time_offset_s (each step 3 rounds from the zero offset's
// fit; then the full fit at the best). The error of a sample is the distance left, in mm.
// Cost: O(rounds * n) for n reference samples, times the grid's 2000 * max_time_offset_s + 1
// steps when the offset is fitted; O(n) memory.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

#include "hmdnode/core/orientation_eval.hpp"
#include "hmdnode/core/result.hpp"
#include "hmdnode/core/trace.hpp"

namespace hmdnode {

struct PositionEvalOptions {
    bool fit_rotation = true;      // else W = the orientation fit's world alignment
    bool fit_lever_arm = true;     // else l = 0
    bool fit_time_offset = false;  // else the orientation evaluation's offset
    double max_time_offset_s = 0.05;
};

struct PositionEval {
    glm::dquat world_rotation{1, 0, 0, 0};  // W: estimate world -> reference world
    glm::dvec3 world_offset{0.0};           // w: in the reference's world, m
    glm::dvec3 lever_arm{0.0};  // l: the reference's point in the estimate's body frame, m
    int64_t time_offset_ns = 0;
    bool time_offset_fitted = false;
    std::vector<double> error_mm;  // per sample of the orientation evaluation
    double p50_mm = 0, p90_mm = 0, max_mm = 0;
    size_t samples = 0;
};

// Errors: a trace without positions (naming which), fewer than 10 samples, or samples that do
// not fix the lever arm (the estimate does not turn over the window).
Result<PositionEval> evaluate_position(const Trace& reference, const Trace& estimate,
                                       const OrientationEval& orientation,
                                       const PositionEvalOptions& options = {});

}  // namespace hmdnode
