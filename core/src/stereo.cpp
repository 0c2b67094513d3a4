#include "hmdnode/core/stereo.hpp"

#include <cmath>

namespace hmdnode {

StereoRig StereoRig::typical() {
    StereoRig rig;
    // Outer half-angle 50 deg, inner 42 deg, up 50 deg, down 50 deg.
    const double outer = std::tan(deg_to_rad(50.0)), inner = std::tan(deg_to_rad(42.0));
    const double vert = std::tan(deg_to_rad(50.0));
    rig.eye[0] = EyeFov{-outer, inner, vert, -vert};
    rig.eye[1] = EyeFov{-inner, outer, vert, -vert};
    return rig;
}

glm::dvec3 eye_offset(const StereoRig& rig, int eye) {
    return glm::dvec3(eye == 0 ? -0.5 * rig.ipd_m : 0.5 * rig.ipd_m, 0.0, 0.0);
}

glm::mat4 eye_view_matrix(const StereoRig& rig, const Pose& head, int eye) {
    // eye-to-world = T(head.position) * R(head.orientation) * T(eye offset); view = its inverse.
    glm::dmat4 r = glm::mat4_cast(head.orientation);
    glm::dmat4 eye_to_world = r;
    eye_to_world[3] = glm::dvec4(head.position + head.orientation * eye_offset(rig, eye), 1.0);
    return glm::mat4(glm::inverse(eye_to_world));
}

glm::mat4 eye_projection(const EyeFov& fov, double n, double f) {
    // Off-axis frustum on the near plane: x in [l, r], y in [d, u]; Vulkan NDC has y pointing down.
    const double l = fov.tan_left * n, r = fov.tan_right * n;
    const double u = fov.tan_up * n, d = fov.tan_down * n;
    glm::dmat4 m(0.0);
    m[0][0] = 2.0 * n / (r - l);
    m[1][1] = -2.0 * n / (u - d);
    m[2][0] = (r + l) / (r - l);
    m[2][1] = -(u + d) / (u - d);
    m[2][2] = f / (n - f);
    m[2][3] = -1.0;
    m[3][2] = n * f / (n - f);
    return glm::mat4(m);
}

double pixels_per_radian(const EyeFov& fov, int height_px) {
    // At the centre, one radian spans height / (tan_up - tan_down) pixels (small-angle slope of
    // tan).
    return double(height_px) / (fov.tan_up - fov.tan_down);
}

bool sphere_in_frustum(const glm::dmat4& view, const EyeFov& fov, double near_m,
                       const glm::dvec3& center, double radius) {
    const glm::dvec3 p = glm::dvec3(view * glm::dvec4(center, 1.0));
    const double d = -p.z;  // depth along the eye's view direction
    if (d < near_m - radius) return false;
    auto outside = [&](double coord, double t, double sign) {
        // note: the side plane coord = t * d, its outward normal's sign
        return sign * (coord - t * d) / std::sqrt(1.0 + t * t) > radius;
    };
    return !(outside(p.x, fov.tan_right, 1.0) || outside(p.x, fov.tan_left, -1.0) ||
             outside(p.y, fov.tan_up, 1.0) || outside(p.y, fov.tan_down, -1.0));
}

}  // namespace hmdnode
