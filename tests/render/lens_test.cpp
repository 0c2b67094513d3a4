// Tests of the lens models, headset profiles and distortion mesh (hmdnode/render/lens.hpp):
// the Valve Index import against its stored profile and against the documented formula computed
// here by hand from the raw factory config (docs/lens-distortion.md), the mesh's exactness at its
// vertices and its interpolation error between them, the render FOV, the generic profile's round
// trip, and the errors of the profile reader.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "../../render/src/lens_pass.hpp"
#include "hmdnode/core/atomic_file.hpp"
#include "hmdnode/core/percentile.hpp"
#include "hmdnode/render/lens.hpp"

namespace hmdnode {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

const fs::path kHeadsets = fs::path(HMDNODE_SOURCE_DIR) / "data" / "headsets";

std::string slurp(const fs::path& p) {
    Result<std::string> text = read_file(p);
    EXPECT_TRUE(text.ok()) << (text.ok() ? "" : text.error().message);
    return text.ok() ? *text : std::string();
}

HeadsetProfile index_profile() {
    Result<HeadsetProfile> p = headset_profile_from_openvr_config(
        slurp(kHeadsets / "valve-index.config.json"), "valve-index.config.json");
    EXPECT_TRUE(p.ok()) << (p.ok() ? "" : p.error().message);
    return p.ok() ? *p : HeadsetProfile{};
}

double rad_to_deg(double r) {
    return r * 180.0 / 3.14159265358979323846;
}

// Angle (deg) between the head-frame ray of tangent t and the unit direction axis.
double angle_from(glm::dvec2 t, glm::dvec3 axis) {
    const glm::dvec3 ray = glm::normalize(glm::dvec3(t, -1.0));
    return rad_to_deg(std::acos(std::clamp(glm::dot(ray, axis), -1.0, 1.0)));
}

// The eye's optical axis (eye frame -z) in the head-aligned frame.
glm::dvec3 eye_axis(const HeadsetProfile& p, int eye) {
    return p.eye[eye].eye_to_head * glm::dvec3(0.0, 0.0, -1.0);
}

// --- the Valve Index profile ---

TEST(LensIndex, ImportOfFactoryConfigEqualsStoredProfile) {
    const HeadsetProfile imported = index_profile();
    Result<HeadsetProfile> stored = load_headset_profile(kHeadsets / "valve-index.json");
    ASSERT_TRUE(stored.ok()) << stored.error().message;
    EXPECT_TRUE(imported == *stored);
    EXPECT_EQ(stored->name, "Valve Utah MP");
    EXPECT_EQ(stored->panel_width, 1440);
    EXPECT_EQ(stored->panel_height, 1600);
    for (int e = 0; e < 2; ++e) {
        EXPECT_EQ(stored->eye[e].model, LensModel::vive_dpoly3_scaled);
        EXPECT_DOUBLE_EQ(stored->eye[e].aspect_x_over_y, 0.9);
        EXPECT_DOUBLE_EQ(stored->eye[e].grow_for_undistort, 0.600000024);
    }
    // Displays canted 5 degrees outward: the left eye's axis points left, the right's right.
    EXPECT_NEAR(rad_to_deg(std::atan2(eye_axis(*stored, 0).x, -eye_axis(*stored, 0).z)), -5.0,
                1e-3);
    EXPECT_NEAR(rad_to_deg(std::atan2(eye_axis(*stored, 1).x, -eye_axis(*stored, 1).z)), 5.0, 1e-3);
    // Spot checks against the raw numbers: green is "distortion", red "distortion_red".
    EXPECT_EQ(stored->eye[0].channel[1].coeffs[0], -0.24167178347517976);
    EXPECT_EQ(stored->eye[1].channel[0].center.x, -0.012373697850175662);
    EXPECT_EQ(stored->eye[0].intrinsics[2][0], -0.017447073);  // row 0, column 2
}

// The documented formula (docs/lens-distortion.md), written out from the raw config JSON:
//   q = (2u-1-cx, (2v-1)/a - cy), r2 = q.q, d = 1/(1 + k1 r2 + k2 r2^2 + k3 r2^3) + k4,
//   g = q d + c, tx = (g.x + K02)/K00, ty = (-a g.y + K12)/K11 (K's last row is (0,0,-1)),
//   then the ray (tx, ty, -1) is multiplied by eye_to_head (rows as given) and re-projected.
TEST(LensIndex, ModelMatchesHandComputedFormula) {
    const json cfg = json::parse(slurp(kHeadsets / "valve-index.config.json"));
    const HeadsetProfile p = index_profile();
    const double a = 1440.0 / 1600.0;
    const char* names[3] = {"distortion_red", "distortion", "distortion_blue"};
    const glm::dvec2 points[] = {{0.5, 0.5}, {0.1, 0.3}, {0.8, 0.9}, {0.3, 0.05}, {0.97, 0.5}};
    for (int e = 0; e < 2; ++e) {
        const json& ej = cfg["tracking_to_eye_transform"][e];
        const json& K = ej["intrinsics"];
        ASSERT_EQ(K[2][0].get<double>(), 0.0);
        ASSERT_EQ(K[2][2].get<double>(), -1.0);
        const json& R = ej["eye_to_head"];
        for (glm::dvec2 uv : points) {
            const LensSample s = lens_sample(p, e, uv);
            EXPECT_TRUE(s.valid);
            for (int i = 0; i < 3; ++i) {
                const json& dj = ej[names[i]];
                const double cx = dj["center_x"], cy = dj["center_y"];
                const double k1 = dj["coeffs"][0], k2 = dj["coeffs"][1], k3 = dj["coeffs"][2],
                             k4 = dj["coeffs"][3];
                const double qx = 2.0 * uv.x - 1.0 - cx, qy = (2.0 * uv.y - 1.0) / a - cy;
                const double r2 = qx * qx + qy * qy;
                ASSERT_LT(r2, ej["undistort_r2_cutoff"].get<double>());
                const double d = 1.0 / (1.0 + k1 * r2 + k2 * r2 * r2 + k3 * r2 * r2 * r2) + k4;
                const double gx = qx * d + cx, gy = qy * d + cy;
                const double tx = (gx + K[0][2].get<double>()) / K[0][0].get<double>();
                const double ty = (-a * gy + K[1][2].get<double>()) / K[1][1].get<double>();
                double h[3];
                for (int r = 0; r < 3; ++r)
                    h[r] = R[r][0].get<double>() * tx + R[r][1].get<double>() * ty -
                           R[r][2].get<double>();
                EXPECT_NEAR(s.tangent[i].x, h[0] / -h[2], 1e-12) << "eye " << e << " ch " << i;
                EXPECT_NEAR(s.tangent[i].y, h[1] / -h[2], 1e-12) << "eye " << e << " ch " << i;
            }
        }
    }
}

TEST(LensIndex, LensCentreMapsToTheEyeAxisAndPanelCentreNearIt) {
    const HeadsetProfile p = index_profile();
    for (int e = 0; e < 2; ++e) {
        const glm::dvec3 axis = eye_axis(p, e);
        // The green lens centre on the panel: 2u-1 = cx, (2v-1)/a = cy.
        const LensChannel& g = p.eye[e].channel[1];
        const glm::dvec2 uv((1.0 + g.center.x) / 2.0, (1.0 + 0.9 * g.center.y) / 2.0);
        const LensSample s = lens_sample(p, e, uv);
        // note: K02 = -cx to the 8 digits the config stores, so the axis is hit to ~1e-6 deg.
        EXPECT_LT(angle_from(s.tangent[1], axis), 1e-4) << "eye " << e;
        // The panel centre is within a degree of the (canted) axis.
        EXPECT_LT(angle_from(lens_sample(p, e, {0.5, 0.5}).tangent[1], axis), 1.0);
        // The head-frame tangent of the axis is (-+tan 5 deg, 0).
        EXPECT_NEAR(s.tangent[1].x, (e == 0 ? -1.0 : 1.0) * std::tan(5.0 * 3.14159265358979 / 180),
                    1e-5);
        EXPECT_NEAR(s.tangent[1].y, 0.0, 1e-5);
    }
}

TEST(LensIndex, RadialMappingIsMonotonicUpToTheCutoff) {
    const HeadsetProfile p = index_profile();
    for (int e = 0; e < 2; ++e) {
        const glm::dvec3 axis = eye_axis(p, e);
        const LensChannel& g = p.eye[e].channel[1];
        const glm::dvec2 centre((1.0 + g.center.x) / 2.0, (1.0 + 0.9 * g.center.y) / 2.0);
        for (int k = 0; k < 24; ++k) {
            const double phi = 2.0 * 3.14159265358979 * k / 24;
            const glm::dvec2 dir(std::cos(phi), std::sin(phi));
            double prev[3] = {-1.0, -1.0, -1.0};
            int steps = 0;
            for (double r = 0.01;; r += 0.01) {
                const glm::dvec2 uv = centre + r * dir;
                if (uv.x < 0.0 || uv.x > 1.0 || uv.y < 0.0 || uv.y > 1.0) break;
                const LensSample s = lens_sample(p, e, uv);
                if (!s.valid) break;
                for (int i = 0; i < 3; ++i) {
                    const double ang = angle_from(s.tangent[i], axis);
                    EXPECT_GT(ang, prev[i]) << "eye " << e << " phi " << phi << " r " << r;
                    prev[i] = ang;
                }
                ++steps;
            }
            EXPECT_GT(steps, 40);
        }
    }
}

TEST(LensIndex, BlueBendsOutwardOfGreenAndRedInward) {
    const HeadsetProfile p = index_profile();
    for (int e = 0; e < 2; ++e) {
        const glm::dvec3 axis = eye_axis(p, e);
        for (glm::dvec2 uv : {glm::dvec2(0.02, 0.5), glm::dvec2(0.98, 0.5), glm::dvec2(0.5, 0.02),
                              glm::dvec2(0.2, 0.2), glm::dvec2(0.75, 0.85)}) {
            const LensSample s = lens_sample(p, e, uv);
            ASSERT_TRUE(s.valid);
            const double red = angle_from(s.tangent[0], axis);
            const double green = angle_from(s.tangent[1], axis);
            const double blue = angle_from(s.tangent[2], axis);
            EXPECT_LT(red, green);
            EXPECT_LT(green, blue);
            // Lateral chromatic aberration: a fraction of a degree to about a degree.
            EXPECT_GT(blue - red, 0.3);
            EXPECT_LT(blue - red, 2.0);
        }
    }
}

TEST(LensIndex, FieldOfViewMatchesPublishedFigures) {
    const HeadsetProfile p = index_profile();
    // Along the centre row and column: horizontal union of both eyes ~108 deg, vertical ~110.
    const double left = rad_to_deg(std::atan(lens_sample(p, 0, {0.0, 0.5}).tangent[1].x));
    const double right = rad_to_deg(std::atan(lens_sample(p, 1, {1.0, 0.5}).tangent[1].x));
    EXPECT_GT(right - left, 104.0);
    EXPECT_LT(right - left, 112.0);
    for (int e = 0; e < 2; ++e) {
        const double up = rad_to_deg(std::atan(lens_sample(p, e, {0.5, 0.0}).tangent[1].y));
        const double down = rad_to_deg(std::atan(lens_sample(p, e, {0.5, 1.0}).tangent[1].y));
        EXPECT_GT(up - down, 104.0);
        EXPECT_LT(up - down, 114.0);
        // The stored fov is Monado's render FOV: intrinsics / (1 + grow), ~103.5 x 109 deg.
        const EyeFov& f = p.eye[e].fov;
        const double s = 1.0 + p.eye[e].grow_for_undistort;
        EXPECT_NEAR(f.tan_right - f.tan_left, 2.0 * s / p.eye[e].intrinsics[0][0], 1e-12);
        EXPECT_NEAR(f.tan_up - f.tan_down, 2.0 * s / p.eye[e].intrinsics[1][1], 1e-12);
        const double h = rad_to_deg(std::atan(f.tan_right) - std::atan(f.tan_left));
        EXPECT_NEAR(h, 103.5, 0.5);
    }
}

TEST(LensIndex, OutsideTheCutoffIsInvalidAndClampedOnTheCutoffCircle) {
    const HeadsetProfile p = index_profile();
    const EyeLens& lens = p.eye[0];
    const glm::dvec2 corner(0.0, 0.0);
    const LensSample s = lens_sample(p, 0, corner);
    EXPECT_FALSE(s.valid);
    for (int i = 0; i < 3; ++i) {
        const glm::dvec2 c = lens.channel[i].center;
        glm::dvec2 q(2.0 * corner.x - 1.0 - c.x, (2.0 * corner.y - 1.0) / 0.9 - c.y);
        ASSERT_GT(glm::dot(q, q), lens.undistort_r2_cutoff);
        q *= std::sqrt(lens.undistort_r2_cutoff / glm::dot(q, q)) * (1.0 - 1e-12);
        const glm::dvec2 on_circle((q.x + c.x + 1.0) / 2.0, ((q.y + c.y) * 0.9 + 1.0) / 2.0);
        const LensSample t = lens_sample(p, 0, on_circle);
        EXPECT_NEAR(t.tangent[i].x, s.tangent[i].x, 1e-9);
        EXPECT_NEAR(t.tangent[i].y, s.tangent[i].y, 1e-9);
    }
}

// --- the mesh ---

TEST(LensMesh, VerticesEqualLensSampleExactly) {
    const HeadsetProfile p = index_profile();
    for (int e = 0; e < 2; ++e) {
        const DistortionMesh m = make_distortion_mesh(p, e, 64, 48);
        ASSERT_EQ(m.vertices.size(), size_t(65 * 49));
        ASSERT_EQ(m.valid.size(), m.vertices.size());
        ASSERT_EQ(m.indices.size(), size_t(6 * 64 * 48));
        for (uint32_t i : m.indices) ASSERT_LT(i, m.vertices.size());
        int invalid = 0;
        for (int r = 0; r <= 48; ++r) {
            for (int c = 0; c <= 64; ++c) {
                const DistortionVertex& v = m.vertices[size_t(r) * 65 + c];
                const glm::dvec2 uv(double(c) / 64, double(r) / 48);
                EXPECT_EQ(v.ndc, glm::vec2(2.0 * uv - 1.0));
                const LensSample s = lens_sample(p, e, uv);
                for (int ch = 0; ch < 3; ++ch) EXPECT_EQ(v.tangent[ch], glm::vec2(s.tangent[ch]));
                EXPECT_EQ(m.valid[size_t(r) * 65 + c], s.valid ? 1 : 0);
                invalid += s.valid ? 0 : 1;
                // The rasteriser's interpolation returns the vertex exactly at the vertex.
                const LensSample at = sample_distortion_mesh(m, uv);
                for (int ch = 0; ch < 3; ++ch) EXPECT_EQ(glm::vec2(at.tangent[ch]), v.tangent[ch]);
            }
        }
        EXPECT_GT(invalid, 0);  // the corners lie beyond undistort_r2_cutoff
        EXPECT_EQ(m.vertices.front().ndc, glm::vec2(-1.0f, -1.0f));
        EXPECT_EQ(m.vertices.back().ndc, glm::vec2(1.0f, 1.0f));
    }
}

TEST(LensMesh, InterpolationIsLinearOverTheDocumentedTriangles) {
    // A mesh of a linear map (model none) is reproduced exactly in between, on either side of the
    // diagonal; that fixes the weights, and a swapped diagonal would break the next test's bound.
    HeadsetProfile p = generic_headset_profile();
    p.eye[0].model = LensModel::none;
    const DistortionMesh m = make_distortion_mesh(p, 0, 8, 8);
    for (glm::dvec2 uv : {glm::dvec2(0.31, 0.27), glm::dvec2(0.27, 0.31), glm::dvec2(0.9, 0.05)}) {
        const LensSample a = sample_distortion_mesh(m, uv), b = lens_sample(p, 0, uv);
        EXPECT_NEAR(a.tangent[1].x, b.tangent[1].x, 1e-6);
        EXPECT_NEAR(a.tangent[1].y, b.tangent[1].y, 1e-6);
    }
    // Triangle list: cell (c, r) is v00 v10 v11, v00 v11 v01.
    EXPECT_EQ(m.indices[0], 0u);
    EXPECT_EQ(m.indices[1], 1u);
    EXPECT_EQ(m.indices[2], 10u);
    EXPECT_EQ(m.indices[3], 0u);
    EXPECT_EQ(m.indices[4], 10u);
    EXPECT_EQ(m.indices[5], 9u);
}

// Error of the 64x64 mesh against the model, in panel-equivalent pixels of the Index's 1440x1600
// panel: the tangent error mapped back through the inverse of the model's local Jacobian (tangent
// per pixel, central differences), i.e. how far on the panel the mesh's colour comes from.
// Points: every cell centre plus 20000 random points; only where the triangle and the model are
// valid (inside undistort_r2_cutoff). Measured figures are in docs/lens-distortion.md.
TEST(LensMesh, InterpolationErrorOfIndex64x64IsBelowBound) {
    const HeadsetProfile p = index_profile();
    const double W = p.panel_width, H = p.panel_height;
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    std::vector<double> errors;
    double max_arcmin = 0.0, worst_px = 0.0;
    glm::dvec2 worst_uv(0.0);
    for (int e = 0; e < 2; ++e) {
        const DistortionMesh m = make_distortion_mesh(p, e, 64, 64);
        std::vector<glm::dvec2> points;
        for (int r = 0; r < 64; ++r)
            for (int c = 0; c < 64; ++c) points.emplace_back((c + 0.5) / 64, (r + 0.5) / 64);
        for (int k = 0; k < 20000; ++k) points.emplace_back(unit(rng), unit(rng));
        for (glm::dvec2 uv : points) {
            const LensSample mesh = sample_distortion_mesh(m, uv);
            const LensSample exact = lens_sample(p, e, uv);
            const double h = 0.25;  // pixels
            const LensSample xp = lens_sample(p, e, uv + glm::dvec2(h / W, 0.0));
            const LensSample xm = lens_sample(p, e, uv - glm::dvec2(h / W, 0.0));
            const LensSample yp = lens_sample(p, e, uv + glm::dvec2(0.0, h / H));
            const LensSample ym = lens_sample(p, e, uv - glm::dvec2(0.0, h / H));
            if (!mesh.valid || !exact.valid || !xp.valid || !xm.valid || !yp.valid || !ym.valid)
                continue;
            double worst = 0.0;
            for (int ch = 0; ch < 3; ++ch) {
                const glm::dmat2 J((xp.tangent[ch] - xm.tangent[ch]) / (2.0 * h),
                                   (yp.tangent[ch] - ym.tangent[ch]) / (2.0 * h));
                const glm::dvec2 px = glm::inverse(J) * (mesh.tangent[ch] - exact.tangent[ch]);
                worst = std::max(worst, glm::length(px));
                const glm::dvec3 a = glm::normalize(glm::dvec3(mesh.tangent[ch], -1.0));
                const glm::dvec3 b = glm::normalize(glm::dvec3(exact.tangent[ch], -1.0));
                max_arcmin = std::max(max_arcmin, 60.0 * rad_to_deg(glm::length(glm::cross(a, b))));
            }
            if (worst > worst_px) worst_px = worst, worst_uv = uv;
            errors.push_back(worst);
        }
    }
    ASSERT_GT(errors.size(), size_t(30000));
    std::sort(errors.begin(), errors.end());
    const double max_px = errors.back();
    const double p99_px = percentile_sorted(errors, 0.99);
    std::cout << "Index 64x64 mesh interpolation error (panel px): max " << max_px << ", p99 "
              << p99_px << ", median " << percentile_sorted(errors, 0.5) << ", points "
              << errors.size() << "; max angle " << max_arcmin << " arcmin; worst at uv ("
              << worst_uv.x << ", " << worst_uv.y << ")\n";
    RecordProperty("max_px", std::to_string(max_px));
    RecordProperty("p99_px", std::to_string(p99_px));
    EXPECT_LT(max_px, 2.5);
    EXPECT_LT(p99_px, 1.5);
}

// The runtime's default mesh: the coarsest whose error stays within 0.5 panel pixels. Prints the
// error by mesh size (the table in docs/lens-distortion.md).
TEST(LensMesh, ChosenMeshIsTheCoarsestWithinHalfAPixel) {
    const HeadsetProfile profiles[] = {generic_headset_profile(), index_profile()};
    for (const HeadsetProfile& p : profiles)
        for (int w : {360, 1440}) {
            const int h = w * 10 / 9;
            const int chosen = choose_mesh_cells(p, w, h, 0.5);
            for (int n : {8, 12, 16, 24, 32, 48, 64, 96, 128}) {
                double max_px = 0.0, p99_px = 0.0;
                for (int e = 0; e < 2; ++e) {
                    const MeshError err =
                        mesh_interpolation_error(p, e, make_distortion_mesh(p, e, n, n), w, h);
                    max_px = std::max(max_px, err.max_px);
                    p99_px = std::max(p99_px, err.p99_px);
                }
                std::cout << p.name << " " << w << "x" << h << " mesh " << n << ": max " << max_px
                          << " px, p99 " << p99_px << " px" << (n == chosen ? "  <- chosen" : "")
                          << "\n";
                if (n == chosen) {
                    EXPECT_LE(max_px, 0.5);
                }
                if (n < chosen) {
                    EXPECT_GT(max_px, 0.5);
                }
            }
        }
    EXPECT_EQ(choose_mesh_cells(generic_headset_profile(), 360, 400, 0.5), 24);
    EXPECT_EQ(choose_mesh_cells(index_profile(), 360, 400, 0.5), 48);
}

// --- the render FOV ---

// --- the fused pass's per-pixel model (render/src/lens_pass.hpp) ---

// What the fused shader computes, mirrored on the CPU in float: at every pixel centre of both
// eyes, every channel's direction (through eye_to_head) is lens_sample()'s to a thousandth of a
// pixel, clamped regions included, where the mesh the node would choose is off by up to half a
// pixel.
void check_lens_pass(const HeadsetProfile& profile, int w, int h) {
    auto setup = gpu::make_lens_pass_setup(profile, w, h);
    ASSERT_TRUE(setup.ok()) << setup.error().message;
    const double tangent_per_px =
        (profile.eye[0].fov.tan_right - profile.eye[0].fov.tan_left) / double(w);
    double worst_px = 0.0;
    for (int e = 0; e < 2; ++e)
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x) {
                const glm::dvec2 uv((x + 0.5) / w, (y + 0.5) / h);
                const LensSample ref = lens_sample(profile, e, uv);
                for (int c = 0; c < 3; ++c) {
                    const glm::vec3 d = setup->eye[e].eye_to_head *
                                        gpu::lens_pass_direction(setup->eye[e], c, glm::vec2(uv));
                    ASSERT_LT(d.z, 0.0f) << "eye " << e << " pixel " << x << "," << y;
                    const glm::dvec2 t = glm::dvec2(d.x, d.y) / double(-d.z);
                    worst_px = std::max(worst_px, glm::length(t - ref.tangent[c]) / tangent_per_px);
                }
            }
    EXPECT_LT(worst_px, 1e-3) << profile.name;
}

