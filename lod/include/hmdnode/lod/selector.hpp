// Runtime level-of-detail selection by projected geometric error, widened by eccentricity and by
// head angular speed, with hysteresis (docs/lod-selection.md has the formula and its defaults).
//
// Threads: one LodSelector belongs to the frame thread. select() neither allocates nor locks.
#pragma once

#include <cstddef>
#include <span>
#include <vector>

#include <glm/glm.hpp>

namespace hmdnode {

struct LodSelectorParams {
    double tolerance_px = 1.0;        // tau0: allowed projected error at the gaze point, still head
    double foveal_deg = 5.0;          // theta0: no widening within this eccentricity
    double eccentricity_gain = 0.15;  // k_e: widening per degree beyond theta0
    double speed_threshold_dps = 15.0;  // omega0: no widening below this head speed
    double speed_gain = 0.03;           // k_w: widening per deg/s beyond omega0
    double max_widening = 64.0;         // cap on the product of both widenings
    double hysteresis = 0.25;           // h: a coarser level must fit within tau * (1 - h)
};

// One object as the selector sees it this frame.
struct LodObjectView {
    glm::dvec3 center{0.0};  // world bounding sphere
    double radius = 0.0;
    std::span<const double>
        level_errors_m;  // geometric error of each level, world metres, level 0 finest
};

// The viewer this frame.
struct LodViewer {
    glm::dvec3 eye_position{0.0};         // world
    glm::dvec3 gaze_direction{0, 0, -1};  // world, unit: head forward or an eye tracker's gaze
    double angular_speed_dps = 0.0;       // head angular speed
    double pixels_per_radian = 500.0;     // at the centre of the eye image
    double near_m = 0.05;
};

struct LodDecision {
    int level = 0;
    double eccentricity_deg = 0.0;
    double tolerance_px = 0.0;
    double projected_error_px = 0.0;  // of the chosen level
};

class LodSelector {
  public:
    explicit LodSelector(size_t object_count, const LodSelectorParams& params = {});

    // tau = tau0 * min(max_widening, (1 + k_e * max(0, theta - theta0)) * (1 + k_w * max(0, omega -
    // omega0)))
    static double tolerance_px(const LodSelectorParams& p, double eccentricity_deg,
                               double speed_dps);
    // Projected error in pixels of a level with error e at distance d: e / d * pixels_per_radian.
    static double projected_error_px(double error_m, double distance_m, double pixels_per_radian);

    // Picks the level of object `index` for this frame and remembers it for hysteresis.
    LodDecision select(size_t index, const LodObjectView& object, const LodViewer& viewer);

    int current_level(size_t index) const { return current_[index]; }
    const LodSelectorParams& params() const { return params_; }
    void reset();

  private:
    LodSelectorParams params_;
    std::vector<int> current_;  // -1: not selected yet
};

}  // namespace hmdnode
