// The stereo rig: per-eye asymmetric frusta and the interpupillary distance. Vulkan clip space:
// x right, y down, depth 0..1.
#pragma once

#include <glm/glm.hpp>

#include "hmdnode/core/pose.hpp"

namespace hmdnode {

// Tangents of the half-angles of one eye's frustum (left and down are negative).
struct EyeFov {
    double tan_left = -1.0, tan_right = 1.0, tan_up = 1.0, tan_down = -1.0;
};

struct StereoRig {
    double ipd_m = 0.063;
    EyeFov eye[2];  // 0 = left, 1 = right
    double near_m = 0.05, far_m = 100.0;

    // A typical headset: ~100 deg per eye, the inner (nasal) side narrower than the outer.
    static StereoRig typical();
};

// Eye position in the head frame: (-ipd/2, 0, 0) for the left eye, (+ipd/2, 0, 0) for the right.
glm::dvec3 eye_offset(const StereoRig& rig, int eye);
// World-to-eye view matrix for a head pose.
glm::mat4 eye_view_matrix(const StereoRig& rig, const Pose& head, int eye);
// Off-axis projection (Vulkan conventions: y down, depth 0..1, reversed-Z not used).
glm::mat4 eye_projection(const EyeFov& fov, double near_m, double far_m);
// Pixels per radian at the centre of the eye image of the given height.
double pixels_per_radian(const EyeFov& fov, int height_px);
// Whether a sphere (world centre, radius) reaches into an eye's frustum: `view` is the eye's
// world-to-eye matrix, the frustum the fov's four side planes and the near plane (no far plane).
// Conservative near the frustum's edges (a sphere beyond two planes' corner may count as inside).
bool sphere_in_frustum(const glm::dmat4& view, const EyeFov& fov, double near_m,
                       const glm::dvec3& center, double radius);

}  // namespace hmdnode