TEST(LensPass, TheGenericModelPerPixelEqualsLensSample) {
    check_lens_pass(generic_headset_profile(), 360, 400);
    EXPECT_TRUE(gpu::make_lens_pass_setup(generic_headset_profile(), 8, 8)->chromatic);
}

TEST(LensPass, TheIndexModelPerPixelEqualsLensSampleBeyondItsCutoffToo) {
    const HeadsetProfile index = index_profile();
    check_lens_pass(index, 360, 400);
    // The Index's cutoff is reached on this panel: the pass clamps there as lens_sample does.
    bool clamped = false;
    for (int y = 0; y < 400 && !clamped; y += 4)
        for (int x = 0; x < 360 && !clamped; x += 4)
            clamped = !lens_sample(index, 0, glm::dvec2((x + 0.5) / 360, (y + 0.5) / 400)).valid;
    EXPECT_TRUE(clamped);
}

TEST(LensPass, AProfileWithoutAberrationNeedsOneSampleAndBadInputIsRefused) {
    HeadsetProfile flat;
    flat.name = "flat";
    flat.panel_width = 100;
    flat.panel_height = 100;
    for (EyeLens& l : flat.eye) l.model = LensModel::none;
    auto setup = gpu::make_lens_pass_setup(flat, 100, 100);
    ASSERT_TRUE(setup.ok()) << setup.error().message;
    EXPECT_FALSE(setup->chromatic);
    check_lens_pass(flat, 64, 64);
    EXPECT_FALSE(gpu::make_lens_pass_setup(flat, 0, 10).ok());
}

