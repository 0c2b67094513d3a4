// Synthetic gaze (core/src/synthetic_gaze.cpp): determinism, the main sequence measured on the
// gaze it writes (not on its own log), eye-head coordination, and the bundled gaze trace's
// eccentricity distribution as docs/trace-format.md states it.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <glm/gtc/quaternion.hpp>

#include "hmdnode/core/pose.hpp"
#include "hmdnode/core/synthetic_gaze.hpp"
#include "hmdnode/core/time.hpp"
#include "hmdnode/core/trace.hpp"

using namespace hmdnode;
namespace fs = std::filesystem;

namespace {

// 60 s of a head looking around: yaw 40 deg * sin(2 pi t / 8 s), pitch 10 deg * sin(2 pi t / 5 s),
// sampled at 100 Hz.
Trace moving_head() {
    Trace t;
    for (int i = 0; i <= 6000; ++i) {
        const double s = i / 100.0;
        const double yaw = deg_to_rad(40.0) * std::sin(2.0 * kPi * s / 8.0);
        const double pitch = deg_to_rad(10.0) * std::sin(2.0 * kPi * s / 5.0);
        TraceSample ts;
        ts.time_ns = s_to_ns(s);
        ts.orientation =
            glm::angleAxis(yaw, glm::dvec3(0, 1, 0)) * glm::angleAxis(pitch, glm::dvec3(1, 0, 0));
        t.samples.push_back(ts);
    }
    return t;
}

double angle_deg(const glm::dvec3& a, const glm::dvec3& b) {
    return rad_to_deg(
        std::acos(std::clamp(glm::dot(glm::normalize(a), glm::normalize(b)), -1.0, 1.0)));
}

struct Detected {
    double amplitude_deg, duration_ms, peak_dps;
    size_t end;  // the sample where it lands
};

// Saccades found in the written gaze alone (velocity threshold on the gaze in the world, which
// holds still during a fixation): amplitude as the eye-in-head change, duration as the span above
// the threshold, peak eye-in-head speed.
std::vector<Detected> detect_saccades(const Trace& t) {
    std::vector<Detected> out;
    constexpr double kThresholdDps = 1.0;
    size_t start = 0;
    bool in = false;
    double peak = 0.0;
    for (size_t i = 1; i < t.samples.size(); ++i) {
        const TraceSample& a = t.samples[i - 1];
        const TraceSample& b = t.samples[i];
        const double dt = ns_to_s(b.time_ns - a.time_ns);
        const double world =
            angle_deg(a.orientation * a.gaze->direction, b.orientation * b.gaze->direction) / dt;
        const double eye = angle_deg(a.gaze->direction, b.gaze->direction) / dt;
        if (world > kThresholdDps) {
            if (!in) {
                in = true;
                start = i - 1;
                peak = 0.0;
            }
            peak = std::max(peak, eye);
        } else if (in) {
            in = false;
            const double amplitude = angle_deg(t.samples[start].gaze->direction, a.gaze->direction);
            // note: a step of a thousandth of a degree is rounding in the interpolated head, not
            // an eye movement.
            if (amplitude > 0.05)
                out.push_back(
                    {amplitude, ns_to_ms(a.time_ns - t.samples[start].time_ns), peak, i - 1});
        }
    }
    return out;
}

}  // namespace

TEST(SyntheticGaze, SameSeedSameGazeOtherSeedOther) {
    const Trace head = moving_head();
    SyntheticGazeParams p;
    p.seed = 7;
    Result<SyntheticGaze> a = synthesize_gaze(head, p);
    Result<SyntheticGaze> b = synthesize_gaze(head, p);
    p.seed = 8;
    Result<SyntheticGaze> c = synthesize_gaze(head, p);
    ASSERT_TRUE(a.ok() && b.ok() && c.ok());
    EXPECT_EQ(*format_trace_csv(a->trace), *format_trace_csv(b->trace));
    EXPECT_NE(*format_trace_csv(a->trace), *format_trace_csv(c->trace));
    // The head is the input's, sample for sample; the trace says the gaze is synthetic.
    ASSERT_EQ(a->trace.samples.size(), head.samples.size());
    for (size_t i = 0; i < head.samples.size(); ++i)
        EXPECT_EQ(a->trace.samples[i].orientation, head.samples[i].orientation);
    ASSERT_FALSE(a->trace.comments.empty());
    EXPECT_EQ(a->trace.comments.back().rfind("gaze: SYNTHETIC, not measured", 0), 0u);
}

TEST(SyntheticGaze, SaccadesInTheWrittenGazeFollowTheMainSequence) {
    SyntheticGazeParams p;
    p.rate_hz = 1000.0;
    p.blinks_per_min = 0.0;  // the detector reads every sample
    Result<SyntheticGaze> g = synthesize_gaze(moving_head(), p);
    ASSERT_TRUE(g.ok()) << g.error().message;
    const std::vector<Detected> found = detect_saccades(g->trace);
    // About 3 saccades a second over 60 s, every one the model made found again.
    EXPECT_GT(found.size(), 120u);
    EXPECT_EQ(found.size(), g->saccades.size());
    // D = 21 + 2.2 A ms, each within the 1 ms sampling; peak speed 1.875 A / D (minimum jerk).
    double sa = 0, sd = 0, saa = 0, sad = 0;
    for (const Detected& d : found) {
        const double expect_ms = 21.0 + 2.2 * d.amplitude_deg;
        EXPECT_NEAR(d.duration_ms, expect_ms, 2.0) << "amplitude " << d.amplitude_deg;
        if (d.amplitude_deg > 2.0) {
            EXPECT_NEAR(d.peak_dps, 1.875 * d.amplitude_deg / (expect_ms * 1e-3),
                        0.05 * d.peak_dps);
        }
        sa += d.amplitude_deg;
        sd += d.duration_ms;
        saa += d.amplitude_deg * d.amplitude_deg;
        sad += d.amplitude_deg * d.duration_ms;
    }
    const double n = double(found.size());
    const double slope = (n * sad - sa * sd) / (n * saa - sa * sa);
    const double intercept = (sd - slope * sa) / n;
    EXPECT_NEAR(slope, 2.2, 0.1);
    EXPECT_NEAR(intercept, 21.0, 1.5);
    // Amplitudes span the range a main sequence is measured over.
    double max_a = 0;
    for (const Detected& d : found) max_a = std::max(max_a, d.amplitude_deg);
    EXPECT_GT(max_a, 15.0);
}

