// evaluate_position on synthetic traces with closed-form answers: a reference whose positions
// are the estimate's under a known world rotation, translation and lever arm (and time shift):
// all three found and the error 0; an added error of known size left whole; a trace without
// positions and a body that does not turn are errors naming why.
#include <gtest/gtest.h>

#include <cmath>

#include "hmdnode/core/orientation_eval.hpp"
#include "hmdnode/core/pose.hpp"
#include "hmdnode/core/position_eval.hpp"

namespace hmdnode {
namespace {

glm::dquat turn(double t) {
    return glm::angleAxis(0.8 * std::sin(0.7 * t), glm::dvec3(0, 1, 0)) *
           glm::angleAxis(0.4 * std::sin(1.3 * t + 0.5), glm::dvec3(1, 0, 0)) *
           glm::angleAxis(0.3 * std::sin(0.9 * t + 1.0), glm::dvec3(0, 0, 1));
}
glm::dvec3 path(double t) {
    return {0.3 * std::cos(0.9 * t), 1.6 + 0.05 * std::sin(2.1 * t), 0.2 * std::sin(0.6 * t)};
}

const glm::dquat kWorld = glm::angleAxis(1.1, glm::normalize(glm::dvec3(0.3, -1.0, 0.4)));
const glm::dquat kBody = glm::angleAxis(0.4, glm::normalize(glm::dvec3(-0.5, 0.2, 1.0)));
const glm::dvec3 kOffset(0.12, -0.40, 2.05);  // m
const glm::dvec3 kLever(0.03, -0.02, 0.07);   // m, estimate body frame

// Samples every 1 ms over 12 s (`repeat`: the same 6 s of motion twice); the reference
// `shift_ns` later than the estimate (estimate time + shift = reference time).
void make_traces(Trace* ref, Trace* est, int64_t shift_ns, bool positions = true,
                 bool turning = true, bool repeat = false) {
    for (int i = 0; i < 12'000; ++i) {
        const double t = (repeat ? i % 6'000 : i) * 1e-3;
        TraceSample e, r;
        e.time_ns = int64_t(i) * 1'000'000;
        e.orientation = turning ? turn(t) : glm::dquat(1, 0, 0, 0);
        if (positions) e.position = path(t);
        r.time_ns = e.time_ns + shift_ns;
        r.orientation = kWorld * e.orientation * kBody;
        r.position = kWorld * (path(t) + glm::mat3_cast(e.orientation) * kLever) + kOffset;
        est->samples.push_back(e);
        ref->samples.push_back(r);
    }
}

TEST(PositionEval, AKnownAlignmentLeverArmAndTimeShiftAreFoundAndLeaveNoError) {
    Trace ref, est;
    make_traces(&ref, &est, 7'000'000);
    OrientationEvalOptions oo;
    oo.fit_time_offset = true;
    oo.leave_out_reference_glitches = false;
    auto o = evaluate_orientation(ref, est, oo);
    ASSERT_TRUE(o.ok()) << o.error().message;
    PositionEvalOptions po;
    po.fit_time_offset = true;
    auto p = evaluate_position(ref, est, *o, po);
    ASSERT_TRUE(p.ok()) << p.error().message;
    EXPECT_EQ(p->time_offset_ns, 7'000'000);
    EXPECT_LT(p->max_mm, 1e-6);
    EXPECT_NEAR(glm::length(p->world_offset - kOffset), 0.0, 1e-9);
    EXPECT_NEAR(glm::length(p->lever_arm - kLever), 0.0, 1e-9);
    EXPECT_NEAR(std::abs(glm::dot(p->world_rotation, kWorld)), 1.0, 1e-12);
    EXPECT_EQ(p->samples, o->samples);
    // Without the lever arm fitted, the error is the lever arm's swing (up to |l|, 7.9 cm here).
    po.fit_lever_arm = false;
    auto q = evaluate_position(ref, est, *o, po);
    ASSERT_TRUE(q.ok());
    EXPECT_GT(q->p90_mm, 5.0);
    EXPECT_LT(q->max_mm, glm::length(kLever) * 2e3);
}

TEST(PositionEval, AnAddedErrorOfKnownSizeIsLeftWhole) {
    Trace ref, est;
    make_traces(&ref, &est, 0, true, true, /*repeat=*/true);
    // The same motion twice, +5 mm along the reference world's x in the first half, -5 mm in the
    // second: the best constant alignment is the true one, the error 5 mm everywhere.
    for (size_t i = 0; i < ref.samples.size(); ++i)
        *ref.samples[i].position += glm::dvec3(i < 6'000 ? 0.005 : -0.005, 0, 0);
    OrientationEvalOptions oo;
    oo.leave_out_reference_glitches = false;
    auto o = evaluate_orientation(ref, est, oo);
    ASSERT_TRUE(o.ok());
    auto p = evaluate_position(ref, est, *o);
    ASSERT_TRUE(p.ok()) << p.error().message;
    EXPECT_NEAR(p->p50_mm, 5.0, 0.05);
    EXPECT_NEAR(p->p90_mm, 5.0, 0.05);
}

TEST(PositionEval, NoPositionsOrNoTurningAreErrorsSayingWhy) {
    Trace ref, est;
    make_traces(&ref, &est, 0, /*positions=*/false);
    auto o = evaluate_orientation(ref, est);
    ASSERT_TRUE(o.ok());
    auto p = evaluate_position(ref, est, *o);
    ASSERT_FALSE(p.ok());
    EXPECT_NE(p.error().message.find("the estimate has no positions"), std::string::npos);
    Trace ref2, est2;
    make_traces(&ref2, &est2, 0, true, /*turning=*/false);
    auto o2 = evaluate_orientation(ref2, est2);
    ASSERT_TRUE(o2.ok());
    auto p2 = evaluate_position(ref2, est2, *o2);
    ASSERT_FALSE(p2.ok());
    EXPECT_NE(p2.error().message.find("lever arm"), std::string::npos) << p2.error().message;
}

}  // namespace
}  // namespace hmdnode
