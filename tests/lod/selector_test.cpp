#include <gtest/gtest.h>

#include <cmath>

#include "hmdnode/lod/selector.hpp"

using namespace hmdnode;

namespace {

// Levels whose errors double: 0, 1 mm, 2 mm, 4 mm, 8 mm, 16 mm.
const double kErrors[] = {0.0, 0.001, 0.002, 0.004, 0.008, 0.016};

LodObjectView object_at(glm::dvec3 c) {
    return LodObjectView{c, 0.1, kErrors};
}

LodViewer viewer(double speed_dps = 0.0) {
    LodViewer v;
    v.eye_position = glm::dvec3(0.0);
    v.gaze_direction = glm::dvec3(0, 0, -1);
    v.angular_speed_dps = speed_dps;
    v.pixels_per_radian = 300.0;
    return v;
}

glm::dvec3 at_angle(double deg, double dist) {
    const double r = deg * 3.14159265358979323846 / 180.0;
    return {dist * std::sin(r), 0.0, -dist * std::cos(r)};
}

}  // namespace

TEST(LodSelector, PicksTheCoarsestLevelWithinTheProjectedTolerance) {
    LodSelector sel(1);
    // 2.1 m to the sphere's surface: 1 px = 7 mm; level 3 (4 mm -> 0.57 px) fits, level 4 (1.14 px)
    // not.
    LodDecision d = sel.select(0, object_at({0, 0, -2.2}), viewer());
    EXPECT_EQ(d.level, 3);
    EXPECT_NEAR(d.projected_error_px, 0.004 / 2.1 * 300.0, 1e-9);
    EXPECT_NEAR(d.tolerance_px, 1.0, 1e-12);
}

TEST(LodSelector, LevelRisesAsTheObjectMovesOffCentre) {
    int last = -1;
    for (double deg = 0; deg <= 60; deg += 5) {
        LodSelector sel(1);
        int level = sel.select(0, object_at(at_angle(deg, 1.0)), viewer()).level;
        EXPECT_GE(level, last) << "at " << deg << " deg";
        last = level;
    }
    LodSelector a(1), b(1);
    EXPECT_LT(a.select(0, object_at(at_angle(0, 1.0)), viewer()).level,
              b.select(0, object_at(at_angle(60, 1.0)), viewer()).level);
}

TEST(LodSelector, LevelRisesWithHeadAngularSpeed) {
    int last = -1;
    for (double dps = 0; dps <= 300; dps += 20) {
        LodSelector sel(1);
        int level = sel.select(0, object_at({0, 0, -1.0}), viewer(dps)).level;
        EXPECT_GE(level, last) << "at " << dps << " deg/s";
        last = level;
    }
    LodSelector a(1), b(1);
    EXPECT_LT(a.select(0, object_at({0, 0, -1.0}), viewer(0)).level,
              b.select(0, object_at({0, 0, -1.0}), viewer(200)).level);
}

// tau = min(tau0 * W, max(tau0, (mar0 + slope * e) * ppd, omega * persistence * ppd)).
TEST(LodSelector, ToleranceFormula) {
    LodSelectorParams p;
    const double ppr = 300.0, ppd = ppr * 3.14159265358979323846 / 180.0;  // 5.236 px per degree
    // In the fovea and still: the display's pixel (acuity 1/48 degree is 0.11 px here).
    EXPECT_DOUBLE_EQ(LodSelector::tolerance_px(p, 0.0, 0.0, ppr), p.tolerance_px);
    // At 30 degrees the eye resolves (1/48 + 0.022 * 30) degrees = 0.681 degrees = 3.57 px.
    EXPECT_NEAR(LodSelector::tolerance_px(p, 30.0, 0.0, ppr), (1.0 / 48.0 + 0.66) * ppd, 1e-12);
    // A 200 deg/s turn smears 200 * 0.002 = 0.4 degrees during the 2 ms persistence: 2.09 px.
    EXPECT_NEAR(LodSelector::tolerance_px(p, 0.0, 200.0, ppr), 0.4 * ppd, 1e-12);
    // The larger of the two, not their product.
    EXPECT_NEAR(LodSelector::tolerance_px(p, 30.0, 200.0, ppr), (1.0 / 48.0 + 0.66) * ppd, 1e-12);
    EXPECT_DOUBLE_EQ(LodSelector::tolerance_px(p, 1e6, 1e6, ppr), p.tolerance_px * p.max_widening);
    LodSelectorParams blur_off = p;
    blur_off.persistence_s = 0.0;
    EXPECT_DOUBLE_EQ(LodSelector::tolerance_px(blur_off, 0.0, 500.0, ppr), p.tolerance_px);
}

// Where acuity, not the pixel, limits what one sees (off the gaze), a sharper panel needs no more
// detail: the tolerance in pixels grows with the pixels per degree as the projected errors do.
// In the fovea the pixel limits, so the sharper panel gets finer levels there.
TEST(LodSelector, PeripheryNeedsNoMoreDetailOnASharperPanel) {
    auto level_at = [](double deg, double ppr) {
        LodSelector sel(1);
        LodViewer v = viewer();
        v.pixels_per_radian = ppr;
        return sel.select(0, object_at(at_angle(deg, 1.0)), v).level;
    };
    for (double deg : {30.0, 45.0}) EXPECT_EQ(level_at(deg, 300.0), level_at(deg, 1200.0)) << deg;
    EXPECT_LT(level_at(0.0, 1200.0), level_at(0.0, 300.0));
}

TEST(LodSelector, DoesNotFlickerAroundAThreshold) {
    // Distance at which level 3 projects to exactly 1 px; wobble 2 % around it for 200 frames.
    const double d_switch = 0.004 * 300.0;  // surface distance where level 3 == 1 px
    LodSelector sel(1);
    int changes = 0, last = -1;
    for (int i = 0; i < 200; ++i) {
        const double d = d_switch * (1.0 + 0.02 * std::sin(i * 0.7)) + 0.1;  // + radius
        int level = sel.select(0, object_at({0, 0, -d}), viewer()).level;
        if (last >= 0 && level != last) ++changes;
        last = level;
    }
    EXPECT_LE(changes, 1);

    // Without hysteresis the same wobble flips the level many times: the test can tell.
    LodSelectorParams no_h;
    no_h.hysteresis = 0.0;
    LodSelector raw(1, no_h);
    changes = 0;
    last = -1;
    for (int i = 0; i < 200; ++i) {
        const double d = d_switch * (1.0 + 0.02 * std::sin(i * 0.7)) + 0.1;
        int level = raw.select(0, object_at({0, 0, -d}), viewer()).level;
        if (last >= 0 && level != last) ++changes;
        last = level;
    }
    EXPECT_GT(changes, 10);
}

TEST(LodSelector, RefinesImmediatelyWhenTheCurrentLevelIsTooCoarse) {
    LodSelector sel(1);
    EXPECT_EQ(sel.select(0, object_at(at_angle(60, 1.0)), viewer()).level, 5);
    // The object jumps to the gaze centre: the next frame picks what a fresh selector would
    // (level 2: 0.67 px at 0.9 m), not something in between.
    LodSelector fresh(1);
    const int want = fresh.select(0, object_at(at_angle(0, 1.0)), viewer()).level;
    EXPECT_EQ(want, 2);
    EXPECT_EQ(sel.select(0, object_at(at_angle(0, 1.0)), viewer()).level, want);
}
