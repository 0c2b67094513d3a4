// The analytic lens models, the distortion mesh over them and the render FOV the mesh needs
// (hmdnode/render/lens.hpp; derivations in docs/lens-distortion.md).
//
// vive_dpoly3_scaled: Monado, src/xrt/auxiliary/util/u_distortion_mesh.c,
// u_compute_distortion_vive (Philipp Zabel, Lubosz Sarnecki, Collabora; BSL-1.0), per channel:
//   q  = (2u - 1 - cx, (2v - 1)/a - cy)                     a = aspect_x_over_y, v down
//   d  = 1 / (1 + k1 r^2 + k2 r^4 + k3 r^6) + k4             r^2 = q.q
//   g  = q d + c                                            "grown NDC": (1 + grow) * render NDC
// Monado then samples its render target at 0.5 + g / (2 (1 + grow)) (y times a), a target whose
// FOV it derives from the intrinsics K divided by (1 + grow) (src/xrt/drivers/vive/vive_config.c,
// _calculate_fov). Composing the two, (1 + grow) cancels and the view direction is
//   (x, y, z) = K^-1 (g.x, -a g.y, 1),  tangent = (x, y) / -z     (K's last row is (0, 0, -1))
// which does not depend on the render FOV. The Valve lighthouse HMD documentation
// ("tracking_to_eye_transform": intrinsics, distortion center_x/center_y in units of w/2, +Y down)
// defines the inputs. Departures from Monado: double precision; r^2 is clamped at
// undistort_r2_cutoff (Monado ignores it) and such samples are flagged invalid.
//
// poly_radial: Brown's even radial polynomial in tangent space (D. C. Brown, "Decentering
// distortion of lenses", 1966), the form of the Oculus SDK 0.2-0.4 DistortionFn
// (scale = K0 + K1 r^2 + K2 r^4 + K3 r^6) with per-channel coefficients for lateral chromatic
// aberration: p = the paraxial tangent of uv in `fov`, t = c + (p - c) * scale(|p - c|^2).
//
// Then every channel's eye-frame ray (t, -1) is rotated by eye_to_head (display canting).
//
// Cost: lens_sample about 60 flops per channel (plus a 40-step bisection only where a model
// stops being defined); a mesh is (cols+1)(rows+1) samples, 32 bytes per vertex, 6 cols rows
// indices; sample_distortion_mesh O(1).
#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>

#include "hmdnode/core/percentile.hpp"
#include "hmdnode/render/lens.hpp"
#include "lens_math.hpp"

