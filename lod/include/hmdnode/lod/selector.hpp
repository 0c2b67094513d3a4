// Runtime level-of-detail selection by projected geometric error against a perceptual tolerance
// (display pixel, acuity at the eccentricity, motion smear during a head turn), with hysteresis
// (docs/lod-selection.md has the formula, its sources and its defaults).
//
// Threads: one LodSelector belongs to the frame thread. select() neither allocates nor locks.
#pragma once

#include <cstddef>
#include <span>
#include <vector>

#include <glm/glm.hpp>

namespace hmdnode {

// The tolerance model (docs/lod-selection.md): the largest of what the display, the eye's acuity
// at the object's eccentricity and the smear of a head turn during the persistence let one see.
struct LodSelectorParams {
    double tolerance_px = 1.0;  // tau0: the display's floor (detail below a pixel is not shown)
    // Minimum angle of resolution MAR(e) = mar0 + slope * e, degrees (Guenter et al. 2012,
    // "Foveated 3D graphics": mar0 = 1/48 degree, slope 0.022-0.034; the lower, conservative end).
    double mar0_deg = 1.0 / 48.0;
    double mar_slope = 0.022;
    double persistence_s = 0.002;  // how long a pixel glows; the frame loop sets the display's
    double max_widening = 64.0;    // cap on tau / tau0
    double hysteresis = 0.25;      // h: a coarser level must fit within tau * (1 - h)
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
    glm::dvec3 gaze_direction{0, 0, -1};  // world, unit: the lens centre (head forward) or a gaze
    double angular_speed_dps = 0.0;       // head angular speed
    double pixels_per_radian = 500.0;     // at the centre of the eye image
    double near_m = 0.05;
};

struct LodDecision {
    int level = 0;
    double eccentricity_deg = 0.0;
    double tolerance_px = 0.0;
    double projected_error_px = 0.0;  // of the chosen level
    double distance_m = 0.0;          // eye to the bounding sphere's nearest point (>= near)
};

class LodSelector {
  public:
    explicit LodSelector(size_t object_count, const LodSelectorParams& params = {});

    // tau = min(tau0 * max_widening, max(tau0, MAR(theta) * ppd, omega * persistence * ppd)),
    // ppd = pixels_per_radian * pi / 180.
    static double tolerance_px(const LodSelectorParams& p, double eccentricity_deg,
                               double speed_dps, double pixels_per_radian);
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
