// Six degrees of freedom through the tools: `hmdnode record --backend rec --base-stations FILE` on
// the bundled Index recording (its light through the device tracker's light path: a solve per
// rotor turn, the light + IMU filter) writes a trace with positions, and `hmdnode tracking eval`
// compares them (mm) beside the orientation with libsurvive's poses, and the IMU-only fused trace
// with the light + IMU one. The setup file
// (tests/data/traces/compare-test-index.base-stations.json) holds the recording's LH_POSE lines
// of 16.01 s: solved by libsurvive during the recording (look-ahead), standing in here for a setup
// stored by an earlier session. The figures asserted are those measured (docs/tracking.md §12),
// with margin.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include <zlib.h>
#include <nlohmann/json.hpp>

#include "firmware_host/command_run.hpp"
#include "hmdnode/core/time.hpp"
#include "hmdnode/core/trace.hpp"
#include "hmdnode/firmware_host/wiring.hpp"

namespace hmdnode {
namespace {

namespace fs = std::filesystem;

const std::string kRec = std::string(HMDNODE_SOURCE_DIR) + "/data/traces/compare-test-index.rec.gz";
const std::string kSetup =
    std::string(HMDNODE_SOURCE_DIR) + "/tests/data/traces/compare-test-index.base-stations.json";

test::CommandRun tool(const std::string& args) {
    return test::run(std::string(HMDNODE_TOOL) + " " + args);
}

using test::read_json;

TEST(SixDofCmd, RecordWritesSixDofFromTheLightAndTrackingEvalComparesPositions) {
    const fs::path dir = test::fresh_temp_dir("hmdnode_sixdof_cmd");
    const fs::path six = dir / "six.csv", lh = dir / "lighthouse.csv", fused = dir / "fused.csv";
    const auto rec =
        tool("record --backend rec --from " + kRec + " --device T20 --out " + six.string() +
             " --reference-out " + lh.string() + " --base-stations " + kSetup);
    ASSERT_EQ(rec.code, 0) << rec.output;
    EXPECT_NE(rec.output.find("4 base station(s) from " + kSetup), std::string::npos) << rec.output;
    // Every W and Y line as a light report 0x28, none refused; every rotor turn solved.
    EXPECT_NE(rec.output.find("110545 (0 refused)"), std::string::npos) << rec.output;
    EXPECT_NE(rec.output.find("15618 rows with a tracked position (first at 9.660 s)"),
              std::string::npos)
        << rec.output;
    auto t = read_trace_csv(six);
    ASSERT_TRUE(t.ok()) << t.error().message;
    ASSERT_TRUE(t->samples.front().position.has_value());
    EXPECT_EQ(t->samples.size(), 15'618u);
    // Tracked from the first base station's calibration frame (9.64 s) to the end (25.5 s),
    // ~1 kHz: measured 15,618 rows from 9.660 s.
    EXPECT_GT(t->samples.size(), 15'000u);
    EXPECT_NEAR(ns_to_s(t->start_ns()), 9.66, 0.05);
    EXPECT_NEAR(ns_to_s(t->end_ns()), 25.49, 0.05);
    bool comment = false;
    for (const std::string& c : t->comments)
        comment |= c.find("6DoF: light + IMU") != std::string::npos;
    EXPECT_TRUE(comment);

    // Against libsurvive's poses: offset 0, then fitted (measured: 6.02 / 37.3 mm; +15 ms fitted
    // to the positions: 4.95 / 17.6 mm; orientation p50 0.96 / 0.91 deg).
    const fs::path r0 = dir / "e0.json", r1 = dir / "e1.json";
    auto ev = tool("tracking eval --reference " + lh.string() + " --estimate " + six.string() +
                   " --report " + r0.string());
    ASSERT_EQ(ev.code, 0) << ev.output;
    EXPECT_NE(ev.output.find("error (mm)"), std::string::npos) << ev.output;
    nlohmann::json s = read_json(r0)["summary"];
    ASSERT_TRUE(s.contains("position_error_mm")) << s.dump();
    EXPECT_LT(s["position_error_mm"]["p50"].get<double>(), 7.5);
    EXPECT_LT(s["position_error_mm"]["p90"].get<double>(), 42.0);
    EXPECT_GT(s["position_error_mm"]["p90"].get<double>(), 5.0);  // not the same data twice
    EXPECT_LT(s["error_deg"]["p50"].get<double>(), 1.1);
    ev = tool("tracking eval --reference " + lh.string() + " --estimate " + six.string() +
              " --time-offset auto --report " + r1.string());
    ASSERT_EQ(ev.code, 0) << ev.output;
    s = read_json(r1)["summary"];
    EXPECT_LT(s["position_error_mm"]["p50"].get<double>(), 6.0);
    EXPECT_LT(s["position_error_mm"]["p90"].get<double>(), 20.0);
    EXPECT_GE(s["position_error_mm"]["time_offset_ms"].get<double>(), 5.0);
    EXPECT_LE(s["position_error_mm"]["time_offset_ms"].get<double>(), 25.0);

    // The IMU-only orientation (the fused trace, no light) against the light + IMU one, over
    // libsurvive's window (16.08 s on; measured p50 0.9 deg).
    const auto imu =
        tool("record --backend rec --from " + kRec + " --device T20 --out " + fused.string());
    ASSERT_EQ(imu.code, 0) << imu.output;
    EXPECT_NE(imu.output.find("no stored base-station setup"), std::string::npos) << imu.output;
    auto f = read_trace_csv(fused);
    ASSERT_TRUE(f.ok()) << f.error().message;
    EXPECT_FALSE(f->samples.front().position.has_value());  // orientation only
    EXPECT_GT(f->samples.size(), 25'000u);
    const fs::path r2 = dir / "e2.json";
    ev = tool("tracking eval --reference " + six.string() + " --estimate " + fused.string() +
              " --start 6.42 --report " + r2.string());
    ASSERT_EQ(ev.code, 0) << ev.output;
    EXPECT_NE(ev.output.find("position: not compared"), std::string::npos) << ev.output;
    s = read_json(r2)["summary"];
    std::printf(
        "IMU-only against light + IMU orientation from 16.08 s: p50 %.3f p95 %.3f max "
        "%.3f deg\n",
        s["error_deg"]["p50"].get<double>(), s["error_deg"]["p95"].get<double>(),
        s["error_deg"]["max"].get<double>());
    EXPECT_LT(s["error_deg"]["p50"].get<double>(), 1.5);
    EXPECT_GT(s["error_deg"]["p50"].get<double>(), 0.05);
    // The same comparison as tracking eval's --imu-only beside the evaluation against
    // libsurvive's poses (its window: 16.08 s on).
    const double p50 = s["error_deg"]["p50"].get<double>();
    const fs::path r3 = dir / "e3.json";
    ev = tool("tracking eval --reference " + lh.string() + " --estimate " + six.string() +
              " --imu-only " + fused.string() + " --report " + r3.string());
    ASSERT_EQ(ev.code, 0) << ev.output;
    EXPECT_NE(ev.output.find("IMU-only " + fused.string() + " against the estimate's orientation"),
              std::string::npos)
        << ev.output;
    s = read_json(r3)["summary"]["imu_only_vs_estimate"];
    EXPECT_NEAR(s["error_deg"]["p50"].get<double>(), p50, 0.01);
    EXPECT_GT(s["samples"].get<size_t>(), 8000u);
}

TEST(SixDofCmd, ABadSetupFileIsAnErrorNamingItAndNothingIsWritten) {
    const fs::path dir = test::fresh_temp_dir("hmdnode_sixdof_bad");
    const fs::path bad = dir / "setup.json", out = dir / "o.csv";
    std::ofstream(bad) << "{\"format\": \"hmdnode base stations\", \"version\": 1, "
                          "\"base_stations\": [{\"system\": 2, \"base_station\": 3, "
                          "\"position\": [0, 0], \"orientation\": [1, 0, 0, 0]}]}\n";
    auto r = tool("record --backend rec --from " + kRec + " --device T20 --out " + out.string() +
                  " --base-stations " + bad.string());
    EXPECT_EQ(r.code, 1) << r.output;
    EXPECT_NE(r.output.find(bad.string()), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("position"), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(out));
    r = tool("record --device 1209:0001 --backend sim --sim-clock --out " + out.string() +
             " --base-stations " + kSetup);
    EXPECT_EQ(r.code, 2) << r.output;
    EXPECT_NE(r.output.find("--base-stations needs --backend hidapi, libusb, rec or capture"),
              std::string::npos)
        << r.output;
    r = tool("record --backend rec --from " + kRec + " --device T20 --out " + out.string() +
             " --base-stations " + kSetup + " --fusion gyro");
    EXPECT_EQ(r.code, 2) << r.output;
    EXPECT_FALSE(fs::exists(out));
}

// The node's wiring (`hmdnode replay --tracker rec --base-stations FILE`): the tracker it makes
// delivers positions once the light tracks, in the node's +y-up world; without the setup none.
TEST(SixDofCmd, TheNodesRecordingTrackerWithASetupDeliversPositions) {
    for (const bool with_setup : {true, false}) {
        SCOPED_TRACE(with_setup ? "with a setup" : "without");
        TrackerSpec spec;
        spec.backend = TrackerBackend::rec;
        spec.from = kRec;
        spec.device = "T20";
        if (with_setup) spec.base_stations = kSetup;
        const WiringKeys keys = WiringKeys::command_line();
        ASSERT_TRUE(check_tracker_spec(spec, ClockKind::sim, keys).ok());
        SimulatedClock clock(kNsPerSecond);
        auto w = make_tracker(spec, clock, keys);
        ASSERT_TRUE(w.ok()) << w.error().message;
        EXPECT_EQ(w->tracker->info().provides_position, with_setup);
        ASSERT_TRUE(w->tracker->start().ok());
        std::vector<TrackerSample> buf(512);
        size_t samples = 0, positions = 0;
        double min_y = 1e9, max_y = -1e9;
        while (!w->tracker->finished()) {
            clock.advance_ns(10 * kNsPerMs);
            for (size_t n = w->tracker->read(buf); n > 0; n = w->tracker->read(buf))
                for (size_t i = 0; i < n; ++i) {
                    ++samples;
                    if (!buf[i].position) continue;
                    ++positions;
                    min_y = std::min(min_y, buf[i].position->y);
                    max_y = std::max(max_y, buf[i].position->y);
                }
        }
        EXPECT_EQ(samples, 25'059u);
        if (!with_setup) {
            EXPECT_EQ(positions, 0u);
            continue;
        }
        EXPECT_GT(positions, 15'000u);
        // +y up: the node's y is libsurvive's z (its POSE lines: -0.075 to 1.078 m; ours within
        // a few cm of them).
        EXPECT_NEAR(min_y, -0.075, 0.05);
        EXPECT_NEAR(max_y, 1.078, 0.05);
    }
    TrackerSpec bad;
    bad.backend = TrackerBackend::trace;  // a trace has no light
    bad.trace_path = "x.csv";
    bad.base_stations = kSetup;
    const Status refused = check_tracker_spec(bad, ClockKind::sim, WiringKeys::command_line());
    ASSERT_FALSE(refused.ok());
    EXPECT_NE(refused.error().message.find("--base-stations (a stored base-station setup) needs "
                                           "--tracker hidapi, libusb, rec or capture"),
              std::string::npos)
        << refused.error().message;
    // A live device takes one: its light interface beside its IMU one (interface_group_test).
    TrackerSpec live;
    live.backend = TrackerBackend::hidapi;
    live.device = "28de:2000";
    live.base_stations = kSetup;
    EXPECT_TRUE(check_tracker_spec(live, ClockKind::real, WiringKeys::command_line()).ok());
}

// The same with a setup that keeps the base stations' calibrations
// (compare-test-index.base-stations-calibrated.json: the poses above and the calibrations decoded
// from the recording's own OOTX frames, standing in for a setup saved by an earlier session, as
// light_tracking_test checks): tracked from the first turns of light (0.18 s), not from the
// first calibration frame (9.64 s); the status says which calibration was used.
TEST(SixDofCmd, RecordWithStoredCalibrationsTracksFromTheFirstLight) {
    const fs::path dir = test::fresh_temp_dir("hmdnode_sixdof_calibrated");
    const fs::path six = dir / "six.csv";
    const std::string setup = std::string(HMDNODE_SOURCE_DIR) +
                              "/tests/data/traces/compare-test-index.base-stations-calibrated.json";
    const auto rec = tool("record --backend rec --from " + kRec + " --device T20 --out " +
                          six.string() + " --base-stations " + setup);
    ASSERT_EQ(rec.code, 0) << rec.output;
    EXPECT_NE(rec.output.find("4 base station(s) from " + setup), std::string::npos) << rec.output;
    EXPECT_NE(rec.output.find("base stations solved with the setup's stored calibration"),
              std::string::npos)
        << rec.output;
    EXPECT_NE(rec.output.find("; 0 turns before any"), std::string::npos) << rec.output;
    auto t = read_trace_csv(six);
    ASSERT_TRUE(t.ok()) << t.error().message;
    std::printf("record with stored calibrations: %zu rows with a position from %.3f s\n",
                t->samples.size(), ns_to_s(t->start_ns()));
    EXPECT_LT(ns_to_s(t->start_ns()), 0.184 + 2.0);  // the first light line at 0.184 s
    EXPECT_NEAR(ns_to_s(t->end_ns()), 25.49, 0.05);
    EXPECT_GT(t->samples.size(), 24'000u);
    std::filesystem::remove_all(dir);
}

// A recording that holds a stored setup: lh2_test_cal with its LH_POSE lines (libsurvive's
// solve at 12.99 s) moved to time 0, before its light, as libsurvive writes a saved
// configuration's base stations. `record` then takes them without --base-stations.
TEST(SixDofCmd, ARecordingsBaseStationsFromBeforeItsLightAreItsStoredSetup) {
    const fs::path dir = test::fresh_temp_dir("hmdnode_sixdof_stored");
    std::string text;
    {
        gzFile gz = gzopen(
            (std::string(HMDNODE_SOURCE_DIR) + "/data/traces/lh2_test_cal.rec.gz").c_str(), "rb");
        ASSERT_NE(gz, nullptr);
        char buf[65536];
        for (int n = gzread(gz, buf, sizeof buf); n > 0; n = gzread(gz, buf, sizeof buf))
            text.append(buf, size_t(n));
        gzclose(gz);  // (its stream is cut short: what inflated is kept)
    }
    std::string head, rest;
    size_t moved = 0;
    for (size_t at = 0; at < text.size();) {
        size_t end = text.find('\n', at);
        if (end == std::string::npos) end = text.size() - 1;
        const std::string line = text.substr(at, end + 1 - at);
        at = end + 1;
        const size_t sp = line.find(' ');
        if (line.find(" LH_POSE ") != std::string::npos && sp != std::string::npos) {
            head += "0.000000" + line.substr(sp);
            ++moved;
        } else {
            rest += line;
        }
    }
    ASSERT_EQ(moved, 2u);
    const fs::path rec = dir / "stored.rec", out = dir / "six.csv", lh = dir / "lh.csv";
    std::ofstream(rec, std::ios::binary) << head << rest;
    const auto r = tool("record --backend rec --from " + rec.string() + " --device T20 --out " +
                        out.string() + " --reference-out " + lh.string());
    ASSERT_EQ(r.code, 0) << r.output;
    EXPECT_NE(r.output.find("2 base station(s) from the recording's LH_POSE lines before its "
                            "light"),
              std::string::npos)
        << r.output;
    auto t = read_trace_csv(out);
    ASSERT_TRUE(t.ok()) << t.error().message;
    ASSERT_TRUE(t->samples.front().position.has_value());
    const fs::path rep = dir / "e.json";
    const auto ev = tool("tracking eval --reference " + lh.string() + " --estimate " +
                         out.string() + " --time-offset auto --report " + rep.string());
    ASSERT_EQ(ev.code, 0) << ev.output;
    const nlohmann::json s = read_json(rep)["summary"];
    std::printf(
        "lh2_test_cal with its base stations at time 0: %zu rows from %.3f s; position "
        "p50 %.2f p90 %.2f mm, orientation p50 %.3f deg\n",
        t->samples.size(), ns_to_s(t->start_ns()), s["position_error_mm"]["p50"].get<double>(),
        s["position_error_mm"]["p90"].get<double>(), s["error_deg"]["p50"].get<double>());
    // Measured: 1,107 rows from 12.210 s (the first calibration frame 12.17 s; libsurvive's
    // first pose 12.99 s); position p50 0.27, p90 0.57 mm; orientation p50 0.038 deg (W, B, the
    // translation, lever arm and offset fitted). Before libsurvive's 8 g for a controller (the
    // Index's 4 g): 0.95 / 2.13 mm, 0.029 deg.
    EXPECT_GT(t->samples.size(), 1'000u);
    EXPECT_NEAR(ns_to_s(t->start_ns()), 12.21, 0.05);
    EXPECT_LT(s["position_error_mm"]["p50"].get<double>(), 0.6);
    EXPECT_LT(s["position_error_mm"]["p90"].get<double>(), 1.5);
    EXPECT_LT(s["error_deg"]["p50"].get<double>(), 0.1);
}

}  // namespace
}  // namespace hmdnode
