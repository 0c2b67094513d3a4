// The fused pass's parameters from a headset profile (see lens_pass.hpp).
#include "lens_pass.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <string>

#include "lens_math.hpp"

namespace hmdnode::gpu {
namespace {

// The r^2 at which lens_sample() clamps this channel over the panel's reach `reach_r2`: the cutoff,
// or the first radius where the model is undefined (a scan, then 40 bisection steps as
// lens_sample() takes), whichever is smaller; a huge value where neither is met.
double clamp_r2(const EyeLens& lens, const LensChannel& ch, double reach_r2) {
    assert(lens.model != LensModel::none && reach_r2 >= 0.0);
    double limit = lens.undistort_r2_cutoff > 0.0 ? lens.undistort_r2_cutoff : 1e30;
    const double top = std::min(limit, reach_r2);
    const int steps = 4096;
    double prev = 0.0;
    for (int i = 1; i <= steps; ++i) {
        const double r2 = top * double(i) / steps;
        if (std::isnan(lens_radial_factor(lens.model, ch.coeffs, r2))) {
            double lo = prev, hi = r2;
            for (int k = 0; k < 40; ++k) {
                const double mid = 0.5 * (lo + hi);
                (std::isnan(lens_radial_factor(lens.model, ch.coeffs, mid)) ? hi : lo) = mid;
            }
            // Within the step where the model stops: defined at lo, below the cutoff.
            assert(lo >= prev && lo <= r2 && lo <= limit);
            return lo;
        }
        prev = r2;
    }
    return limit;
}

// The largest |q|^2 of channel `ch` over the panel: q is affine in the panel position, so a
// corner holds it.
double reach_r2(const HeadsetProfile& p, const EyeLens& lens, const LensChannel& ch) {
    double best = 0.0;
    for (double u : {0.0, 1.0})
        for (double v : {0.0, 1.0}) {
            glm::dvec2 q;
            if (lens.model == LensModel::vive_dpoly3_scaled) {
                const double a = lens.aspect_x_over_y > 0.0
                                     ? lens.aspect_x_over_y
                                     : double(p.panel_width) / double(p.panel_height);
                q = glm::dvec2(2.0 * u - 1.0 - ch.center.x, (2.0 * v - 1.0) / a - ch.center.y);
            } else {
                q = glm::dvec2(lens.fov.tan_left + u * (lens.fov.tan_right - lens.fov.tan_left),
                               lens.fov.tan_up + v * (lens.fov.tan_down - lens.fov.tan_up)) -
                    ch.center;
            }
            best = std::max(best, glm::dot(q, q));
        }
    return best * 1.01;
}

}  // namespace

Result<LensPassSetup> make_lens_pass_setup(const HeadsetProfile& profile, int panel_width,
                                           int panel_height) {
    if (panel_width < 1 || panel_height < 1)
        return make_error("lens pass: panel " + std::to_string(panel_width) + "x" +
                          std::to_string(panel_height) + " is empty");
    if (Status s = validate_headset_profile(
            profile, profile.name.empty() ? "headset profile" : profile.name);
        !s)
        return s.error();
    LensPassSetup setup;
    for (int e = 0; e < 2; ++e) {
        const EyeLens& lens = profile.eye[e];
        LensPassEye& out = setup.eye[e];
        // A validated profile: the vive model's panel aspect is positive.
        assert(lens.model != LensModel::vive_dpoly3_scaled || lens.aspect_x_over_y > 0.0 ||
               (profile.panel_width > 0 && profile.panel_height > 0));
        LensUniforms& u = out.uniforms;
        out.model = lens.model == LensModel::vive_dpoly3_scaled ? LensPassModel::vive
                    : lens.model == LensModel::poly_radial      ? LensPassModel::poly_radial
                                                                : LensPassModel::none;
        const double a = lens.aspect_x_over_y > 0.0
                             ? lens.aspect_x_over_y
                             : (profile.panel_width > 0 && profile.panel_height > 0
                                    ? double(profile.panel_width) / double(profile.panel_height)
                                    : 1.0);
        for (int c = 0; c < 3; ++c) {
            const LensChannel& ch = lens.channel[c];
            const double limit = out.model == LensPassModel::none
                                     ? 1e30
                                     : clamp_r2(lens, ch, reach_r2(profile, lens, ch));
            u.center_limit[c] = glm::vec4(float(ch.center.x), float(ch.center.y),
                                          float(std::min(limit, 1e30)), 0.0f);
            u.coeffs[c] = glm::vec4(float(ch.coeffs[0]), float(ch.coeffs[1]), float(ch.coeffs[2]),
                                    float(ch.coeffs[3]));
            if (c > 0 && out.model != LensPassModel::none &&
                (ch.center != lens.channel[0].center || ch.coeffs != lens.channel[0].coeffs))
                setup.chromatic = true;
        }
        u.fov = glm::vec4(float(lens.fov.tan_left), float(lens.fov.tan_right),
                          float(lens.fov.tan_up), float(lens.fov.tan_down));
        u.panel = glm::vec4(1.0f / float(panel_width), 1.0f / float(panel_height), float(a),
                            float(1.0 / a));
        u.pre = glm::mat4(1.0f);
        if (out.model == LensPassModel::vive) {
            // (x, y, z) = K^-1 (g.x, -a g.y, 1): the aspect's diagonal folded in.
            const glm::dmat3 pre =
                glm::inverse(lens.intrinsics) *
                glm::dmat3(glm::dvec3(1, 0, 0), glm::dvec3(0, -a, 0), glm::dvec3(0, 0, 1));
            u.pre = glm::mat4(glm::mat3(pre));
            u.pre[3] = glm::vec4(glm::vec3(glm::inverse(pre) * glm::dvec3(0.0, 0.0, -1.0)), 1.0f);
        }
        // Shared centre and clamp: one offset and radius serve every channel.
        out.shared = out.model != LensPassModel::vive;
        for (int c = 1; c < 3; ++c)
            out.shared = out.shared && glm::vec3(u.center_limit[c]) == glm::vec3(u.center_limit[0]);
        for (int c = 0; c < 3; ++c) out.clamped = out.clamped || u.center_limit[c].z < 1e29f;
        out.eye_to_head = glm::mat3(lens.eye_to_head);
    }
    return setup;
}

glm::vec3 lens_pass_direction(const LensPassEye& eye, int c, glm::vec2 uv) {
    assert(c >= 0 && c < 3);
    const LensUniforms& u = eye.uniforms;
    const glm::vec2 ctr(u.center_limit[c]);
    auto radial = [&](glm::vec2 q) {
        const float lim = u.center_limit[c].z;
        float r2 = glm::dot(q, q);
        if (r2 > lim) {
            q *= std::sqrt(lim / r2);
            r2 = lim;
        }
        const glm::vec4 k = u.coeffs[c];
        const float f = eye.model == LensPassModel::vive
                            ? 1.0f / (1.0f + r2 * (k.x + r2 * (k.y + r2 * k.z))) + k.w
                            : k.x + r2 * (k.y + r2 * (k.z + r2 * k.w));
        return q * f;
    };
    if (eye.model == LensPassModel::vive) {
        const float a = u.panel.z;
        const glm::vec2 q(2.0f * uv.x - 1.0f - ctr.x, (2.0f * uv.y - 1.0f) / a - ctr.y);
        const glm::vec3 ray = glm::mat3(u.pre) * glm::vec3(radial(q) + ctr, 1.0f);
        return ray.z < 0.0f ? ray : glm::vec3(0.0f, 0.0f, -1.0f);
    }
    glm::vec2 p(u.fov.x + uv.x * (u.fov.y - u.fov.x), u.fov.z + uv.y * (u.fov.w - u.fov.z));
    if (eye.model == LensPassModel::poly_radial) p = ctr + radial(p - ctr);
    return glm::vec3(p, -1.0f);
}

glm::mat4 lens_pass_reprojection(const glm::mat4& warp_reprojection, const LensPassEye& eye) {
    const glm::mat3 m = glm::mat3(warp_reprojection) * eye.eye_to_head;
    return glm::mat4(eye.model == LensPassModel::vive ? m * glm::mat3(eye.uniforms.pre) : m);
}

}  // namespace hmdnode::gpu
