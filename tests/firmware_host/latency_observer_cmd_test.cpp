// `hmdnode latency --observer camera` as a user runs it on the deterministic simulated clock
// (fixed frame cost, 360x400 per eye at 90 Hz, persistence 2 ms): the simulated camera (240 Hz,
// 1 ms exposure, global shutter, random phases) films the mock display, and the report's per-frame
// figures agree with the closed forms of docs/latency.md, "Closed forms": each observed latency
// within a camera period plus the exposure of the node's figure for the marker's row, the
// differences' mean 0 +- 0.2 ms, every decoded id one the node presented, in order. The flash
// calibration recovers a stamp delay the observer is not told of within a camera period plus the
// exposure. Bad option values exit 2 naming the option; a missing device exits 1 naming it; no
// report is left behind.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "firmware_host/command_run.hpp"

namespace fs = std::filesystem;
using hmdnode::test::CommandRun;
using hmdnode::test::run;

namespace {

const std::string kTool = HMDNODE_TOOL;
const std::string kScene = HMDNODE_DEMO_SCENE;
const std::string kPanel = " --clock sim --eye-width 360 --eye-height 400 --refresh 90 --quiet";
constexpr double kCameraPeriodMs = 1000.0 / 240.0, kExposureMs = 1.0;

nlohmann::json read_json(const fs::path& p) {
    std::ifstream in(p);
    return nlohmann::json::parse(in, nullptr, false);
}

TEST(LatencyObserverCmd, SimulatedCameraAgreesWithTheNodesFigureAsTheClosedFormSays) {
    const fs::path dir = hmdnode::test::fresh_temp_dir("hmdnode_latency_observer");
    const fs::path report = dir / "report.json";
    // Jitter of half a camera period either way: the camera's phases cover its period.
    const CommandRun r =
        run(kTool + " latency --scene " + kScene + kPanel +
            " --frame-cost-ms 4 --modes predict+warp --duration 3 --observer camera --camera sim"
            " --camera-jitter-ms 2.0833 --report " +
            report.string());
    ASSERT_EQ(r.code, 0) << r.output;
    EXPECT_NE(r.output.find("observed - node (ms)"), std::string::npos) << r.output;
    const nlohmann::json j = read_json(report);
    ASSERT_FALSE(j.is_discarded());
    EXPECT_EQ(j["options"]["observer"]["camera"], "sim");
    const nlohmann::json& obs = j["modes"][0]["observer"];
    const nlohmann::json& s = obs["summary"];
    EXPECT_EQ(s["unmatched"], 0);  // every decoded id is one the node presented
    EXPECT_EQ(s["frames"].get<size_t>(), obs["frames"].size());
    size_t matched = 0;
    double sum = 0.0;
    uint64_t last_present = 0;
    const size_t presents = j["modes"][0]["summary"]["frames"];
    for (const nlohmann::json& f : obs["frames"]) {
        if (!f["decoded"]) {
            EXPECT_FALSE(f["reason"].get<std::string>().empty());  // reported, never guessed
            continue;
        }
        ASSERT_TRUE(f["matched"]) << f.dump();
        const uint64_t present = f["present"];
        EXPECT_LT(present, presents);
        EXPECT_GE(present, last_present);  // in order
        last_present = present;
        const double d = f["difference_ms"];
        EXPECT_LE(std::abs(d), kCameraPeriodMs + kExposureMs) << f.dump();  // the target
        EXPECT_LE(std::abs(d), 0.5 * (2.0 + kExposureMs) + 1e-3);           // the lit window's half
        EXPECT_NEAR(double(f["observed_ms"]) - double(f["node_ms"]), d, 1e-9);
        sum += d;
        ++matched;
    }
    EXPECT_EQ(matched, s["decoded"].get<size_t>());
    ASSERT_GT(matched, 60u);
    EXPECT_NEAR(sum / double(matched), 0.0, 0.2);  // the closed form's offset
}

TEST(LatencyObserverCmd, FlashCalibrationRecoversAnUntoldStampDelay) {
    const fs::path dir = hmdnode::test::fresh_temp_dir("hmdnode_latency_flash");
    for (double delay : {0.0, 3.0, 7.5}) {
        const fs::path report = dir / ("flash_" + std::to_string(int(delay * 10)) + ".json");
        const CommandRun r =
            run(kTool + " latency" + kPanel + " --observer camera --calibrate-flash" +
                " --camera-delay-ms " + std::to_string(delay) + " --report " + report.string());
        ASSERT_EQ(r.code, 0) << r.output;
        EXPECT_NE(r.output.find("camera delay"), std::string::npos) << r.output;
        const nlohmann::json j = read_json(report);
        ASSERT_FALSE(j.is_discarded());
        EXPECT_EQ(j["format"], "hmdnode-camera-calibration/1");
        EXPECT_NEAR(double(j["camera_period_ms"]), kCameraPeriodMs, 0.01);
        EXPECT_NEAR(double(j["delay_ms"]), delay, kCameraPeriodMs + kExposureMs) << j.dump();
        size_t seen = 0;
        for (const nlohmann::json& f : j["flashes"]) {
            if (!f["seen"]) continue;
            ++seen;
            // One flash: within half a period plus half the exposure (and rounding).
            EXPECT_LE(std::abs(double(f["delay_ms"]) - delay), double(j["bound_ms"]) + 0.01)
                << f.dump();
        }
        EXPECT_EQ(seen, 12u);
    }
}

TEST(LatencyObserverCmd, BadCameraOptionsExitTwoNamingTheOption) {
    const fs::path dir = hmdnode::test::fresh_temp_dir("hmdnode_latency_observer_bad");
    const fs::path report = dir / "r.json";
    const std::string base = kTool + " latency --scene " + kScene + kPanel +
                             " --frame-cost-ms 4 --duration 0.5 --report " + report.string();
    const std::vector<std::pair<std::string, std::string>> cases = {
        {" --observer webcam", "--observer"},
        {" --camera sim", "--camera goes with --observer camera"},
        {" --calibrate-flash", "--calibrate-flash"},
        {" --observer camera --camera-fps 0", "--camera-fps"},
        {" --observer camera --camera-fps fast", "--camera-fps"},
        {" --observer camera --camera-exposure-ms -1", "--camera-exposure-ms"},
        {" --observer camera --camera-shutter diagonal", "--camera-shutter"},
        {" --observer camera --camera-line-us 20", "--camera-line-us"},
        {" --observer camera --camera-stamp late", "--camera-stamp"},
        {" --observer camera --camera-jitter-ms nan", "--camera-jitter-ms"},
        {" --observer camera --camera-delay-ms 1e9", "--camera-delay-ms"},
        {" --observer camera --marker-cell-px 2.5", "--marker-cell-px"},
        {" --observer camera --marker-cell-px 40", "--marker-cell-px 40"},
        {" --observer camera --camera-size 640x480", "--camera-size"},
        {" --observer camera --flashes 3", "--flashes"},
        {" --observer camera --calibrate-flash --camera-shutter rolling", "--calibrate-flash"},
        {" --observer camera --camera /dev/video0", "--clock real"},
        {" --observer camera --camera /dev/video0 --clock real --camera-fps 60", "--camera-fps"},
        {" --observer camera --camera /dev/video0 --clock real --camera-size 64", "--camera-size"},
        {" --observer camera --camera /dev/video0 --clock real --camera-format mjpeg",
         "--camera-format"},
    };
    for (const auto& [args, named] : cases) {
        std::string cmd = base + args;
        // The device cases run on the real clock: drop the simulated clock's cost.
        if (args.find("--clock real") != std::string::npos) {
            cmd = kTool + " latency --scene " + kScene +
                  " --eye-width 360 --eye-height 400 --quiet --duration 0.5 --report " +
                  report.string() + args;
        }
        const CommandRun r = run(cmd);
        EXPECT_EQ(r.code, 2) << args << ": " << r.output;
        EXPECT_NE(r.output.find("hmdnode latency: "), std::string::npos) << r.output;
        EXPECT_NE(r.output.find(named), std::string::npos) << args << ": " << r.output;
        EXPECT_FALSE(fs::exists(report)) << args;
    }
}

TEST(LatencyObserverCmd, AMissingCameraDeviceFailsNamingIt) {
    const fs::path dir = hmdnode::test::fresh_temp_dir("hmdnode_latency_observer_missing");
    const fs::path report = dir / "r.json";
    const std::string device = (dir / "video-none").string();
    const CommandRun r = run(kTool + " latency --scene " + kScene +
                             " --clock real --duration 0.5 --quiet --observer camera --camera " +
                             device + " --report " + report.string());
    EXPECT_EQ(r.code, 1) << r.output;
    EXPECT_NE(r.output.find(device), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("nothing written"), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(report));
}

// A real panel (--display kms or vk-display): the options that go with it and those that do not.
TEST(LatencyObserverCmd, BadDisplayOptionsExitTwoNamingTheOption) {
    const fs::path dir = hmdnode::test::fresh_temp_dir("hmdnode_latency_display_bad");
    const fs::path report = dir / "r.json";
    const std::string sim = kTool + " latency --scene " + kScene + kPanel +
                            " --frame-cost-ms 4 --duration 0.5 --report " + report.string();
    const std::string real = kTool + " latency --scene " + kScene +
                             " --clock real --quiet --duration 0.5 --report " + report.string();
    const std::vector<std::pair<std::string, std::string>> cases = {
        {sim + " --display hdmi", "--display \"hdmi\""},
        {sim + " --display-device /dev/dri/card0", "--display-device goes with --display kms"},
        {sim + " --display-mode 2880x1600@90", "--display-mode goes with --display kms"},
        {sim + " --display kms", "give --clock real"},
        {real + " --display kms --eye-width 360", "--eye-width: with --display kms"},
        {real + " --display kms --refresh 120", "--refresh: with --display kms"},
        {real + " --display kms --observer camera", "--camera sim films the mock display only"},
        {real + " --display vk-display --display-device /dev/dri/card0",
         "--display-device goes with --display kms"},
        {real + " --display kms --display-persistence-ms -1", "--display-persistence-ms"},
    };
    for (const auto& [cmd, named] : cases) {
        const CommandRun r = run(cmd);
        EXPECT_EQ(r.code, 2) << cmd << ": " << r.output;
        EXPECT_NE(r.output.find("hmdnode latency: "), std::string::npos) << r.output;
        EXPECT_NE(r.output.find(named), std::string::npos) << cmd << ": " << r.output;
        EXPECT_FALSE(fs::exists(report)) << cmd;
    }
}

// A real panel that cannot be opened: exit 1 naming the device, nothing written; the flash
// calibration alike.
TEST(LatencyObserverCmd, AMissingDisplayDeviceFailsNamingIt) {
    const fs::path dir = hmdnode::test::fresh_temp_dir("hmdnode_latency_display_missing");
    const fs::path report = dir / "r.json";
    const std::string device = (dir / "card-none").string();
    const CommandRun r =
        run(kTool + " latency --scene " + kScene +
            " --clock real --duration 0.5 --quiet --modes none --display kms --display-device " +
            device + " --report " + report.string());
    EXPECT_EQ(r.code, 1) << r.output;
    EXPECT_NE(r.output.find(device), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("nothing written"), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(report));
}

}  // namespace
