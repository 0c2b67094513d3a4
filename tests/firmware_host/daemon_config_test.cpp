// hmdnoded's config reader on values a fuzzer finds (tests/fuzz/daemon_config_fuzz.cpp): numbers
// that do not fit the field are refused with the key named (exit 2), never converted with an
// overflowing cast (undefined behaviour that UBSan reports).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <tuple>

#include <nlohmann/json.hpp>
#include "firmware_host/command_run.hpp"

namespace fs = std::filesystem;

namespace {

// Runs the daemon on the demo config with `patch` merged in; returns its run.
hmdnode::test::CommandRun run_with(const std::string& name, const nlohmann::json& patch) {
    const fs::path dir = hmdnode::test::fresh_temp_dir("hmdnode_daemon_config_" + name);
    nlohmann::json cfg = {
        {"scene", HMDNODE_DEMO_SCENE},
        {"clock", "sim"},
        {"tracker", {{"trace", HMDNODE_SOURCE_DIR "/data/traces/corbillon2018_user1.csv"}}},
        {"display", {{"eye_width", 32}, {"eye_height", 32}}}};
    cfg.merge_patch(patch);
    std::ofstream(dir / "hmdnoded.json") << cfg.dump(1);
    return hmdnode::test::run(std::string(HMDNODE_DAEMON) + " --config " +
                              (dir / "hmdnoded.json").string() + " --max-frames 1");
}

}  // namespace

TEST(DaemonConfig, IntegerFieldsTakeIntegersThatFit) {
    for (const auto& [name, patch, key] :
         {std::tuple{"max_frames_float", nlohmann::json{{"max_frames", 1e30}}, "max_frames"},
          std::tuple{"priority_huge", nlohmann::json{{"realtime_priority", 4294967296}},
                     "realtime_priority"},
          std::tuple{"eye_fraction", nlohmann::json{{"display", {{"eye_width", 32.5}}}},
                     "eye_width"},
          std::tuple{"mesh_negative_huge",
                     nlohmann::json{{"node", {{"mesh", -9223372036854775807LL}}}}, "mesh"}}) {
        const hmdnode::test::CommandRun r = run_with(name, patch);
        EXPECT_EQ(r.code, 2) << name << ": " << r.output;
        EXPECT_NE(r.output.find(std::string("\"") + key + "\" must be an integer"),
                  std::string::npos)
            << name << ": " << r.output;
    }
}

TEST(DaemonConfig, DurationsOutOfRangeAreRefusedBeforeTheirConversion) {
    for (const auto& [name, patch, key] :
         {std::tuple{"latency", nlohmann::json{{"tracker", {{"latency_us", 1e300}}}},
                     "tracker.latency_us"},
          std::tuple{"jitter", nlohmann::json{{"tracker", {{"jitter_us", 2e6}}}},
                     "tracker.jitter_us"},
          std::tuple{"persistence", nlohmann::json{{"display", {{"persistence_ms", 1e300}}}},
                     "display.persistence_ms"},
          std::tuple{"status_every", nlohmann::json{{"status", {{"every_s", 1e300}}}},
                     "status.every_s"}}) {
        const hmdnode::test::CommandRun r = run_with(name, patch);
        EXPECT_EQ(r.code, 2) << name << ": " << r.output;
        EXPECT_NE(r.output.find(key), std::string::npos) << name << ": " << r.output;
    }
    EXPECT_EQ(run_with("good_latency", {{"tracker", {{"latency_us", 5000}}}}).code, 0);
}

// display.type "kms" / "vk-display" (docs/daemon.md): errors name the field; a KMS display that
// cannot be opened and a vk-display on lavapipe (no displays) are clear errors, exit 2.
TEST(DaemonConfig, DisplayTypesAndTheirFields) {
    for (const auto& [name, patch, text] :
         {std::tuple{"type_unknown", nlohmann::json{{"display", {{"type", "x11"}}}},
                     "display.type \"x11\" is not one of mock, kms, vk-display"},
          std::tuple{"mode_bad",
                     nlohmann::json{{"display",
                                     {{"type", "kms"},
                                      {"mode", "2880x1600@"},
                                      {"eye_width", nullptr},
                                      {"eye_height", nullptr}}}},
                     "display.mode: \"2880x1600@\" is not WIDTHxHEIGHT@HZ"},
          std::tuple{"connector_on_mock", nlohmann::json{{"display", {{"connector", "DP-1"}}}},
                     "display.connector"},
          std::tuple{"eye_on_kms", nlohmann::json{{"display", {{"type", "kms"}}}},
                     "display.type kms takes them from display.mode"},
          std::tuple{"kms_missing_device",
                     nlohmann::json{{"clock", "real"},
                                    {"display",
                                     {{"type", "kms"},
                                      {"device", "/dev/dri/card-hmdnode-missing"},
                                      {"eye_width", nullptr},
                                      {"eye_height", nullptr}}}},
                     "/dev/dri/card-hmdnode-missing"},
          std::tuple{
              "vk_display_none",
              nlohmann::json{
                  {"clock", "real"},
                  {"display",
                   {{"type", "vk-display"}, {"eye_width", nullptr}, {"eye_height", nullptr}}}},
              "displays found: none"}}) {
        const hmdnode::test::CommandRun r = run_with(name, patch);
        EXPECT_EQ(r.code, 2) << name << ": " << r.output;
        EXPECT_NE(r.output.find(text), std::string::npos) << name << ": " << r.output;
    }
}

