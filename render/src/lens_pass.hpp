// The fused late-warp + lens pass's parameters: one eye's lens model (lens.hpp) in the form both
// backends' fragment shaders evaluate per panel pixel (render/shaders/lens_warp.frag and its GLES
// twin in gles_shaders.cpp), so that rotational reprojection, lens distortion and chromatic
// aberration are one full-screen pass with no distortion mesh (OpenHMD evaluates its lens
// polynomial per fragment the same way; Monado's compute compositor fuses distortion and time
// warp in one dispatch). Per pixel and channel the shader computes the homogeneous eye-frame
// direction d the panel point shows, then h = reproject * eye_to_head * d and samples the eye
// buffer at h.xy / h.z: exactly lens_sample()'s tangent followed by the mesh pass's reprojection,
// up to a positive scale of d (which h.xy / h.z cancels), in float.
//
// Where lens_sample() clamps a channel (undistort_r2_cutoff, or the radius where the model stops
// being defined, found here once by a scan and bisection over the panel's reach), the shader
// clamps at the same r^2.
//
// Cost: set-up O(panel samples of one 65x65 grid per channel); the shader about 25 flops per
// channel beyond the three bilinear samples.
#pragma once

#include <glm/glm.hpp>

#include "hmdnode/render/lens.hpp"

namespace hmdnode::gpu {

// The shaders' model switch (a specialisation constant in Vulkan, a #define in GLES).
enum class LensPassModel : int { none = 0, poly_radial = 1, vive = 2 };

// std140 layout of the shaders' `Lens` uniform block; one per eye.
struct LensUniforms {
    glm::vec4 center_limit[3];  // per channel: xy centre, z the r^2 the model is clamped at
    glm::vec4 coeffs[3];        // per channel
    glm::vec4 fov;              // tan_left, tan_right, tan_up, tan_down (none, poly_radial)
    glm::vec4 panel;            // x 1 / panel width, y 1 / panel height, z aspect, w 1 / aspect
    glm::mat4 pre;  // vive: K^-1 diag(1, -aspect, 1) in the upper 3x3, and in column 3 the (g, 1)
                    // whose ray is straight ahead (pre^-1 (0, 0, -1)); else identity
};
static_assert(sizeof(LensUniforms) == 192, "std140 layout of the Lens block");

struct LensPassEye {
    LensPassModel model = LensPassModel::none;
    LensUniforms uniforms{};
    glm::mat3 eye_to_head{1.0f};  // folded into the per-frame reprojection matrix
    bool shared = false;          // the channels share one centre and one clamp (poly_radial, none)
    bool clamped = false;         // the panel reaches where some channel's model is clamped
};

struct LensPassSetup {
    LensPassEye eye[2];
    bool chromatic = false;  // some channel of some eye differs: three samples per pixel
};

// The set-up for `profile` at panel_width x panel_height per eye. Errors: an empty panel, a
// profile validate_headset_profile() refuses.
Result<LensPassSetup> make_lens_pass_setup(const HeadsetProfile& profile, int panel_width,
                                           int panel_height);

// What the shader computes for channel c at panel position uv ([0,1]^2, v down), in float: the
// eye-frame direction (up to a positive scale). The CPU mirror the tests hold against
// lens_sample().
glm::vec3 lens_pass_direction(const LensPassEye& eye, int channel, glm::vec2 uv);

// The per-frame matrix of one eye: warp_reprojection(rendered_projection, delta) * eye_to_head,
// times the vive model's pre matrix (so the shader projects (g, 1) directly).
glm::mat4 lens_pass_reprojection(const glm::mat4& warp_reprojection, const LensPassEye& eye);

}  // namespace hmdnode::gpu