TEST(LensFov, RenderFovContainsEveryMeshTangent) {
    for (const HeadsetProfile& p : {index_profile(), generic_headset_profile()}) {
        for (int e = 0; e < 2; ++e) {
            const DistortionMesh m = make_distortion_mesh(p, e);
            const EyeFov f = lens_render_fov(p, e);
            bool touches[4] = {false, false, false, false};
            for (const DistortionVertex& v : m.vertices) {
                for (const glm::vec2& t : v.tangent) {
                    EXPECT_GE(t.x, f.tan_left);
                    EXPECT_LE(t.x, f.tan_right);
                    EXPECT_GE(t.y, f.tan_down);
                    EXPECT_LE(t.y, f.tan_up);
                    touches[0] |= t.x == f.tan_left, touches[1] |= t.x == f.tan_right;
                    touches[2] |= t.y == f.tan_up, touches[3] |= t.y == f.tan_down;
                }
            }
            for (bool b : touches) EXPECT_TRUE(b) << p.name << " eye " << e << ": not smallest";
        }
    }
}

TEST(LensFov, MarginGrowsEachSideByAFractionOfTheSize) {
    const HeadsetProfile p = index_profile();
    const EyeFov f = lens_render_fov(p, 1);
    const EyeFov g = lens_render_fov(p, 1, 0.1);
    const double w = f.tan_right - f.tan_left, h = f.tan_up - f.tan_down;
    EXPECT_NEAR(g.tan_left, f.tan_left - 0.1 * w, 1e-12);
    EXPECT_NEAR(g.tan_right, f.tan_right + 0.1 * w, 1e-12);
    EXPECT_NEAR(g.tan_up, f.tan_up + 0.1 * h, 1e-12);
    EXPECT_NEAR(g.tan_down, f.tan_down - 0.1 * h, 1e-12);
    // Index per eye, head-aligned: about 110 x 118 deg (the valid panel up to the cutoff).
    EXPECT_NEAR(rad_to_deg(std::atan(f.tan_right) - std::atan(f.tan_left)), 110.0, 3.0);
    EXPECT_NEAR(rad_to_deg(std::atan(f.tan_up) - std::atan(f.tan_down)), 118.0, 3.0);
}

