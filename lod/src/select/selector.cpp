// Runtime LOD selection: screen-space error (D. Luebke, M. Reddy, J. D. Cohen, A. Varshney, B.
// Watson, R. Huebner, "Level of Detail for 3D Graphics", Morgan Kaufmann 2003, ch. 4) against a
// perceptual tolerance, the eccentricity and speed criteria of J. He, P. Wang, J. Zhu, J. Zeng,
// "Application and Optimization of Mesh Simplification in 3D virtual Reality Scene in a
// High-performance Environment" (venue and year not stated in our copy) and of Reddy's perceptual
// LOD (M. Reddy, "Perceptually Modulated Level of Detail for Virtual Environments", PhD thesis,
// University of Edinburgh, 1997) made quantitative: acuity as the minimum angle of resolution that
// grows linearly with eccentricity (B. Guenter, M. Finch, S. Drucker, D. Tan, J. Snyder, "Foveated
// 3D graphics", ACM Transactions on Graphics 31(6), SIGGRAPH Asia 2012), and the smear of a head
// turn during the display's persistence; hysteresis against flicker. Full citations:
// docs/references.md. Cost: O(levels) per object per frame, no allocation.
#include "hmdnode/lod/selector.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>

namespace hmdnode {

LodSelector::LodSelector(size_t object_count, const LodSelectorParams& params)
    : params_(params), current_(object_count, -1) {}

void LodSelector::reset() {
    std::fill(current_.begin(), current_.end(), -1);
}

double LodSelector::tolerance_px(const LodSelectorParams& p, double eccentricity_deg,
                                 double speed_dps, double pixels_per_radian) {
    const double ppd = pixels_per_radian * (3.14159265358979323846 / 180.0);
    const double acuity = (p.mar0_deg + p.mar_slope * std::max(0.0, eccentricity_deg)) * ppd;
    const double smear = std::max(0.0, speed_dps) * p.persistence_s * ppd;
    return std::min(p.tolerance_px * p.max_widening, std::max({p.tolerance_px, acuity, smear}));
}

double LodSelector::projected_error_px(double error_m, double distance_m,
                                       double pixels_per_radian) {
    return error_m / distance_m * pixels_per_radian;
}

LodDecision LodSelector::select(size_t index, const LodObjectView& object,
                                const LodViewer& viewer) {
    assert(index < current_.size());
    assert(!object.level_errors_m.empty());
    const int levels = int(object.level_errors_m.size());

    // Distance to the nearest point of the bounding sphere, and eccentricity of its nearest edge.
    const glm::dvec3 to_center = object.center - viewer.eye_position;
    const double center_dist = glm::length(to_center);
    const double distance = std::max(viewer.near_m, center_dist - object.radius);
    double ecc_deg = 0.0;
    if (center_dist > object.radius && center_dist > 1e-9) {
        const double cos_a =
            std::clamp(glm::dot(to_center / center_dist, viewer.gaze_direction), -1.0, 1.0);
        const double half_size = std::asin(std::min(1.0, object.radius / center_dist));
        ecc_deg = (180.0 / 3.14159265358979323846) * (std::max(0.0, std::acos(cos_a) - half_size));
    }
    const double tol =
        tolerance_px(params_, ecc_deg, viewer.angular_speed_dps, viewer.pixels_per_radian);

    auto projected = [&](int l) {
        return projected_error_px(object.level_errors_m[l], distance, viewer.pixels_per_radian);
    };
    // The coarsest level whose projected error fits a tolerance (levels ordered fine to coarse).
    auto coarsest_within = [&](double t) {
        int best = 0;
        for (int l = 0; l < levels; ++l)
            if (projected(l) <= t) best = l;
        return best;
    };

    int& cur = current_[index];
    int level;
    if (cur < 0 || cur >= levels) {
        level = coarsest_within(tol);
    } else if (projected(cur) > tol) {
        level = coarsest_within(tol);  // the current level is too coarse now: refine at once
    } else {
        // Coarsen only when a coarser level fits with margin; otherwise keep the current level.
        level = std::max(cur, coarsest_within(tol * (1.0 - params_.hysteresis)));
    }
    cur = level;
    return LodDecision{level, ecc_deg, tol, projected(level), distance};
}

}  // namespace hmdnode
