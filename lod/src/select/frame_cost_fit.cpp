// A frame's render cost learned online: render ms = base + per_triangle * triangles, fitted by
// exponentially weighted least squares (recursive: the weighted means and co-moments updated per
// frame, D. H. D. West, "Updating mean and variance estimates: an improved method", Communications
// of the ACM 22(9), 1979, with every older weight multiplied by the decay), so the fit follows a
// renderer whose cost drifts. While the triangle counts seen barely differ (relative spread
// under 1 %) the slope is not identifiable: the last identified slope is kept (at first: the whole
// mean cost over the mean count, base 0). Cost: O(1) per frame, no allocation.
#include <algorithm>
#include <cmath>

#include "hmdnode/lod/budget.hpp"

namespace hmdnode {

FrameCostFit::FrameCostFit(double decay) : decay_(std::clamp(decay, 0.0, 1.0)) {}

void FrameCostFit::add(uint64_t triangles, double render_ms) {
    const double x = double(triangles), y = render_ms;
    weight_ = decay_ * weight_ + 1.0;
    const double dx = x - mean_x_, dy = y - mean_y_;
    mean_x_ += dx / weight_;
    mean_y_ += dy / weight_;
    cxx_ = decay_ * cxx_ + dx * (x - mean_x_);
    cxy_ = decay_ * cxy_ + dx * (y - mean_y_);
    const double variance = cxx_ / weight_;
    if (variance > 1e-4 * mean_x_ * mean_x_ && variance > 0.0) {
        per_triangle_ms_ = std::max(0.0, cxy_ / cxx_);
        slope_known_ = true;
    } else if (!slope_known_) {
        per_triangle_ms_ = mean_x_ > 0.0 ? std::max(0.0, mean_y_) / mean_x_ : 0.0;
    }
    base_ms_ = mean_y_ - per_triangle_ms_ * mean_x_;
}

}  // namespace hmdnode