// --- the generic profile, save / load ---

TEST(LensGeneric, BuiltInEqualsFileAndRoundTrips) {
    const HeadsetProfile g = generic_headset_profile();
    Result<HeadsetProfile> file = load_headset_profile(kHeadsets / "generic.json");
    ASSERT_TRUE(file.ok()) << file.error().message;
    EXPECT_TRUE(*file == g);
    EXPECT_EQ(headset_profile_to_json(g), slurp(kHeadsets / "generic.json"));

    const fs::path tmp = fs::path(testing::TempDir()) / "hmdnode_lens_generic.json";
    ASSERT_TRUE(save_headset_profile(g, tmp).ok());
    Result<HeadsetProfile> back = load_headset_profile(tmp);
    ASSERT_TRUE(back.ok()) << back.error().message;
    EXPECT_TRUE(*back == g);
    // A changed field is seen by the comparison.
    HeadsetProfile changed = g;
    changed.eye[1].channel[2].coeffs[1] += 1e-15;
    EXPECT_FALSE(changed == g);
    fs::remove(tmp);
}

TEST(LensGeneric, IsABarrelPredistortionWithSmallChromaticAberration) {
    const HeadsetProfile g = generic_headset_profile();
    for (int e = 0; e < 2; ++e) {
        const EyeFov f = lens_render_fov(g, e);
        const double h = rad_to_deg(std::atan(f.tan_right) - std::atan(f.tan_left));
        EXPECT_GT(h, 95.0);
        EXPECT_LT(h, 110.0);
        // Pincushion lens, so panel edges see further out than the paraxial rectangle.
        const LensSample edge = lens_sample(g, e, {0.5, 0.0});
        EXPECT_GT(edge.tangent[1].y, g.eye[e].fov.tan_up * 1.2);
        const double ca = rad_to_deg(std::atan(edge.tangent[2].y) - std::atan(edge.tangent[0].y));
        EXPECT_GT(ca, 0.2);
        EXPECT_LT(ca, 0.8);
    }
}