TEST(SyntheticGaze, TheEyeLeadsHeadTurns) {
    // Where a saccade lands while the head turns faster than 20 deg/s, the eye points ahead of the
    // head into the turn (found in the written gaze: its yaw from the head forward, signed along
    // the turn); without the lead (lead_s = 0) it lands about on the head forward.
    const Trace head = moving_head();
    auto landing_lead_deg = [&](double lead_s) {
        SyntheticGazeParams p;
        p.lead_s = lead_s;
        p.rate_hz = 1000.0;
        p.blinks_per_min = 0.0;
        Result<SyntheticGaze> g = synthesize_gaze(head, p);
        EXPECT_TRUE(g.ok());
        double sum = 0.0;
        size_t n = 0;
        for (const Detected& d : detect_saccades(g->trace)) {
            const TraceSample& s = g->trace.samples[d.end];
            const glm::dvec3 w = glm::inverse(s.orientation) *
                                 head.pose_at(s.time_ns).angular_velocity.value_or(glm::dvec3(0));
            if (rad_to_deg(std::abs(w.y)) < 20.0) continue;
            const glm::dvec3 e = s.gaze->direction;
            const double eye_yaw = rad_to_deg(std::atan2(-e.x, -e.z));  // + to the left
            sum += w.y > 0 ? eye_yaw : -eye_yaw;                        // w.y > 0: turning left
            ++n;
        }
        EXPECT_GT(n, 50u);
        return sum / double(n);
    };
    const double with_lead = landing_lead_deg(0.2);
    const double without = landing_lead_deg(0.0);
    EXPECT_GT(with_lead, 3.0);
    EXPECT_LT(std::abs(without), 2.0);
}

TEST(SyntheticGaze, BundledGazeTraceMatchesTheDocumentedDistribution) {
    // data/traces/corbillon2018_user1_gaze.csv: `hmdnode trace add-gaze --seed 1` on the bundled
    // head trace. docs/trace-format.md states: valid 97 % (blinks), eccentricity p50 about 9 deg,
    // p90 under 20 deg, over 90 % of valid gazes within 20 deg of the head forward.
    const fs::path path =
        fs::path(HMDNODE_SOURCE_DIR) / "data" / "traces" / "corbillon2018_user1_gaze.csv";
    Result<Trace> t = read_trace_csv(path);
    ASSERT_TRUE(t.ok()) << t.error().message;
    const TraceStats st = compute_trace_stats(*t);
    ASSERT_TRUE(st.has_gaze);
    EXPECT_NEAR(st.gaze_valid_fraction, 0.97, 0.015);
    EXPECT_GT(st.gaze_eccentricity_p50_deg, 6.0);
    EXPECT_LT(st.gaze_eccentricity_p50_deg, 12.0);
    EXPECT_LT(st.gaze_eccentricity_p90_deg, 20.0);
    EXPECT_GT(st.gaze_within_20deg_fraction, 0.9);
    // It is the bundled head trace with gaze added: same samples, same head.
    Result<Trace> head = read_trace_csv(fs::path(HMDNODE_SOURCE_DIR) / "data" / "traces" /
                                        "corbillon2018_user1.csv");
    ASSERT_TRUE(head.ok());
    ASSERT_EQ(head->samples.size(), t->samples.size());
    for (size_t i = 0; i < t->samples.size(); i += 97) {
        EXPECT_EQ(head->samples[i].time_ns, t->samples[i].time_ns);
        EXPECT_EQ(head->samples[i].orientation, t->samples[i].orientation);
    }
    // And the tool reproduces it from the seed.
    SyntheticGazeParams p;
    p.seed = 1;
    Result<SyntheticGaze> again = synthesize_gaze(*head, p);
    ASSERT_TRUE(again.ok());
    for (size_t i = 0; i < t->samples.size(); i += 97)
        EXPECT_NEAR(
            angle_deg(again->trace.samples[i].gaze->direction, t->samples[i].gaze->direction), 0.0,
            1e-6);
}

TEST(SyntheticGaze, RefusesBadParametersAndShortTraces) {
    SyntheticGazeParams p;
    p.target_max_deg = 50.0;  // beyond the eye's range
    Result<SyntheticGaze> r = synthesize_gaze(moving_head(), p);
    ASSERT_FALSE(r.ok());
    EXPECT_NE(r.error().message.find("target_max_deg"), std::string::npos);
    Trace one;
    one.samples.resize(1);
    EXPECT_FALSE(synthesize_gaze(one, {}).ok());
}