// "eye_tracker": {"backend": "none" | "trace"} (docs/daemon.md): a wrong name, or a trace without
// gaze columns, is refused naming the key or the file (exit 2); the bundled gaze trace runs and
// the status file says where eccentricity came from.
TEST(DaemonConfig, EyeTrackerBackendAndItsTrace) {
    const hmdnode::test::CommandRun bad =
        run_with("eye_bad", {{"eye_tracker", {{"backend", "tobii"}}}});
    EXPECT_EQ(bad.code, 2) << bad.output;
    EXPECT_NE(bad.output.find("eye_tracker.backend \"tobii\" is not one of none, trace"),
              std::string::npos)
        << bad.output;
    const hmdnode::test::CommandRun no_gaze =
        run_with("eye_no_gaze", {{"eye_tracker", {{"backend", "trace"}}}});
    EXPECT_EQ(no_gaze.code, 2) << no_gaze.output;
    EXPECT_NE(no_gaze.output.find("corbillon2018_user1.csv: the trace has no gaze columns"),
              std::string::npos)
        << no_gaze.output;

    const hmdnode::test::CommandRun ok = run_with(
        "eye_ok",
        {{"eye_tracker", {{"backend", "trace"}}},
         {"tracker", {{"trace", HMDNODE_SOURCE_DIR "/data/traces/corbillon2018_user1_gaze.csv"}}}});
    EXPECT_EQ(ok.code, 0) << ok.output;

    // 60 frames with a status window every 0.2 s: the status file names the eye tracker and how
    // many of the window's new frames measured eccentricity from its gaze.
    const fs::path dir = hmdnode::test::fresh_temp_dir("hmdnode_daemon_config_eye_status");
    nlohmann::json cfg = {
        {"scene", HMDNODE_DEMO_SCENE},
        {"clock", "sim"},
        {"tracker", {{"trace", HMDNODE_SOURCE_DIR "/data/traces/corbillon2018_user1_gaze.csv"}}},
        {"eye_tracker", {{"backend", "trace"}}},
        {"display", {{"eye_width", 32}, {"eye_height", 32}}},
        {"status", {{"path", (dir / "status.json").string()}, {"every_s", 0.2}}}};
    std::ofstream(dir / "hmdnoded.json") << cfg.dump(1);
    const hmdnode::test::CommandRun run =
        hmdnode::test::run(std::string(HMDNODE_DAEMON) + " --config " +
                           (dir / "hmdnoded.json").string() + " --max-frames 60");
    ASSERT_EQ(run.code, 0) << run.output;
    std::ifstream in(dir / "status.json");
    const nlohmann::json status = nlohmann::json::parse(in);
    EXPECT_EQ(status["eye_tracker"], "trace");
    EXPECT_GT(status["gaze_frames"].get<int>(), 0);
    EXPECT_NE(status["gaze_source"], "lens_centre");
}

// The frame budget's levers (docs/daemon.md, docs/latency.md): values out of range are refused
// with the key named; good ones run, and the daemon logs the lens pass it chose.
TEST(DaemonConfig, FrameBudgetLeversAreCheckedAndTaken) {
    for (const auto& [name, patch, key] :
         {std::tuple{"lens_pass", nlohmann::json{{"node", {{"lens_pass", "lut"}}}},
                     "node.lens_pass"},
          std::tuple{"min_scale", nlohmann::json{{"node", {{"min_render_scale", 0.05}}}},
                     "node.min_render_scale"},
          std::tuple{"divisor", nlohmann::json{{"node", {{"max_render_divisor", 9}}}},
                     "node.max_render_divisor"}}) {
        const hmdnode::test::CommandRun r = run_with(name, patch);
        EXPECT_EQ(r.code, 2) << name << ": " << r.output;
        EXPECT_NE(r.output.find(key), std::string::npos) << name << ": " << r.output;
    }
    const hmdnode::test::CommandRun ok = run_with("levers_ok", {{"node",
                                                                 {{"lens_pass", "fused"},
                                                                  {"pixel_ladder", false},
                                                                  {"min_render_scale", 0.6},
                                                                  {"max_render_divisor", 2}}}});
    EXPECT_EQ(ok.code, 0) << ok.output;
    EXPECT_NE(ok.output.find("lens pass fused"), std::string::npos) << ok.output;
}

// tracker.base_stations (docs/daemon.md): a stored setup for a lighthouse device's light; with a
// backend that has no light it is a config error naming the key (exit 2); with a recording's
// light the daemon loads it and runs.
TEST(DaemonConfig, BaseStationsNeedABackendWithLight) {
    const std::string setup =
        HMDNODE_SOURCE_DIR "/tests/data/traces/compare-test-index.base-stations.json";
    hmdnode::test::CommandRun r =
        run_with("base_stations_trace", {{"tracker", {{"base_stations", setup}}}});
    EXPECT_EQ(r.code, 2) << r.output;
    EXPECT_NE(r.output.find("tracker.base_stations (a stored base-station setup) needs "
                            "tracker.backend hidapi, libusb, rec or capture"),
              std::string::npos)
        << r.output;
    r = run_with("base_stations_rec",
                 {{"tracker",
                   {{"trace", nullptr},
                    {"backend", "rec"},
                    {"from", HMDNODE_SOURCE_DIR "/data/traces/compare-test-index.rec.gz"},
                    {"device", "T20"},
                    {"base_stations", setup}}}});
    EXPECT_EQ(r.code, 0) << r.output;
    r = run_with("base_stations_missing",
                 {{"tracker",
                   {{"trace", nullptr},
                    {"backend", "rec"},
                    {"from", HMDNODE_SOURCE_DIR "/data/traces/compare-test-index.rec.gz"},
                    {"device", "T20"},
                    {"base_stations", "/nonexistent/setup.json"}}}});
    EXPECT_NE(r.code, 0) << r.output;
    EXPECT_NE(r.output.find("/nonexistent/setup.json"), std::string::npos) << r.output;
}