// --- errors ---

std::string profile_error(const std::string& text) {
    Result<HeadsetProfile> p = parse_headset_profile(text, "test.json");
    EXPECT_FALSE(p.ok());
    return p.ok() ? std::string() : p.error().message;
}

json generic_json() {
    return json::parse(headset_profile_to_json(generic_headset_profile()));
}

TEST(LensErrors, MissingFileNamesTheFile) {
    Result<HeadsetProfile> p = load_headset_profile(kHeadsets / "no-such-headset.json");
    ASSERT_FALSE(p.ok());
    EXPECT_NE(p.error().message.find("no-such-headset.json"), std::string::npos);
}

TEST(LensErrors, BadJsonNamesTheFile) {
    const fs::path tmp = fs::path(testing::TempDir()) / "hmdnode_lens_bad.json";
    ASSERT_TRUE(write_file_atomically(tmp, "{\"version\": 1, \"name\": ").ok());
    Result<HeadsetProfile> p = load_headset_profile(tmp);
    ASSERT_FALSE(p.ok());
    EXPECT_NE(p.error().message.find("hmdnode_lens_bad.json: not valid JSON"), std::string::npos)
        << p.error().message;
    fs::remove(tmp);
}

TEST(LensErrors, MissingAndWrongTypedFieldsNameTheirPath) {
    json j = generic_json();
    j["eye"][1]["channel"].erase("blue");
    EXPECT_EQ(profile_error(j.dump()), "test.json: eye[1].channel.blue: missing");

    j = generic_json();
    j["eye"][1]["channel"]["red"]["coeffs"] = {1.0, 0.2, 0.0};
    EXPECT_EQ(profile_error(j.dump()), "test.json: eye[1].channel.red.coeffs: expected 4 numbers");

    j = generic_json();
    j["eye"][0]["fov"]["tan_up"] = "up";
    EXPECT_EQ(profile_error(j.dump()), "test.json: eye[0].fov.tan_up: expected a number");

    j = generic_json();
    j["panel_width"] = 1080.5;
    EXPECT_EQ(profile_error(j.dump()), "test.json: panel_width: expected an integer");

    j = generic_json();
    j.erase("name");
    EXPECT_EQ(profile_error(j.dump()), "test.json: name: missing");

    j = generic_json();
    j["eye"][0]["fov_typo"] = 1;
    EXPECT_EQ(profile_error(j.dump()), "test.json: eye[0].fov_typo: unknown field");
}

