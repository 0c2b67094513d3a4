// The end-to-end check of issue 22's first target: the bundled libsurvive recording of a Valve
// Index (data/traces/compare-test-index.rec.gz) through `hmdnode record --backend rec` (the Index
// codec with the recording's factory calibration, clock sync, fusion), its lighthouse poses written
// beside it, and `hmdnode tracking eval` of the one against the other. The figures asserted are the
// ones measured (docs/tracking.md §8), against the target p95 <= 1.0 deg, max <= 2.0 deg. Also: the
// report's and the plot's shape, and the usage errors.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

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

TEST(TrackingEvalCmd, IndexRecordingFusedAgainstItsLighthousePoses) {
    const fs::path dir = test::fresh_temp_dir("hmdnode_tracking_eval_index");
    const fs::path fused = dir / "fused.csv", lh = dir / "lighthouse.csv";
    const fs::path report = dir / "eval.json", plot = dir / "eval.svg";
    const auto rec = tool("record --backend rec --from " + kRec + " --device T20 --out " +
                          fused.string() + " --reference-out " + lh.string());
    ASSERT_EQ(rec.code, 0) << rec.output;
    EXPECT_NE(rec.output.find("factory calibration      applied"), std::string::npos) << rec.output;
    auto est = read_trace_csv(fused);
    ASSERT_TRUE(est.ok()) << est.error().message;
    auto ref = read_trace_csv(lh);
    ASSERT_TRUE(ref.ok()) << ref.error().message;
    // ~1 kHz fused rows over the recording's 25 s, on its timeline (its first IMU line at 0.22 s).
    EXPECT_GT(est->samples.size(), 24000u);
    EXPECT_NEAR(ns_to_s(est->start_ns()), 0.22, 0.05);
    EXPECT_EQ(ref->start_ns(), 16'089'040'000);

    const auto ev =
        tool("tracking eval --reference " + lh.string() + " --estimate " + fused.string() +
             " --report " + report.string() + " --plot " + plot.string());
    ASSERT_EQ(ev.code, 0) << ev.output;
    const nlohmann::json j = nlohmann::json::parse(slurp(report));
    const nlohmann::json& s = j["summary"];
    const size_t samples = s["samples"].get<size_t>();
    EXPECT_GT(samples, 4600u);
    const double p95 = s["error_deg"]["p95"].get<double>();
    const double max = s["error_deg"]["max"].get<double>();
    std::printf(
        "compare-test-index.rec.gz fused vs lighthouse: p50 %.3f p95 %.3f max %.3f deg; "
        "tilt p95 %.3f, heading p95 %.3f (%zu samples)\n",
        s["error_deg"]["p50"].get<double>(), p95, max, s["tilt_error_deg"]["p95"].get<double>(),
        s["heading_error_deg"]["p95"].get<double>(), samples);
    // The figures measured (deterministic: simulated clock, fixed input). Target p95 <= 1.0 deg,
    // max <= 2.0 deg: MISSED on the whole window (docs/tracking.md §8 says why we think so).
    EXPECT_EQ(samples, 4679u);
    EXPECT_NEAR(s["error_deg"]["p50"].get<double>(), 3.543, 0.002);
    EXPECT_NEAR(p95, 8.773, 0.002);
    EXPECT_NEAR(max, 11.277, 0.002);
    // The last 1.4 s, with the headset still (gyro < 3 deg/s): within the target.
    const fs::path tail = dir / "tail.json";
    const auto ev_tail = tool("tracking eval --reference " + lh.string() + " --estimate " +
                              fused.string() + " --start 8 --report " + tail.string());
    ASSERT_EQ(ev_tail.code, 0) << ev_tail.output;
    const nlohmann::json t = nlohmann::json::parse(slurp(tail))["summary"];
    EXPECT_NEAR(t["error_deg"]["p95"].get<double>(), 0.882, 0.002);
    EXPECT_NEAR(t["error_deg"]["max"].get<double>(), 0.945, 0.002);
    for (const char* k : {"error_deg", "tilt_error_deg", "heading_error_deg"})
        for (const char* p : {"p50", "p95", "max"}) EXPECT_TRUE(s[k][p].is_number()) << k << p;
    const std::string svg = slurp(plot);
    EXPECT_EQ(svg.rfind("<svg", 0), 0u);
    EXPECT_NE(svg.find("<polyline"), std::string::npos);
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
}

}  // namespace
}  // namespace hmdnode
