// Lens distortion of a head-mounted display, as pure CPU maths: headset profiles (per eye, per
// colour channel), the analytic models that map a panel point to the view direction it shows, a
// distortion mesh for the warp pass, and the render FOV that mesh needs.
//
// Models: `poly_radial` (Brown's even radial polynomial about a lens centre, in tangent space, as
// the Oculus SDK 0.2-0.4 DistortionFn), `vive_dpoly3_scaled` (the Vive / Index factory model as
// Monado evaluates it: src/xrt/auxiliary/util/u_distortion_mesh.c, u_compute_distortion_vive, with
// the FOV of src/xrt/drivers/vive/vive_config.c, _calculate_fov). The formulas, their derivation
// and the profile JSON format are in docs/lens-distortion.md.
//
// Threads: every function is pure (no globals, no I/O except load/save) and may be called from
// any thread. Cost: lens_sample is O(1) (a few dozen flops per channel); a mesh is
// (cols+1)(rows+1) samples and 6 cols rows indices.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "hmdnode/core/result.hpp"
#include "hmdnode/core/stereo.hpp"

namespace hmdnode {

enum class LensModel { none, poly_radial, vive_dpoly3_scaled };

// Name used in profile JSON ("none", "poly_radial", "vive_dpoly3_scaled").
const char* lens_model_name(LensModel model);

// One colour channel of one eye's lens.
//  poly_radial:        center = lens axis in paraxial tangents; coeffs = k0..k3 of
//                      t = c + (p - c)(k0 + k1 r^2 + k2 r^4 + k3 r^6), r = |p - c|.
//  vive_dpoly3_scaled: center = (center_x, center_y) of the device config (panel units of w/2,
//                      y down); coeffs = the config's 4 coeffs (k1 k2 k3 and the scaled term).
struct LensChannel {
    glm::dvec2 center{0.0};
    std::array<double, 4> coeffs{};
};

struct EyeLens {
    LensModel model = LensModel::none;
    LensChannel channel[3];            // 0 red, 1 green, 2 blue
    glm::dmat3 intrinsics{1.0};        // as the device gives it (vive model); glm is column-major
    double grow_for_undistort = 0.0;   // vive: the render-target growth the intrinsics include
    double undistort_r2_cutoff = 0.0;  // 0: none; else the model's domain (r^2 of its input)
    double aspect_x_over_y = 0.0;      // vive: physical panel aspect; 0: panel_width/panel_height
    glm::dmat3 eye_to_head{1.0};       // display canting: eye frame -> head-aligned eye frame
    EyeFov fov;  // poly_radial / none: the paraxial tangent rectangle the panel spans (eye frame);
                 // vive: Monado's render FOV from intrinsics and grow_for_undistort (informational)
};

struct HeadsetProfile {
    std::string name;
    int panel_width = 0, panel_height = 0;  // pixels per eye, nominal
    double refresh_hz = 90.0;
    EyeLens eye[2];  // 0 = left
};

bool operator==(const LensChannel& a, const LensChannel& b);
bool operator==(const EyeLens& a, const EyeLens& b);
bool operator==(const HeadsetProfile& a, const HeadsetProfile& b);

// Reads a profile (docs/lens-distortion.md, "Profile format"); errors name the file and the JSON
// field path, e.g. "valve-index.json: eye[1].channel.red.coeffs: expected 4 numbers".
Result<HeadsetProfile> load_headset_profile(const std::filesystem::path& path);
// Parses profile JSON text; `source_name` names it in errors.
Result<HeadsetProfile> parse_headset_profile(const std::string& json_text,
                                             const std::string& source_name);
// The profile as JSON text (what save writes; doubles round-trip exactly).
std::string headset_profile_to_json(const HeadsetProfile& profile);
// Writes atomically (temporary file, then rename).
Status save_headset_profile(const HeadsetProfile& profile, const std::filesystem::path& path);

// From an OpenVR/lighthouse device config JSON text (the libsurvive CONFIG line, or
// data/headsets/valve-index.config.json): tracking_to_eye_transform[0..1] and device.*.
// `source_name` names the text in errors. The profile's name is "<manufacturer> <model_number>".
Result<HeadsetProfile> headset_profile_from_openvr_config(const std::string& json_text,
                                                          const std::string& source_name);

// A built-in profile: "generic", a typical ~100-degree headset with a barrel poly_radial model and
// a small lateral chromatic aberration; equals data/headsets/generic.json.
HeadsetProfile generic_headset_profile();

// Checks what the models need (finite numbers, an invertible intrinsics matrix, a rotation in
// eye_to_head, a non-empty fov); `source_name` names the profile in errors.
Status validate_headset_profile(const HeadsetProfile& profile, const std::string& source_name);

// The analytic model. uv: a position on one eye's panel, [0,1]^2, u right, v DOWN (pixel (i,j)
// centre = ((i+0.5)/W, (j+0.5)/H)). Returns, per colour channel, the view direction that panel
// point must show, as tangents (tx, ty) in the HEAD-ALIGNED eye frame (x right, y UP, the ray is
// (tx, ty, -1)): eye_to_head is applied, so each eye renders with an unrotated asymmetric
// frustum. valid = false where the model is undefined or outside undistort_r2_cutoff in any
// channel; that channel's tangent is then clamped radially at the cutoff (or where the model
// stops being defined).
struct LensSample {
    glm::dvec2 tangent[3];
    bool valid = true;
};
LensSample lens_sample(const HeadsetProfile& profile, int eye, glm::dvec2 uv);

// A distortion mesh per eye: (cols+1) x (rows+1) vertices over the panel, row-major from the top
// left (vertex (c, r) at index r (cols+1) + c, uv = (c/cols, r/rows)), two triangles per cell
// split along the (c,r)-(c+1,r+1) diagonal, as a triangle list. Positions in Vulkan NDC (x right,
// y DOWN, [-1,1]); attributes = lens_sample() tangents at the vertex, as float.
struct DistortionVertex {
    glm::vec2 ndc;
    glm::vec2 tangent[3];
};
struct DistortionMesh {
    int cols = 0, rows = 0;
    std::vector<DistortionVertex> vertices;
    std::vector<uint32_t> indices;
    std::vector<uint8_t> valid;  // per vertex: lens_sample().valid (1/0)
};
DistortionMesh make_distortion_mesh(const HeadsetProfile& profile, int eye, int cols = 64,
                                    int rows = 64);

// What a rasteriser gives between vertices: barycentric interpolation of the mesh's tangents at
// uv, over the same triangulation; valid = all three vertices of the triangle are valid.
LensSample sample_distortion_mesh(const DistortionMesh& mesh, glm::dvec2 uv);

// The smallest tangent rectangle containing every tangent of every channel of the mesh's vertices
// (valid and clamped alike: the rasteriser interpolates both, and convex combinations stay
// inside), grown by `margin` (a fraction of its width / height per side) to leave room for a late
// rotational warp.
EyeFov mesh_render_fov(const DistortionMesh& mesh, double margin = 0.0);
// mesh_render_fov of make_distortion_mesh(profile, eye) (64 x 64).
EyeFov lens_render_fov(const HeadsetProfile& profile, int eye, double margin = 0.0);

// How far the mesh's colours come from on the panel, against the model: per panel pixel of a
// panel_width x panel_height eye, over every cell's centre and edge midpoints where the model is
// valid, the largest channel's error (the tangent error mapped through the model's inverse local
// Jacobian). Cost: 18 lens_sample calls per sample point.
struct MeshError {
    double max_px = 0.0, p99_px = 0.0;
};
MeshError mesh_interpolation_error(const HeadsetProfile& profile, int eye,
                                   const DistortionMesh& mesh, int panel_width, int panel_height);

// The coarsest square mesh (of 8, 12, 16, 24, 32, 48, 64, 96, 128 cells per side) whose
// interpolation error stays within max_error_px everywhere on both eyes at this panel size: on a
// software rasteriser the mesh's triangles cost as much as its pixels. 128 when none does.
int choose_mesh_cells(const HeadsetProfile& profile, int panel_width, int panel_height,
                      double max_error_px);

}  // namespace hmdnode