TEST(LensErrors, NonFiniteCoefficientIsRejected) {
    // JSON has no NaN or infinity; a number beyond a double is refused by the parser, naming
    // the file and the number.
    std::string text = generic_json().dump();
    const std::string needle = "1.008";  // blue k0 of both eyes
    text.replace(text.find(needle), needle.size(), "1e999");
    const std::string msg = profile_error(text);
    EXPECT_EQ(msg.rfind("test.json: not valid JSON", 0), 0u) << msg;
    EXPECT_NE(msg.find("1e999"), std::string::npos) << msg;
    // An in-memory NaN is refused by save, naming the field, and writes nothing.
    HeadsetProfile g = generic_headset_profile();
    g.eye[1].channel[0].coeffs[2] = std::nan("");
    const fs::path tmp = fs::path(testing::TempDir()) / "hmdnode_lens_nan.json";
    const Status s = save_headset_profile(g, tmp);
    ASSERT_FALSE(s.ok());
    EXPECT_NE(s.error().message.find("eye[1].channel.red.coeffs: not finite"), std::string::npos)
        << s.error().message;
    EXPECT_FALSE(fs::exists(tmp));
}

TEST(LensErrors, EyeCountMustBeTwo) {
    json j = generic_json();
    j["eye"].push_back(j["eye"][0]);
    EXPECT_EQ(profile_error(j.dump()), "test.json: eye: expected 2 eyes, got 3");
    json c = json::parse(slurp(kHeadsets / "valve-index.config.json"));
    c["tracking_to_eye_transform"].erase(1);
    Result<HeadsetProfile> p = headset_profile_from_openvr_config(c.dump(), "cfg.json");
    ASSERT_FALSE(p.ok());
    EXPECT_EQ(p.error().message, "cfg.json: tracking_to_eye_transform: expected 2 eyes, got 1");
}

