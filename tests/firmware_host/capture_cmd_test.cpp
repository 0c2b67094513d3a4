// `hmdnode capture info` (its light section too) and `hmdnode replay --capture` as a user runs
// them, on the real Vive capture bundled in data/traces and on bad input.
#include <gtest/gtest.h>

#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include "firmware_host/command_run.hpp"

namespace fs = std::filesystem;

namespace {

using hmdnode::test::CommandRun;
using hmdnode::test::run;

fs::path temp_dir(const std::string& name) {
    return hmdnode::test::fresh_temp_dir("hmdnode_capture_cmd_test_" + name);
}

const std::string kTool = HMDNODE_TOOL;
const std::string kScene = HMDNODE_DEMO_SCENE;
const fs::path kCapture = fs::path(HMDNODE_SOURCE_DIR) / "data/traces/vive_cal.pcap.gz";

bool has(const std::string& s, const std::string& part) {
    return s.find(part) != std::string::npos;
}

TEST(CaptureCmd, InfoSummarisesTheRealViveCapture) {
    ASSERT_TRUE(fs::exists(kCapture)) << kCapture << " is missing";
    CommandRun r = run(kTool + " capture info " + kCapture.string());
    ASSERT_EQ(r.code, 0) << r.output;
    EXPECT_TRUE(has(r.output, "link type 220")) << r.output;
    EXPECT_TRUE(has(r.output, "device bus 1 address 62: 28de:2000 (from usbdevs) HMD")) << r.output;
    EXPECT_TRUE(has(r.output, "report ids 0x00 x1 (0.0 /s) 0x20 x20569")) << r.output;
    EXPECT_TRUE(
        has(r.output, "unique samples        22073 over 22.354 s of device time = 987.4 /s"))
        << r.output;
    EXPECT_TRUE(has(r.output, "sequence gaps         5 (171 samples missing)")) << r.output;
    EXPECT_TRUE(has(r.output, "20569 decoded, 0 malformed")) << r.output;
    EXPECT_TRUE(has(r.output, "(0.38 % from g)")) << r.output;
    // Its light (lighthouse 1): every report decoded, both base stations calibrated.
    EXPECT_TRUE(
        has(r.output, "sensor model          32 sensors (the configuration read in the capture)"))
        << r.output;
    EXPECT_TRUE(has(r.output, "reports               16311, 0 refused")) << r.output;
    EXPECT_TRUE(has(r.output, "events                30797 hits, 5376 syncs")) << r.output;
    EXPECT_TRUE(has(r.output,
                    "lighthouse 1 base station 0: 2681 syncs, 14721 hits on 12 sensors; "
                    "calibration: id 0xf77e21f3"))
        << r.output;
    EXPECT_TRUE(has(r.output,
                    "lighthouse 1 base station 1: 2695 syncs, 16076 hits on 15 sensors; "
                    "calibration: id 0x0aa54f65"))
        << r.output;
}

TEST(CaptureCmd, InfoFailsOnMissingOrForeignFiles) {
    const fs::path dir = temp_dir("bad");
    CommandRun r = run(kTool + " capture info " + (dir / "nope.pcap").string());
    EXPECT_NE(r.code, 0);
    EXPECT_TRUE(has(r.output, "nope.pcap")) << r.output;
    const fs::path junk = dir / "junk.pcap";
    std::ofstream(junk, std::ios::binary) << "this is not a pcap file at all, not even close";
    r = run(kTool + " capture info " + junk.string());
    EXPECT_NE(r.code, 0);
    EXPECT_TRUE(has(r.output, "junk.pcap")) << r.output;
}

TEST(CaptureCmd, ReplayRunsTheCaptureThroughTheNode) {
    ASSERT_TRUE(fs::exists(kCapture)) << kCapture << " is missing";
    const fs::path dir = temp_dir("replay");
    const fs::path report = dir / "report.json";
    // note: a fixed frame cost; the one measured at start would follow the machine's load.
    CommandRun r = run(kTool + " replay --quiet --eye-width 32 --eye-height 32 --max-frames 120 " +
                       "--frame-cost-ms 2 " + "--scene " + kScene + " --capture " +
                       kCapture.string() + " --device 28de:2000 --report " + report.string());
    ASSERT_EQ(r.code, 0) << r.output;
    std::ifstream in(report);
    const nlohmann::json j = nlohmann::json::parse(in);
    EXPECT_EQ(j["summary"]["frames"], 120);
    // 120 frames at 90 Hz cover ~1.33 s of a ~987 samples/s capture.
    EXPECT_GT(j["trace_samples"].get<double>(), 1000.0);
    EXPECT_LT(j["trace_samples"].get<double>(), 1500.0);
    // The headset lies still on a table: the fused pose (and so the view) does not turn.
    EXPECT_LT(j["frames"].back()["angular_speed_dps"].get<double>(), 3.0);
    // A capture has no truth: no registration error, in the report (null) and the table (n/a).
    EXPECT_TRUE(j["summary"]["registration_error_deg"]["p50"].is_null()) << j["summary"].dump();
    EXPECT_TRUE(j["frames"].front()["registration_error_deg"].is_null());
    EXPECT_TRUE(has(r.output, "registration error (deg)        n/a      n/a      n/a      n/a"))
        << r.output;
}

TEST(CaptureCmd, ReplayStartAndDurationCountFromTheCapturesFirstSample) {
    ASSERT_TRUE(fs::exists(kCapture)) << kCapture << " is missing";
    const fs::path dir = temp_dir("start");
    const std::string base = kTool + " replay --quiet --eye-width 32 --eye-height 32 --scene " +
                             kScene + " --capture " + kCapture.string() + " --device 28de:2000";
    const fs::path report = dir / "report.json";
    // A fixed frame cost: the simulated clock's default model is measured on this machine.
    CommandRun r =
        run(base + " --frame-cost-ms 4 --start 10 --duration 1 --report " + report.string());
    ASSERT_EQ(r.code, 0) << r.output;
    std::ifstream in(report);
    const nlohmann::json j = nlohmann::json::parse(in);
    // 1 s at 90 Hz.
    EXPECT_GE(j["summary"]["frames"].get<int>(), 88);
    EXPECT_LE(j["summary"]["frames"].get<int>(), 91);
    // The reports of the first 10 s were decoded and fused (not shown): ~987 samples/s.
    EXPECT_GT(j["trace_samples"].get<double>(), 10000.0);
    EXPECT_LT(j["trace_samples"].get<double>(), 12000.0);
    // From the first frame on the newest sample is the capture's at 10 s, which arrives at the
    // replay's start (host time 0): the first frame is as fresh as in a replay from the start.
    const nlohmann::json& f0 = j["frames"].front();
    EXPECT_GT(f0["pose_sample_time_ns"].get<int64_t>(), -5'000'000);
    EXPECT_LT(f0["latency_ms"].get<double>(), 40.0);
    EXPECT_LT(j["frames"].back()["angular_speed_dps"].get<double>(), 3.0);

    // The same replay twice is the same (the simulated clock).
    CommandRun again = run(base + " --frame-cost-ms 4 --start 10 --duration 1 --report " +
                           (dir / "b.json").string());
    ASSERT_EQ(again.code, 0) << again.output;
    std::ifstream in_b(dir / "b.json");
    const nlohmann::json b = nlohmann::json::parse(in_b);
    ASSERT_EQ(b["frames"].size(), j["frames"].size());
    for (size_t i = 0; i < b["frames"].size(); ++i)
        for (const char* key : {"pose_sample_time_ns", "photon_time_ns", "angular_speed_dps"})
            EXPECT_EQ(b["frames"][i][key], j["frames"][i][key]) << i << " " << key;

    // A start past the capture's end (22.4 s) is an error, and writes no report.
    r = run(base + " --start 30 --report " + (dir / "past.json").string());
    EXPECT_NE(r.code, 0) << r.output;
    EXPECT_TRUE(has(r.output, "past the capture's last sample")) << r.output;
    EXPECT_FALSE(fs::exists(dir / "past.json"));
    // On the real clock --start is refused (the reports before it would flood the ring).
    r = run(base + " --clock real --start 10 --report " + (dir / "real.json").string());
    EXPECT_NE(r.code, 0) << r.output;
    EXPECT_TRUE(has(r.output, "--start with --tracker capture needs --clock sim")) << r.output;
    EXPECT_FALSE(fs::exists(dir / "real.json"));
}

TEST(CaptureCmd, ReplayNamesTheDevicesWhenTheOneAskedForIsAbsent) {
    ASSERT_TRUE(fs::exists(kCapture)) << kCapture << " is missing";
    const fs::path dir = temp_dir("absent");
    CommandRun r =
        run(kTool + " replay --quiet --scene " + kScene + " --capture " + kCapture.string() +
            " --device 1234:5678 --report " + (dir / "r.json").string());
    EXPECT_NE(r.code, 0);
    EXPECT_TRUE(has(r.output, "no device 1234:5678")) << r.output;
    EXPECT_TRUE(has(r.output, "1-62=28de:2000")) << r.output;
    EXPECT_FALSE(fs::exists(dir / "r.json"));
    r = run(kTool + " replay --quiet --scene " + kScene + " --capture " + kCapture.string());
    EXPECT_EQ(r.code, 2) << r.output;
}

// `replay --capture --device VID:PID:SERIAL` used to run the node with a tracker that never
// opened and exit 0 with an empty report; the selector matching nothing is an error now.
TEST(CaptureCmd, ReplaySelectorMatchingNothingIsAnError) {
    ASSERT_TRUE(fs::exists(kCapture)) << kCapture << " is missing";
    const fs::path dir = temp_dir("replay_serial");
    const fs::path report = dir / "report.json";
    const CommandRun r =
        run(kTool + " replay --quiet --eye-width 32 --eye-height 32 --duration 1 " + "--scene " +
            kScene + " --capture " + kCapture.string() + " --device 28de:2000:LHR-0001 --report " +
            report.string());
    EXPECT_NE(r.code, 0) << r.output;
    EXPECT_NE(r.output.find("1-62=28de:2000"), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(report));
}

}  // namespace
