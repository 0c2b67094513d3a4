// Integral correction of the render budget: the allocator predicts with a fitted model, and what
// the model misses (fill, driver overhead, a drifting machine) shows as measured render time above
// or below the target. The budget handed to the allocator is scale x target, with
// scale += gain * (target - measured) / target after each frame, clamped to [min, max] (max 1 by
// default: it takes budget away from a model that underestimates and gives it back, but never
// more than the target, since the fit corrects an overestimate itself); it rises only while the
// allocator held detail back (anti-windup: a frame that got all the detail it
// wanted says nothing about how much more would fit). Cost: O(1) per frame.
#include <algorithm>

#include "hmdnode/lod/budget.hpp"

namespace hmdnode {

void BudgetFeedback::update(double measured_ms, double target_ms, bool limited) {
    if (!(target_ms > 0.0)) return;
    const double error = (target_ms - measured_ms) / target_ms;
    if (error > 0.0 && !limited) return;
    scale_ = std::clamp(scale_ + params_.gain * error, params_.min_scale, params_.max_scale);
}

}  // namespace hmdnode