TEST(LensErrors, UnknownModelIsRejected) {
    json j = generic_json();
    j["eye"][1]["model"] = "fisheye";
    EXPECT_NE(profile_error(j.dump()).find("test.json: eye[1].model: unknown model \"fisheye\""),
              std::string::npos);
    json c = json::parse(slurp(kHeadsets / "valve-index.config.json"));
    c["tracking_to_eye_transform"][0]["distortion_blue"]["type"] = "DISTORT_POLY3";
    Result<HeadsetProfile> p = headset_profile_from_openvr_config(c.dump(), "cfg.json");
    ASSERT_FALSE(p.ok());
    EXPECT_NE(p.error().message.find(
                  "cfg.json: tracking_to_eye_transform[0].distortion_blue.type: unsupported"),
              std::string::npos)
        << p.error().message;
}

TEST(LensErrors, OpenVrConfigFieldErrorsNameThePath) {
    json c = json::parse(slurp(kHeadsets / "valve-index.config.json"));
    c["tracking_to_eye_transform"][1].erase("intrinsics");
    Result<HeadsetProfile> p = headset_profile_from_openvr_config(c.dump(), "cfg.json");
    ASSERT_FALSE(p.ok());
    EXPECT_EQ(p.error().message, "cfg.json: tracking_to_eye_transform[1].intrinsics: missing");

    c = json::parse(slurp(kHeadsets / "valve-index.config.json"));
    c["tracking_to_eye_transform"][0]["distortion"]["coeffs"][1] = "x";
    p = headset_profile_from_openvr_config(c.dump(), "cfg.json");
    ASSERT_FALSE(p.ok());
    EXPECT_EQ(p.error().message,
              "cfg.json: tracking_to_eye_transform[0].distortion.coeffs[1]: expected a number");

    p = headset_profile_from_openvr_config("[1, 2", "cfg.json");
    ASSERT_FALSE(p.ok());
    EXPECT_EQ(p.error().message.rfind("cfg.json: not valid JSON", 0), 0u);
}

}  // namespace
}  // namespace hmdnode