namespace hmdnode {
namespace {

double panel_aspect(const HeadsetProfile& p, const EyeLens& lens) {
    if (lens.aspect_x_over_y > 0.0) return lens.aspect_x_over_y;
    assert(p.panel_width > 0 && p.panel_height > 0);
    return double(p.panel_width) / double(p.panel_height);
}

// Applies the radial model to an offset q from the channel centre: q * factor(|q|^2), with |q|^2
// clamped at the cutoff and, where the model is undefined, at the largest defined r2 below.
glm::dvec2 apply_radial(const EyeLens& lens, const LensChannel& ch, glm::dvec2 q, bool* valid) {
    assert(valid != nullptr && lens.model != LensModel::none);
    double r2 = glm::dot(q, q);
    if (lens.undistort_r2_cutoff > 0.0 && r2 > lens.undistort_r2_cutoff) {
        q *= std::sqrt(lens.undistort_r2_cutoff / r2);
        r2 = lens.undistort_r2_cutoff;
        *valid = false;
    }
    double f = lens_radial_factor(lens.model, ch.coeffs, r2);
    if (std::isnan(f)) {
        *valid = false;
        double lo = 0.0, hi = r2;  // note: factor(0) is defined for every validated profile
        for (int i = 0; i < 40; ++i) {
            const double mid = 0.5 * (lo + hi);
            (std::isnan(lens_radial_factor(lens.model, ch.coeffs, mid)) ? hi : lo) = mid;
        }
        // The bisection keeps lo where the model is defined, below where it is not.
        assert(lo >= 0.0 && lo <= hi && hi <= r2);
        q *= r2 > 0.0 ? std::sqrt(lo / r2) : 0.0;
        f = lens_radial_factor(lens.model, ch.coeffs, lo);
        if (std::isnan(f)) f = 0.0;
    }
    return q * f;
}

// Eye-frame tangent -> head-aligned tangent through eye_to_head.
glm::dvec2 to_head(const glm::dmat3& eye_to_head, glm::dvec2 t, bool* valid) {
    assert(valid != nullptr);
    const glm::dvec3 ray = eye_to_head * glm::dvec3(t, -1.0);
    if (!(ray.z < -1e-9)) {
        *valid = false;
        return t;
    }
    return glm::dvec2(ray.x, ray.y) / -ray.z;
}

}  // namespace

LensSample lens_sample(const HeadsetProfile& profile, int eye, glm::dvec2 uv) {
    assert(eye == 0 || eye == 1);
    const EyeLens& lens = profile.eye[eye];
    LensSample out;
    switch (lens.model) {
        case LensModel::none: {
            const glm::dvec2 p(lens.fov.tan_left + uv.x * (lens.fov.tan_right - lens.fov.tan_left),
                               lens.fov.tan_up + uv.y * (lens.fov.tan_down - lens.fov.tan_up));
            for (auto& t : out.tangent) t = p;
            break;
        }
        case LensModel::poly_radial: {
            const glm::dvec2 p(lens.fov.tan_left + uv.x * (lens.fov.tan_right - lens.fov.tan_left),
                               lens.fov.tan_up + uv.y * (lens.fov.tan_down - lens.fov.tan_up));
            for (int i = 0; i < 3; ++i) {
                const LensChannel& ch = lens.channel[i];
                out.tangent[i] = ch.center + apply_radial(lens, ch, p - ch.center, &out.valid);
            }
            break;
        }
        case LensModel::vive_dpoly3_scaled: {
            const double a = panel_aspect(profile, lens);
            const glm::dmat3 k_inv = glm::inverse(lens.intrinsics);
            for (int i = 0; i < 3; ++i) {
                const LensChannel& ch = lens.channel[i];
                const glm::dvec2 q(2.0 * uv.x - 1.0 - ch.center.x,
                                   (2.0 * uv.y - 1.0) / a - ch.center.y);
                const glm::dvec2 g = apply_radial(lens, ch, q, &out.valid) + ch.center;
                const glm::dvec3 ray = k_inv * glm::dvec3(g.x, -a * g.y, 1.0);
                if (!(ray.z < 0.0)) {
                    out.valid = false;
                    out.tangent[i] = glm::dvec2(0.0);
                    continue;
                }
                out.tangent[i] = glm::dvec2(ray.x, ray.y) / -ray.z;
            }
            break;
        }
    }
    for (auto& t : out.tangent) t = to_head(lens.eye_to_head, t, &out.valid);
    return out;
}

DistortionMesh make_distortion_mesh(const HeadsetProfile& profile, int eye, int cols, int rows) {
    assert(cols > 0 && rows > 0);
    DistortionMesh mesh;
    mesh.cols = cols;
    mesh.rows = rows;
    const size_t vcols = size_t(cols) + 1, vrows = size_t(rows) + 1;
    mesh.vertices.reserve(vcols * vrows);
    mesh.valid.reserve(vcols * vrows);
    for (int r = 0; r <= rows; ++r) {
        for (int c = 0; c <= cols; ++c) {
            const glm::dvec2 uv(double(c) / cols, double(r) / rows);
            const LensSample s = lens_sample(profile, eye, uv);
            DistortionVertex v;
            v.ndc = glm::vec2(2.0 * uv - 1.0);
            for (int i = 0; i < 3; ++i) v.tangent[i] = glm::vec2(s.tangent[i]);
            mesh.vertices.push_back(v);
            mesh.valid.push_back(s.valid ? 1 : 0);
        }
    }
    assert(mesh.vertices.size() == vcols * vrows && mesh.valid.size() == mesh.vertices.size());
    mesh.indices.reserve(size_t(6) * cols * rows);
    for (int r = 0; r < rows; ++r) {
        for (int c = 0; c < cols; ++c) {
            const uint32_t v00 = uint32_t(r * vcols + c), v10 = v00 + 1;
            const uint32_t v01 = uint32_t(v00 + vcols), v11 = v01 + 1;
            assert(v11 < mesh.vertices.size());  // the cell's corners are vertices of the grid
            mesh.indices.insert(mesh.indices.end(), {v00, v10, v11, v00, v11, v01});
        }
    }
    assert(mesh.indices.size() == size_t(6) * size_t(cols) * size_t(rows));
    return mesh;
}

LensSample sample_distortion_mesh(const DistortionMesh& mesh, glm::dvec2 uv) {
    assert(mesh.cols > 0 && mesh.rows > 0);
    // The grid make_distortion_mesh builds: (cols + 1) x (rows + 1) vertices.
    assert(mesh.vertices.size() == (size_t(mesh.cols) + 1) * (size_t(mesh.rows) + 1));
    assert(mesh.valid.empty() || mesh.valid.size() == mesh.vertices.size());
    const double fu = uv.x * mesh.cols, fv = uv.y * mesh.rows;
    const int c = std::clamp(int(std::floor(fu)), 0, mesh.cols - 1);
    const int r = std::clamp(int(std::floor(fv)), 0, mesh.rows - 1);
    const double x = fu - c, y = fv - r;
    const size_t vcols = size_t(mesh.cols) + 1;
    const size_t v00 = size_t(r) * vcols + c, v10 = v00 + 1, v01 = v00 + vcols, v11 = v01 + 1;
    // The cell's two triangles, split along v00-v11 as make_distortion_mesh does.
    size_t idx[3];
    double w[3];
    if (x >= y) {
        idx[0] = v00, idx[1] = v10, idx[2] = v11;
        w[0] = 1.0 - x, w[1] = x - y, w[2] = y;
    } else {
        idx[0] = v00, idx[1] = v11, idx[2] = v01;
        w[0] = 1.0 - y, w[1] = x, w[2] = y - x;
    }
    // Barycentric weights of the point in its triangle (inside it for uv in [0, 1]^2).
    assert(std::abs(w[0] + w[1] + w[2] - 1.0) < 1e-9 && idx[1] < mesh.vertices.size() &&
           idx[2] < mesh.vertices.size());
    LensSample out;
    for (int ch = 0; ch < 3; ++ch) {
        glm::dvec2 t(0.0);
        for (int k = 0; k < 3; ++k) t += w[k] * glm::dvec2(mesh.vertices[idx[k]].tangent[ch]);
        out.tangent[ch] = t;
    }
    if (!mesh.valid.empty()) {
        out.valid = mesh.valid[idx[0]] && mesh.valid[idx[1]] && mesh.valid[idx[2]];
    }
    return out;
}

EyeFov mesh_render_fov(const DistortionMesh& mesh, double margin) {
    assert(!mesh.vertices.empty() && margin >= 0.0);
    const double inf = std::numeric_limits<double>::infinity();
    double x0 = inf, x1 = -inf, y0 = inf, y1 = -inf;
    for (const DistortionVertex& v : mesh.vertices) {
        for (const glm::vec2& t : v.tangent) {
            x0 = std::min(x0, double(t.x)), x1 = std::max(x1, double(t.x));
            y0 = std::min(y0, double(t.y)), y1 = std::max(y1, double(t.y));
        }
    }
    const double mx = margin * (x1 - x0), my = margin * (y1 - y0);
    return EyeFov{x0 - mx, x1 + mx, y1 + my, y0 - my};
}

EyeFov lens_render_fov(const HeadsetProfile& profile, int eye, double margin) {
    return mesh_render_fov(make_distortion_mesh(profile, eye), margin);
}

MeshError mesh_interpolation_error(const HeadsetProfile& profile, int eye,
                                   const DistortionMesh& mesh, int panel_width, int panel_height) {
    // At every cell centre and the midpoints of its top and left edges (where a bilinear-like
    // error peaks): the mesh's tangent error through the inverse of the model's local Jacobian
    // (tangent per panel pixel, central differences over 0.25 px), for each channel.
    assert((eye == 0 || eye == 1) && panel_width > 0 && panel_height > 0);
    const double w = panel_width, h = panel_height, d = 0.25;
    std::vector<double> errors;
    errors.reserve(size_t(mesh.cols) * mesh.rows * 3);
    for (int r = 0; r < mesh.rows; ++r)
        for (int c = 0; c < mesh.cols; ++c)
            for (const glm::dvec2 f :
                 {glm::dvec2(0.5, 0.5), glm::dvec2(0.5, 0.0), glm::dvec2(0.0, 0.5)}) {
                const glm::dvec2 uv((c + f.x) / mesh.cols, (r + f.y) / mesh.rows);
                const LensSample m = sample_distortion_mesh(mesh, uv);
                const LensSample x = lens_sample(profile, eye, uv);
                const LensSample xp = lens_sample(profile, eye, uv + glm::dvec2(d / w, 0.0));
                const LensSample xm = lens_sample(profile, eye, uv - glm::dvec2(d / w, 0.0));
                const LensSample yp = lens_sample(profile, eye, uv + glm::dvec2(0.0, d / h));
                const LensSample ym = lens_sample(profile, eye, uv - glm::dvec2(0.0, d / h));
                if (!m.valid || !x.valid || !xp.valid || !xm.valid || !yp.valid || !ym.valid)
                    continue;
                double worst = 0.0;
                for (int ch = 0; ch < 3; ++ch) {
                    const glm::dmat2 j((xp.tangent[ch] - xm.tangent[ch]) / (2.0 * d),
                                       (yp.tangent[ch] - ym.tangent[ch]) / (2.0 * d));
                    if (std::abs(glm::determinant(j)) < 1e-300) continue;
                    worst = std::max(
                        worst, glm::length(glm::inverse(j) * (m.tangent[ch] - x.tangent[ch])));
                }
                errors.push_back(worst);
            }
    MeshError e;
    if (errors.empty()) return e;
    std::sort(errors.begin(), errors.end());
    e.max_px = errors.back();
    e.p99_px = percentile_sorted(errors, 0.99);
    return e;
}

int choose_mesh_cells(const HeadsetProfile& profile, int panel_width, int panel_height,
                      double max_error_px) {
    assert(panel_width > 0 && panel_height > 0 && max_error_px >= 0.0);
    const int sizes[] = {8, 12, 16, 24, 32, 48, 64, 96, 128};
    for (int n : sizes) {
        double worst = 0.0;
        for (int eye = 0; eye < 2; ++eye)
            worst = std::max(worst, mesh_interpolation_error(
                                        profile, eye, make_distortion_mesh(profile, eye, n, n),
                                        panel_width, panel_height)
                                        .max_px);
        if (worst <= max_error_px) return n;
    }
    return 128;
}

}  // namespace hmdnode
