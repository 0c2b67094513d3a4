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

TEST(LodSelector, ToleranceFormula) {
    LodSelectorParams p;
    EXPECT_DOUBLE_EQ(LodSelector::tolerance_px(p, 0.0, 0.0), p.tolerance_px);
    EXPECT_DOUBLE_EQ(LodSelector::tolerance_px(p, p.foveal_deg, p.speed_threshold_dps),
                     p.tolerance_px);
    EXPECT_DOUBLE_EQ(LodSelector::tolerance_px(p, p.foveal_deg + 10.0, 0.0),
                     p.tolerance_px * (1.0 + 10.0 * p.eccentricity_gain));
    EXPECT_DOUBLE_EQ(LodSelector::tolerance_px(p, 0.0, p.speed_threshold_dps + 100.0),
                     p.tolerance_px * (1.0 + 100.0 * p.speed_gain));
    EXPECT_DOUBLE_EQ(LodSelector::tolerance_px(p, 1e6, 1e6), p.tolerance_px * p.max_widening);
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
