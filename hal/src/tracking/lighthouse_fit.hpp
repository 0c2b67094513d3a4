// Private to hal: the two numerical cores the lighthouse pose solver and the base-station placement
// share (docs/tracking.md §10). lighthouse_pnp.cpp: the PnP seed; lighthouse_lsq.cpp: the
// Levenberg-Marquardt refinement on calibrated angle residuals with outlier rejection.
#pragma once

#include <array>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "hmdnode/hal/codec/light_codec.hpp"
#include "hmdnode/hal/tracking/lighthouse_solver.hpp"

namespace hmdnode::lighthouse::detail {

// One angle in a fit of a transform X (source -> target): the base station sees the point at
// q = outer_r * (X * point) + outer_t (its own frame).
struct FitAngle {
    glm::dvec3 point{0.0};   // source frame
    glm::dvec3 normal{0.0};  // source frame; zero: no facing check
    glm::dmat3 outer_r{1.0};
    glm::dvec3 outer_t{0.0};
    PlaneCalibration cal{};
    Generation generation = Generation::lh2;
    int plane = 0;
    double angle = 0;
    int station = 0;  // the caller's index
    int sensor = 0;
    int64_t device_time_ns = 0;
    double dt_s = 0;  // its time - the fit's reference time (the velocity model's lever)
    enum class State : uint8_t { used, outlier, facing_away } state = State::used;
};

// The calibrated model's angle for a point in the base station's frame.
double predict_angle(const FitAngle& a, const glm::dvec3& q);

struct FitResult {
    bool enough = false;  // enough angles and sensors, and all six degrees of freedom observable
    std::string why;      // when not
    RigidPose pose;
    glm::dvec3 velocity{0.0}, angular_velocity{0.0};  // target frame; zero without the model
    bool moving = false;                              // fitted with the velocity model
    double rms = 0;
    size_t used = 0, outliers = 0, facing_away = 0;
    int iterations = 0;
    std::array<double, 36> covariance{};
};

// Levenberg-Marquardt from `start`, then the k-sigma outlier rounds (SolverOptions); marks each
// angle's state. `velocity`: also a constant linear and angular velocity over the angles' times
// (dt_s), under a weak prior (SolverOptions::velocity_prior_*). Cost: O(angles) per iteration.
FitResult fit_pose(std::vector<FitAngle>& angles, const RigidPose& start,
                   const SolverOptions& options, bool velocity = false);

// Perspective-n-point by orthogonal iteration (Lu, Hager & Mjolsness, "Fast and globally
// convergent pose estimation from video images", IEEE PAMI 22(6), 2000): the transform taking
// `points` (source frame) onto the unit `rays` (camera frame), from 24 starts; the solution
// with the fewest points behind the camera or facing away from it (normals, may be empty), then
// the least object-space error. Up to three stray rays are left out (the one missed most, when
// over 5x the median miss and 20 mrad) and the pose solved again. Needs >= 3 points.
// Cost: O(24 * 50 * n) per try, <= 4 tries.
std::optional<RigidPose> pnp_orthogonal_iteration(std::span<const glm::dvec3> points,
                                                  std::span<const glm::dvec3> rays,
                                                  std::span<const glm::dvec3> normals,
                                                  double max_incidence_rad);

}  // namespace hmdnode::lighthouse::detail
