// The end-to-end check of the tracking target (fused orientation against lighthouse-solved poses):
// the bundled libsurvive recording of a Valve Index (data/traces/compare-test-index.rec.gz) through
// `hmdnode record --backend rec` (the Index codec with the recording's factory calibration, clock
// sync, fusion), its lighthouse poses written beside it, and `hmdnode tracking eval` of the one
// against the other. The figures asserted are the ones measured (docs/tracking.md §8), against the
// target p95 <= 1.0 deg, max <= 2.0 deg: with and without the fitted time offset, without the
// intervals the saturated samples disturb, the gyro alone (the fusion's share), one second of
// violent motion (the reference's share), and the poses at their recorded TIME. Also: the report's
// and the plot's shape, and the usage errors.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>
#include <nlohmann/json.hpp>

#include "firmware_host/command_run.hpp"
#include "hmdnode/core/time.hpp"
#include "hmdnode/core/trace.hpp"

namespace hmdnode {
namespace {

namespace fs = std::filesystem;

const std::string kRec = std::string(HMDNODE_SOURCE_DIR) + "/data/traces/compare-test-index.rec.gz";

test::CommandRun tool(const std::string& args) {
    return test::run(std::string(HMDNODE_TOOL) + " " + args);
}

std::string slurp(const fs::path& p) {
    std::ifstream in(p);
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

nlohmann::json eval_summary(const std::string& args, const fs::path& report) {
    const auto ev = tool("tracking eval " + args + " --report " + report.string());
    EXPECT_EQ(ev.code, 0) << ev.output;
    return nlohmann::json::parse(slurp(report))["summary"];
}

void expect_percentiles(const nlohmann::json& p, double p50, double p95, double max,
                        const char* what) {
    EXPECT_NEAR(p["p50"].get<double>(), p50, 0.002) << what;
    EXPECT_NEAR(p["p95"].get<double>(), p95, 0.002) << what;
    EXPECT_NEAR(p["max"].get<double>(), max, 0.002) << what;
}

TEST(TrackingEvalCmd, IndexRecordingFusedAgainstItsLighthousePoses) {
    const fs::path dir = test::fresh_temp_dir("hmdnode_tracking_eval_index");
    const fs::path fused = dir / "fused.csv", lh = dir / "lighthouse.csv";
    const fs::path report = dir / "eval.json", plot = dir / "eval.svg";
    const auto rec = tool("record --backend rec --from " + kRec + " --device T20 --out " +
                          fused.string() + " --reference-out " + lh.string());
    ASSERT_EQ(rec.code, 0) << rec.output;
    EXPECT_NE(rec.output.find("factory calibration      applied"), std::string::npos) << rec.output;
    EXPECT_NE(rec.output.find("4680 lighthouse poses from POSE lines of T20 at their IMU sample's "
                              "instant (4680 sharing its TIME, 0 after it)"),
              std::string::npos)
        << rec.output;
    auto est = read_trace_csv(fused);
    ASSERT_TRUE(est.ok()) << est.error().message;
    auto ref = read_trace_csv(lh);
    ASSERT_TRUE(ref.ok()) << ref.error().message;
    // ~1 kHz fused rows over the recording's 25 s, on its timeline (its first IMU line at 0.22 s).
    EXPECT_GT(est->samples.size(), 24000u);
    EXPECT_NEAR(ns_to_s(est->start_ns()), 0.22, 0.05);
    // The first pose follows the IMU line of TIME 16.089040 s: the instant of that sample, on the
    // fused timeline (the clock sync of the device's ticks), is earlier than its arrival.
    EXPECT_NEAR(ns_to_s(ref->start_ns()), 16.089, 0.02);
    EXPECT_LT(ref->start_ns(), 16'089'040'000);
    // The saturated IMU samples, marked for tracking eval: 13 at 19.30 s, 12 at 21.24-21.26 s.
    std::vector<std::string> sat;
    for (const std::string& c : est->comments)
        if (c.rfind("saturated_ns ", 0) == 0) sat.push_back(c);
    ASSERT_EQ(sat.size(), 2u);
    EXPECT_EQ(sat[0].substr(sat[0].rfind(' ')), " 13");
    EXPECT_EQ(sat[1].substr(sat[1].rfind(' ')), " 12");

    const std::string pair = "--reference " + lh.string() + " --estimate " + fused.string();
    const auto ev =
        tool("tracking eval " + pair + " --report " + report.string() + " --plot " + plot.string());
    ASSERT_EQ(ev.code, 0) << ev.output;
    const nlohmann::json s = nlohmann::json::parse(slurp(report))["summary"];
    std::printf(
        "compare-test-index.rec.gz fused vs lighthouse: p50 %.3f p95 %.3f max %.3f deg; "
        "tilt p95 %.3f, heading p95 %.3f (%zu samples)\n",
        s["error_deg"]["p50"].get<double>(), s["error_deg"]["p95"].get<double>(),
        s["error_deg"]["max"].get<double>(), s["tilt_error_deg"]["p95"].get<double>(),
        s["heading_error_deg"]["p95"].get<double>(), s["samples"].get<size_t>());
    // The figures measured (deterministic: simulated clock, fixed input), docs/tracking.md §8.
    // Target p95 <= 1.0 deg, max <= 2.0 deg: MISSED (the docs say what is known of why).
    EXPECT_EQ(s["samples"].get<size_t>(), 4680u);
    EXPECT_EQ(s["time_offset_ms"].get<double>(), 0.0);
    expect_percentiles(s["error_deg"], 0.944, 2.508, 4.170, "all, offset 0");
    expect_percentiles(s["tilt_error_deg"], 0.638, 2.376, 4.096, "tilt, offset 0");
    expect_percentiles(s["heading_error_deg"], 0.359, 1.123, 1.465, "heading, offset 0");
    const nlohmann::json& x = s["excluding_saturation"];
    EXPECT_EQ(x["excluded_samples"].get<size_t>(), 558u);
    EXPECT_EQ(x["saturated_imu_samples"].get<size_t>(), 25u);
    expect_percentiles(x["error_deg"], 0.932, 2.406, 3.749, "without saturation, offset 0");

    // The time offset fitted with the rotations: 3.3 ms (the reference's own lag, or the IMU's).
    const nlohmann::json a = eval_summary(pair + " --time-offset auto", dir / "auto.json");
    EXPECT_NEAR(a["time_offset_ms"].get<double>(), 3.329, 0.005);
    EXPECT_TRUE(a["time_offset_fitted"].get<bool>());
    expect_percentiles(a["error_deg"], 0.835, 2.458, 3.309, "all, offset fitted");
    expect_percentiles(a["excluding_saturation"]["error_deg"], 0.798, 2.349, 3.010,
                       "without saturation, offset fitted");

    // The fusion's share: the gyro integrated alone (no gravity correction) does no better, so
    // what is left is the gyro against the reference, not the fusion's corrections.
    const fs::path gyro = dir / "gyro.csv";
    const auto g = tool("record --backend rec --from " + kRec + " --device T20 --fusion gyro " +
                        "--out " + gyro.string());
    ASSERT_EQ(g.code, 0) << g.output;
    const std::string gpair = "--reference " + lh.string() + " --estimate " + gyro.string();
    const nlohmann::json ga = eval_summary(gpair + " --time-offset auto", dir / "gyro.json");
    expect_percentiles(ga["error_deg"], 0.875, 2.582, 3.230, "gyro only, offset fitted");
    // Within one second of the violent motion (19.09-20.09 s), where the gyro alone cannot drift
    // more than a few hundredths of a degree, it disagrees with the reference by 2.6 deg p95.
    const nlohmann::json gw =
        eval_summary(gpair + " --time-offset auto --start 3 --duration 1", dir / "gyro_w.json");
    expect_percentiles(gw["error_deg"], 1.264, 2.636, 3.234, "gyro only, 1 s window");

    // The last 1.4 s, headset still: within the target by far.
    const nlohmann::json t = eval_summary(pair + " --start 8", dir / "tail.json");
    expect_percentiles(t["error_deg"], 0.076, 0.136, 0.173, "still tail");

    // The poses at their TIME (--reference-time recorded): the fitted offset is then the USB
    // arrival delay, 14.5 ms, and unfitted the error is twice as large.
    const fs::path fr = dir / "fr.csv", lr = dir / "lr.csv";
    const auto rr =
        tool("record --backend rec --from " + kRec + " --device T20 --out " + fr.string() +
             " --reference-out " + lr.string() + " --reference-time recorded");
    ASSERT_EQ(rr.code, 0) << rr.output;
    const std::string rpair = "--reference " + lr.string() + " --estimate " + fr.string();
    const nlohmann::json r0 = eval_summary(rpair, dir / "r0.json");
    expect_percentiles(r0["error_deg"], 0.937, 5.190, 8.400, "TIME-stamped poses, offset 0");
    const nlohmann::json ra = eval_summary(rpair + " --time-offset auto", dir / "ra.json");
    EXPECT_NEAR(ra["time_offset_ms"].get<double>(), 14.498, 0.005);

    for (const char* k : {"error_deg", "tilt_error_deg", "heading_error_deg"})
        for (const char* p : {"p50", "p95", "max"}) EXPECT_TRUE(s[k][p].is_number()) << k << p;
    const std::string svg = slurp(plot);
    EXPECT_EQ(svg.rfind("<svg", 0), 0u);
    EXPECT_NE(svg.find("<polyline"), std::string::npos);
}

// Synthetic traces: a head turning (or still), the reference at 500 Hz with constant world and
// body rotations, the estimate at 1 kHz; `time_base` comments as the tools write them.
void write_pair(const fs::path& ref, const fs::path& est, const std::string& ref_base,
                const std::string& est_base, bool moving, bool glitch) {
    Trace r, e;
    const glm::dquat w = glm::angleAxis(1.0, glm::normalize(glm::dvec3(1, 2, 3)));
    auto head = [&](double t) {
        return moving ? glm::angleAxis(0.8 * std::sin(0.7 * t), glm::dvec3(0, 1, 0)) *
                            glm::angleAxis(0.4 * std::sin(1.3 * t), glm::dvec3(1, 0, 0))
                      : glm::dquat(1, 0, 0, 0);
    };
    for (int i = 0; i < 6000; ++i) {
        TraceSample s;
        s.time_ns = int64_t(i) * 1'000'000;
        s.orientation = head(i * 1e-3);
        e.samples.push_back(s);
    }
    uint64_t seed = 7;
    for (int i = 100; i < 2900; ++i) {
        TraceSample s;
        s.time_ns = int64_t(i) * 2'000'000;
        seed = seed * 6364136223846793005ull + 1442695040888963407ull;
        const double n = double(seed >> 11) / double(1ull << 53) - 0.5;
        s.orientation = w * head(i * 2e-3) * glm::angleAxis(0.001 * n, glm::dvec3(0, 0, 1));
        if (glitch && i >= 1500 && i < 1505)  // 5 samples 40 deg off: 20,000 deg/s, gyro unmoved
            s.orientation = glm::angleAxis(0.7, glm::dvec3(1, 0, 0)) * s.orientation;
        r.samples.push_back(s);
    }
    if (!ref_base.empty()) r.comments.push_back("time_base " + ref_base);
    if (!est_base.empty()) e.comments.push_back("time_base " + est_base);
    ASSERT_TRUE(write_trace_csv(r, ref).ok());
    ASSERT_TRUE(write_trace_csv(e, est).ok());
}

// The capture path's times start at 0, the .rec path's are the recording's TIME: traces whose
// time bases differ are refused (exit 1, naming both inputs and their bases, no report); one
// without a time base is evaluated with a note.
TEST(TrackingEvalCmd, TracesOnDifferentTimeBasesAreRefused) {
    const fs::path dir = test::fresh_temp_dir("hmdnode_tracking_eval_bases");
    const fs::path ref = dir / "ref.csv", est = dir / "est.csv", rep = dir / "r.json";
    write_pair(ref, est, "recording_time libsurvive x.rec (its TIME)",
               "first_sample capture y.pcap (0 = its first pose)", true, false);
    auto r = tool("tracking eval --reference " + ref.string() + " --estimate " + est.string() +
                  " --report " + rep.string());
    EXPECT_EQ(r.code, 1) << r.output;
    EXPECT_NE(r.output.find("--reference " + ref.string() +
                            " is on the time base \"recording_time libsurvive x.rec (its TIME)\" "
                            "and --estimate " +
                            est.string() +
                            " on \"first_sample capture y.pcap (0 = its first "
                            "pose)\": their times do not share a zero"),
              std::string::npos)
        << r.output;
    EXPECT_FALSE(fs::exists(rep));
    write_pair(ref, est, "recording_time libsurvive x.rec (its TIME)",
               "recording_time libsurvive x.rec (its TIME)", true, false);
    r = tool("tracking eval --reference " + ref.string() + " --estimate " + est.string());
    EXPECT_EQ(r.code, 0) << r.output;
    EXPECT_EQ(r.output.find("note:"), std::string::npos) << r.output;
    write_pair(ref, est, "recording_time libsurvive x.rec (its TIME)", "", true, false);
    r = tool("tracking eval --reference " + ref.string() + " --estimate " + est.string());
    EXPECT_EQ(r.code, 0) << r.output;
    EXPECT_NE(r.output.find("note: --estimate " + est.string() + " has no time_base comment"),
              std::string::npos)
        << r.output;
}

// A reference excursion the estimate's gyro does not see is left out with a warning that counts
// it; a still device's offset is not fitted, and the warning says why instead of advising a wider
// search.
TEST(TrackingEvalCmd, ReferenceGlitchesAndAnUnobservableOffsetAreReported) {
    const fs::path dir = test::fresh_temp_dir("hmdnode_tracking_eval_glitch");
    const fs::path ref = dir / "ref.csv", est = dir / "est.csv";
    write_pair(ref, est, "", "", true, true);
    const nlohmann::json s =
        eval_summary("--reference " + ref.string() + " --estimate " + est.string(), dir / "g.json");
    EXPECT_EQ(s["reference_glitches"]["excursions"].get<int>(), 1);
    EXPECT_EQ(s["reference_glitches"]["samples_left_out"].get<int>(), 5);
    EXPECT_LT(s["error_deg"]["max"].get<double>(), 0.05);  // the noise: 0.5 mrad at most
    auto r = tool("tracking eval --reference " + ref.string() + " --estimate " + est.string());
    EXPECT_NE(r.output.find("warning: --reference " + ref.string() +
                            ": 2 step(s) the estimate's gyro does not see"),
              std::string::npos)
        << r.output;
    EXPECT_NE(r.output.find("1 excursion(s) the reference returns from: 5 reference samples left "
                            "out"),
              std::string::npos)
        << r.output;
    r = tool("tracking eval --reference " + ref.string() + " --estimate " + est.string() +
             " --keep-reference-glitches");
    EXPECT_EQ(r.output.find("step(s)"), std::string::npos) << r.output;
    // Still: no offset can be observed.
    write_pair(ref, est, "", "", false, false);
    const nlohmann::json st = eval_summary(
        "--reference " + ref.string() + " --estimate " + est.string() + " --time-offset auto",
        dir / "s.json");
    EXPECT_FALSE(st["time_offset_observable"].get<bool>());
    EXPECT_FALSE(st["time_offset_fitted"].get<bool>());
    EXPECT_EQ(st["time_offset_ms"].get<double>(), 0.0);
    r = tool("tracking eval --reference " + ref.string() + " --estimate " + est.string() +
             " --time-offset auto");
    EXPECT_NE(r.output.find("warning: not enough motion to observe a time offset"),
              std::string::npos)
        << r.output;
    EXPECT_NE(r.output.find("a wider search cannot help"), std::string::npos) << r.output;
    EXPECT_EQ(r.output.find("--max-time-offset widens it"), std::string::npos) << r.output;
}

TEST(TrackingEvalCmd, BadInputIsRefused) {
    const fs::path dir = test::fresh_temp_dir("hmdnode_tracking_eval_bad");
    // A device the recording does not hold: exit 1, naming the ones it does.
    auto r = tool("record --backend rec --from " + kRec + " --device WM0 --out " +
                  (dir / "x.csv").string());
    EXPECT_EQ(r.code, 1) << r.output;
    EXPECT_NE(r.output.find("no IMU line (i) of device WM0 (devices: T20"), std::string::npos)
        << r.output;
    EXPECT_FALSE(fs::exists(dir / "x.csv"));
    // --reference-out belongs to --backend rec.
    r = tool("record --backend sim --device 1209:0001 --out " + (dir / "y.csv").string() +
             " --reference-out " + (dir / "z.csv").string());
    EXPECT_EQ(r.code, 2) << r.output;
    // Traces that do not share a timeline.
    Trace a, b;
    for (int i = 0; i < 20; ++i) {
        TraceSample s;
        s.time_ns = int64_t(i) * 10'000'000;
        a.samples.push_back(s);
        s.time_ns += 1'000'000'000'000;
        b.samples.push_back(s);
    }
    ASSERT_TRUE(write_trace_csv(a, dir / "a.csv").ok());
    ASSERT_TRUE(write_trace_csv(b, dir / "b.csv").ok());
    r = tool("tracking eval --reference " + (dir / "a.csv").string() + " --estimate " +
             (dir / "b.csv").string() + " --report " + (dir / "r.json").string());
    EXPECT_EQ(r.code, 1) << r.output;
    EXPECT_NE(r.output.find("do the traces share a timeline?"), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(dir / "r.json"));
    r = tool("tracking eval --reference " + (dir / "a.csv").string());
    EXPECT_EQ(r.code, 2) << r.output;
    r = tool("tracking eval --reference " + (dir / "a.csv").string() + " --estimate " +
             (dir / "a.csv").string() + " --time-offset soon");
    EXPECT_EQ(r.code, 2) << r.output;
    EXPECT_NE(r.output.find("--time-offset \"soon\" is neither auto nor milliseconds"),
              std::string::npos)
        << r.output;
    // --fusion gyro belongs to --backend rec.
    r = tool("record --backend sim --device 1209:0001 --out " + (dir / "y.csv").string() +
             " --fusion gyro");
    EXPECT_EQ(r.code, 2) << r.output;
}

}  // namespace
}  // namespace hmdnode
