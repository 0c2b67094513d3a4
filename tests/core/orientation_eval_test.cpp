// evaluate_orientation on synthetic traces with closed-form answers: an estimate that differs
// from the reference by constant world and body rotations only (error 0, both found), and one
// with an added error of known size about the vertical (heading) or a horizontal axis (tilt),
// of opposite signs over two copies of the same motion so the best constant alignment leaves it
// whole; the window options and the
// error when the traces do not overlap.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "hmdnode/core/orientation_eval.hpp"
#include "hmdnode/core/pose.hpp"

namespace hmdnode {
namespace {

constexpr double kDeg = kPi / 180.0;

// A head moving about all three axes.
glm::dquat motion(double t) {
    return glm::angleAxis(0.8 * std::sin(0.7 * t), glm::dvec3(0, 1, 0)) *
           glm::angleAxis(0.4 * std::sin(1.3 * t + 0.5), glm::dvec3(1, 0, 0)) *
           glm::angleAxis(0.3 * std::sin(0.9 * t + 1.0), glm::dvec3(0, 0, 1));
}

const glm::dquat kWorld = glm::angleAxis(1.1, glm::normalize(glm::dvec3(0.3, -1.0, 0.4)));
const glm::dquat kBody = glm::angleAxis(2.0, glm::normalize(glm::dvec3(-0.5, 0.2, 1.0)));

// The reference is kWorld * err(t) * est(t) * kBody: err acts in the estimate's world.
void make_traces(Trace* ref, Trace* est, const glm::dvec3& err_axis, double err_rad) {
    for (int i = 0; i < 2000; ++i) {
        // The same 10 s of motion twice, the error +err_rad in the first and -err_rad in the
        // second: by symmetry the best constant alignment is the true one, leaving err_rad whole.
        const glm::dquat e = motion((i % 1000) * 0.01);
        const double sign = i < 1000 ? 1.0 : -1.0;
        const glm::dquat err = glm::angleAxis(sign * err_rad, err_axis);
        TraceSample r, s;
        r.time_ns = s.time_ns = int64_t(i) * 10'000'000 + 3'000'000'000;
        s.orientation = e;
        r.orientation = kWorld * err * e * kBody;
        ref->samples.push_back(r);
        est->samples.push_back(s);
    }
}

double angle_between(const glm::dquat& a, const glm::dquat& b) {
    return 2.0 * std::acos(std::min(1.0, std::abs(glm::dot(a, b))));
}

TEST(OrientationEval, ConstantWorldAndBodyRotationsAreFoundAndLeaveNoError) {
    Trace ref, est;
    make_traces(&ref, &est, glm::dvec3(0, 1, 0), 0.0);
    auto r = evaluate_orientation(ref, est);
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_EQ(r->samples, 2000u);
    EXPECT_LT(angle_between(r->world_alignment, kWorld), 1e-6);
    EXPECT_LT(angle_between(r->body_alignment, kBody), 1e-6);
    EXPECT_LT(r->error.max, 1e-5);
}

// An error of err_deg about `axis` in the estimate's world: every sample reads err_deg in all,
// err_deg in the component `part` (heading or tilt) and none in `other`.
void expect_whole_error(const glm::dvec3& axis, double err_deg,
                        ErrorPercentiles OrientationEval::*part,
                        ErrorPercentiles OrientationEval::*other) {
    Trace ref, est;
    make_traces(&ref, &est, axis, err_deg * kDeg);
    auto r = evaluate_orientation(ref, est);
    ASSERT_TRUE(r.ok()) << r.error().message;
    for (const ErrorPercentiles& p : {r->error, (*r).*part}) {
        EXPECT_NEAR(p.p50, err_deg, 1e-3);
        EXPECT_NEAR(p.p95, err_deg, 1e-3);
        EXPECT_NEAR(p.max, err_deg, 1e-3);
    }
    EXPECT_LT(((*r).*other).max, 1e-3);
}

TEST(OrientationEval, AHeadingErrorIsReportedWholeAsHeading) {
    expect_whole_error(glm::dvec3(0, 1, 0), 1.5, &OrientationEval::heading, &OrientationEval::tilt);
}

TEST(OrientationEval, ATiltErrorIsReportedWholeAsTilt) {
    expect_whole_error(glm::dvec3(1, 0, 0), 0.7, &OrientationEval::tilt, &OrientationEval::heading);
}

TEST(OrientationEval, TheWindowRestrictsTheSamplesAndDisjointTracesAreAnError) {
    Trace ref, est;
    make_traces(&ref, &est, glm::dvec3(0, 1, 0), 0.0);
    auto r = evaluate_orientation(ref, est, {5.0, 2.0});
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_EQ(r->samples, 201u);  // 5.00 .. 7.00 s after the reference's start, both ends in
    EXPECT_EQ(r->time_ns.front(), ref.start_ns() + 5'000'000'000);
    for (TraceSample& s : est.samples) s.time_ns += 100'000'000'000;
    auto none = evaluate_orientation(ref, est);
    ASSERT_FALSE(none.ok());
    EXPECT_NE(none.error().message.find("0 reference samples in the window"), std::string::npos)
        << none.error().message;
}

// The reference is the estimate's motion delayed by a known offset (estimate time + offset =
// reference time), sampled at 200 Hz against the estimate's 1 kHz, with the constant rotations.
void make_shifted_traces(Trace* ref, Trace* est, double offset_s) {
    auto head = [](double t) {  // motion() plus a quicker shake, as a head turning and nodding
        return motion(t) * glm::angleAxis(0.15 * std::sin(7.0 * t), glm::dvec3(0, 1, 0));
    };
    for (int i = 0; i < 20000; ++i) {
        TraceSample s;
        s.time_ns = int64_t(i) * 1'000'000 + 2'000'000'000;
        s.orientation = head(i * 1e-3);
        est->samples.push_back(s);
    }
    for (int i = 100; i < 3900; ++i) {  // 0.5 .. 19.5 s of the estimate's span
        TraceSample r;
        r.time_ns = int64_t(i) * 5'000'000 + 2'000'000'000;
        r.orientation = kWorld * head(i * 5e-3 - offset_s) * kBody;
        ref->samples.push_back(r);
    }
}

TEST(OrientationEval, AKnownTimeOffsetIsRecoveredWithTheRotations) {
    for (double offset_ms : {37.4, -12.25, 0.0}) {
        Trace ref, est;
        make_shifted_traces(&ref, &est, offset_ms * 1e-3);
        // Not fitted: the shift reads as error (up to ~1.6 rad/s x 37 ms = 3.4 deg).
        auto plain = evaluate_orientation(ref, est);
        ASSERT_TRUE(plain.ok()) << plain.error().message;
        if (offset_ms != 0.0) {
            EXPECT_GT(plain->error.max, 0.5) << offset_ms;
        }
        OrientationEvalOptions fit;
        fit.fit_time_offset = true;
        auto r = evaluate_orientation(ref, est, fit);
        ASSERT_TRUE(r.ok()) << r.error().message;
        EXPECT_NEAR(double(r->time_offset_ns) * 1e-6, offset_ms, 1.0) << offset_ms;
        EXPECT_FALSE(r->time_offset_at_range_limit);
        EXPECT_LT(angle_between(r->world_alignment, kWorld), 1e-3);
        EXPECT_LT(angle_between(r->body_alignment, kBody), 1e-3);
        EXPECT_LT(r->error.max, 0.05) << offset_ms;
        std::printf("offset %.3f ms: fitted %.4f ms, error max %.5f deg (%.3f deg unfitted)\n",
                    offset_ms, double(r->time_offset_ns) * 1e-6, r->error.max, plain->error.max);
        // Given rather than fitted: the same.
        OrientationEvalOptions given;
        given.time_offset_s = offset_ms * 1e-3;
        auto g = evaluate_orientation(ref, est, given);
        ASSERT_TRUE(g.ok()) << g.error().message;
        EXPECT_EQ(g->time_offset_ns, std::llround(offset_ms * 1e6));
        EXPECT_LT(g->error.max, 0.05) << offset_ms;
    }
    // An offset beyond the search range is flagged, not passed off as found.
    Trace ref, est;
    make_shifted_traces(&ref, &est, 0.3);
    OrientationEvalOptions narrow;
    narrow.fit_time_offset = true;
    narrow.max_time_offset_s = 0.1;
    auto r = evaluate_orientation(ref, est, narrow);
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_TRUE(r->time_offset_at_range_limit);
}

// The reference with an excursion the estimate does not see (a pose solver's glitch: 30 deg for
// 20 ms, 10 samples at 500 Hz, the gyro reading the motion only) is found, left out and counted;
// kept, it reads as a 30 deg error. A step that does not come back is counted, nothing left out.
TEST(OrientationEval, ReferenceGlitchesTheGyroDoesNotSeeAreLeftOutAndCounted) {
    auto build = [](Trace* ref, Trace* est, int glitch_from, int glitch_to) {
        for (int i = 0; i < 10000; ++i) {  // 10 s at 1 kHz
            TraceSample s;
            s.time_ns = int64_t(i) * 1'000'000 + 1'000'000'000;
            s.orientation = motion(i * 1e-3);
            est->samples.push_back(s);
        }
        for (int i = 10; i < 4990; ++i) {  // 500 Hz
            TraceSample r;
            r.time_ns = int64_t(i) * 2'000'000 + 1'000'000'000;
            glm::dquat q = motion(i * 2e-3);
            if (i >= glitch_from && i < glitch_to)
                q = glm::angleAxis(30 * kDeg, glm::dvec3(1, 0, 0)) * q;
            r.orientation = kWorld * q * kBody;
            ref->samples.push_back(r);
        }
    };
    Trace ref, est;
    build(&ref, &est, 2000, 2010);
    auto r = evaluate_orientation(ref, est);
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_EQ(r->glitches.steps, 2u);
    EXPECT_EQ(r->glitches.excursions, 1u);
    EXPECT_EQ(r->glitches.samples_left_out, 10u);
    EXPECT_EQ(r->glitches.unreturned_steps, 0u);
    EXPECT_EQ(r->samples, ref.samples.size() - 10);
    EXPECT_EQ(r->glitches.worst_at_ns, int64_t(1999) * 2'000'000 + 1'000'000'000);
    EXPECT_GT(r->glitches.worst_reference_rate_deg_s, 10000.0);  // 30 deg in 2 ms
    EXPECT_LT(r->glitches.worst_estimate_rate_deg_s, 100.0);
    EXPECT_LT(r->error.max, 1e-3);
    EXPECT_LT(angle_between(r->world_alignment, kWorld), 1e-6);
    OrientationEvalOptions keep;
    keep.leave_out_reference_glitches = false;
    auto k = evaluate_orientation(ref, est, keep);
    ASSERT_TRUE(k.ok());
    EXPECT_EQ(k->glitches.steps, 0u);
    EXPECT_GT(k->error.max, 29.0);
    // A jump that stays: counted, not left out.
    Trace ref2, est2;
    build(&ref2, &est2, 3000, 100000);
    auto s = evaluate_orientation(ref2, est2);
    ASSERT_TRUE(s.ok());
    EXPECT_EQ(s->glitches.unreturned_steps, 1u);
    EXPECT_EQ(s->glitches.samples_left_out, 0u);
    ASSERT_EQ(s->glitches.unreturned_at_ns.size(), 1u);
    EXPECT_EQ(s->glitches.unreturned_at_ns[0], int64_t(2999) * 2'000'000 + 1'000'000'000);
}

// A still device: no motion tells a time offset, so the search's result (noise, at its edge) is
// not used and the result says why; with motion the same reference noise leaves it observable.
TEST(OrientationEval, AnOffsetAStillDeviceCannotShowIsNotFitted) {
    for (bool moving : {false, true}) {
        Trace ref, est;
        uint64_t seed = 12345;
        auto noise = [&] {  // uniform in [-1, 1]
            seed = seed * 6364136223846793005ull + 1442695040888963407ull;
            return double(seed >> 11) / double(1ull << 52) - 1.0;
        };
        for (int i = 0; i < 6000; ++i) {  // 6 s at 1 kHz; still: a gyro bias drifts its heading
            TraceSample s;
            s.time_ns = int64_t(i) * 1'000'000 + 1'000'000'000;
            const glm::dquat m = moving ? motion(i * 1e-3) : glm::dquat(1, 0, 0, 0);
            s.orientation =
                glm::angleAxis(moving ? 0.0 : 0.002 * i * 1e-3, glm::dvec3(0, 1, 0)) * m;
            est.samples.push_back(s);
        }
        for (int i = 300; i < 2700; ++i) {  // 500 Hz, 0.6 .. 5.4 s, 0.05 deg of noise
            TraceSample r;
            r.time_ns = int64_t(i) * 2'000'000 + 1'000'000'000;
            const glm::dquat m = moving ? motion(i * 2e-3) : glm::dquat(1, 0, 0, 0);
            const glm::dvec3 n(noise(), noise(), noise());
            r.orientation = kWorld * m * kBody * glm::angleAxis(0.05 * kDeg, glm::normalize(n));
            ref.samples.push_back(r);
        }
        OrientationEvalOptions fit;
        fit.fit_time_offset = true;
        auto r = evaluate_orientation(ref, est, fit);
        ASSERT_TRUE(r.ok()) << r.error().message;
        EXPECT_EQ(r->glitches.steps, 0u) << moving;
        std::printf(
            "%s: observable %d, sigma %.1f ms, rate %.2f deg/s, fit %.3f ms, used %.3f ms\n",
            moving ? "moving" : "still", int(r->time_offset_observable), r->time_offset_sigma_ms,
            r->reference_rate_rms_deg_s, r->unobservable_fit_ms, double(r->time_offset_ns) * 1e-6);
        EXPECT_EQ(r->time_offset_observable, moving);
        EXPECT_FALSE(r->time_offset_at_range_limit);
        if (moving) {
            EXPECT_NEAR(double(r->time_offset_ns) * 1e-6, 0.0, 1.0);
        } else {
            EXPECT_EQ(r->time_offset_ns, 0);
            EXPECT_GT(r->time_offset_sigma_ms, 50.0);
        }
    }
}

TEST(OrientationEval, TheTimeBaseIsTheTraceComment) {
    Trace t;
    EXPECT_FALSE(trace_time_base(t).has_value());
    t.comments = {"saturated_ns 1 2 3", " time_base first_sample capture x.pcap (0 = its first)"};
    ASSERT_TRUE(trace_time_base(t).has_value());
    EXPECT_EQ(*trace_time_base(t), "first_sample capture x.pcap (0 = its first)");
}

TEST(OrientationEval, PercentilesAreNearestRank) {
    std::vector<double> v;
    for (int i = 100; i >= 1; --i) v.push_back(i);
    const ErrorPercentiles p = error_percentiles(v);
    EXPECT_EQ(p.p50, 50);
    EXPECT_EQ(p.p95, 95);
    EXPECT_EQ(p.max, 100);
}

}  // namespace
}  // namespace hmdnode
