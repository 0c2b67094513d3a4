// The radial factor of the lens models (lens.hpp), shared by the analytic model (lens_model.cpp)
// and the fused pass's set-up (lens_pass.cpp), so both clamp where the model stops being defined.
#pragma once

#include <array>
#include <limits>

#include "hmdnode/render/lens.hpp"

namespace hmdnode {

// The radial factor of `model` at r2, or NaN where the model is undefined.
//  vive_dpoly3_scaled: 1 / (1 + k0 r^2 + k1 r^4 + k2 r^6) + k3, defined where the denominator and
//                      the result are positive;
//  poly_radial:        k0 + k1 r^2 + k2 r^4 + k3 r^6, defined where positive.
inline double lens_radial_factor(LensModel model, const std::array<double, 4>& k, double r2) {
    if (model == LensModel::vive_dpoly3_scaled) {
        const double bottom = 1.0 + r2 * (k[0] + r2 * (k[1] + r2 * k[2]));
        if (!(bottom > 1e-9)) return std::numeric_limits<double>::quiet_NaN();
        const double d = 1.0 / bottom + k[3];
        return d > 0.0 ? d : std::numeric_limits<double>::quiet_NaN();
    }
    const double f = k[0] + r2 * (k[1] + r2 * (k[2] + r2 * k[3]));
    return f > 0.0 ? f : std::numeric_limits<double>::quiet_NaN();
}

}  // namespace hmdnode
