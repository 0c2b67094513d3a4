// The tools as a user runs them: exit codes, messages, and no output on failure.
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
    return hmdnode::test::fresh_temp_dir("hmdnode_cli_test_" + name);
}

void write(const fs::path& p, const std::string& text) {
    std::ofstream(p, std::ios::binary) << text;
}

const std::string kTool = HMDNODE_TOOL;
const std::string kScene = HMDNODE_DEMO_SCENE;
const std::string kTrace = HMDNODE_SOURCE_DIR "/data/traces/corbillon2018_user1.csv";

std::string replay_cmd(const fs::path& scene, const fs::path& trace, const fs::path& report) {
    return kTool + " replay --quiet --eye-width 32 --eye-height 32 --duration 0.5 --scene " +
           scene.string() + " --trace " + trace.string() + " --report " + report.string();
}

void expect_replay_fails(const fs::path& scene, const fs::path& trace,
                         std::initializer_list<std::string> parts) {
    const fs::path report = trace.parent_path() / "report.json";
    CommandRun r = run(replay_cmd(scene, trace, report));
    EXPECT_NE(r.code, 0) << r.output;
    for (const std::string& part : parts)
        EXPECT_NE(r.output.find(part), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(report)) << "a failed replay must write no report";
}

const char* kGoodHeader = "time_ns,qw,qx,qy,qz\n";

}  // namespace

TEST(Cli, ReplaysTheBundledRealTrace) {
    // note: a fixed frame and warp cost, so that the simulated clock owes nothing to the
    // renderer's measured speed: the run, its latency included, is the same on every machine.
    fs::path dir = temp_dir("real");
    CommandRun r = run(replay_cmd(kScene, kTrace, dir / "report.json") +
                       " --start 30 --frame-cost-ms 4 --warp-cost-ms 0.5");
    ASSERT_EQ(r.code, 0) << r.output;
    EXPECT_NE(r.output.find("motion-to-photon"), std::string::npos);
    std::ifstream in(dir / "report.json");
    nlohmann::json j = nlohmann::json::parse(in);
    EXPECT_EQ(j["summary"]["frames"].get<int>(), 44);  // 0.5 s at 90 Hz, every vsync made
    EXPECT_EQ(j["summary"]["missed_vsyncs"].get<int>(), 0);
    // MTP per vsync (docs/latency.md section 3), warp on: the photon offset (half a 90 Hz period
    // to the middle row, 5.556 ms, + half the 2 ms persistence) + the latch margin (0.5) + the
    // pacing margin (1 ms at the start, 10 us less per vsync made: 0.57-1.0 ms over these 44)
    // + the warp (0.5) + the tracker's transport latency (1) = 9.13-9.56 ms, plus the age of the
    // newest trace sample at the warp's wake: this trace is as recorded, one sample per 13-20 ms
    // here, so about 8 ms at the median. The p50 (nearest rank, core's percentile: the 22nd of
    // the 44 vsyncs; it was the mean of the 22nd and 23rd, 17.552563, before the project chose
    // one percentile definition) is that of this deterministic run, the same in every run.
    const double p50 = j["summary"]["latency_ms"]["p50"].get<double>();
    EXPECT_DOUBLE_EQ(p50, 17.551038);
    const double floor_ms = 5.0 / 0.9 + 1.0 + 0.5 + 0.57 + 0.5 + 1.0;
    EXPECT_GT(p50, floor_ms);
    EXPECT_LT(p50, floor_ms + 0.43 + 20.0);  // at most the floor with the initial margin + a gap
    EXPECT_LT(j["summary"]["registration_error_deg"]["p50"].get<double>(), 2.0);
    EXPECT_EQ(j["renderer_backend"], "vulkan");
}

TEST(Cli, ReplayRendersOnTheBackendItIsGivenAndReportsIt) {
    fs::path dir = temp_dir("gles");
    CommandRun r = run(replay_cmd(kScene, kTrace, dir / "report.json") +
                       " --renderer gles --frame-cost-ms 4 --warp-cost-ms 0.5");
    ASSERT_EQ(r.code, 0) << r.output;
    std::ifstream in(dir / "report.json");
    nlohmann::json j = nlohmann::json::parse(in);
    EXPECT_EQ(j["renderer_backend"], "gles");
    EXPECT_EQ(j["summary"]["missed_vsyncs"].get<int>(), 0);
    // An unknown backend is a usage error; from the environment, a clear error.
    r = run(replay_cmd(kScene, kTrace, dir / "bad.json") + " --renderer metal");
    EXPECT_EQ(r.code, 2) << r.output;
    EXPECT_NE(r.output.find("--renderer"), std::string::npos) << r.output;
    r = run("HMDNODE_RENDERER=metal " + replay_cmd(kScene, kTrace, dir / "bad.json"));
    EXPECT_NE(r.code, 0) << r.output;
    EXPECT_NE(r.output.find("HMDNODE_RENDERER: unknown renderer backend \"metal\""),
              std::string::npos)
        << r.output;
    EXPECT_FALSE(fs::exists(dir / "bad.json"));
}

TEST(Cli, TraceWithAMissingColumnFails) {
    fs::path dir = temp_dir("missing_column");
    write(dir / "t.csv", "time_ns,qw,qx,qy\n0,1,0,0\n1000000,1,0,0\n");
    expect_replay_fails(kScene, dir / "t.csv", {"t.csv", "qz"});
}

TEST(Cli, TraceWithANonNumericFieldFails) {
    fs::path dir = temp_dir("non_numeric");
    write(dir / "t.csv", std::string(kGoodHeader) + "0,1,0,0,0\n1000000,1,abc,0,0\n");
    expect_replay_fails(kScene, dir / "t.csv", {"t.csv:3", "qx", "abc"});
}

TEST(Cli, TraceWithTimeGoingBackwardsFails) {
    fs::path dir = temp_dir("backwards");
    write(dir / "t.csv",
          std::string(kGoodHeader) + "0,1,0,0,0\n2000000,1,0,0,0\n1000000,1,0,0,0\n");
    expect_replay_fails(kScene, dir / "t.csv", {"t.csv:4", "backwards"});
}

TEST(Cli, TruncatedSceneFails) {
    fs::path dir = temp_dir("truncated");
    std::ifstream in(kScene, std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), {});
    write(dir / "half.glb", bytes.substr(0, bytes.size() / 2));
    fs::copy_file(kTrace, dir / "t.csv");
    expect_replay_fails(dir / "half.glb", dir / "t.csv", {"half.glb", "truncated"});
}

TEST(Cli, NonGltfSceneFails) {
    fs::path dir = temp_dir("not_gltf");
    write(dir / "scene.glb", "this is not a scene\n");
    fs::copy_file(kTrace, dir / "t.csv");
    expect_replay_fails(dir / "scene.glb", dir / "t.csv", {"scene.glb"});
    expect_replay_fails(dir / "missing.glb", dir / "t.csv", {"missing.glb"});
}

TEST(Cli, ImportsAndReplaysTheRawCorbillonTable) {
    fs::path dir = temp_dir("import");
    const fs::path raw = HMDNODE_SOURCE_DIR "/tests/data/traces/corbillon2018_user1_head.txt";
    CommandRun imp = run(kTool + " trace import --source-frame z-up-x-forward --from " +
                         raw.string() + " --to " + (dir / "t.csv").string());
    ASSERT_EQ(imp.code, 0) << imp.output;
    EXPECT_NE(imp.output.find("sign flips"), std::string::npos);
    CommandRun r = run(replay_cmd(kScene, dir / "t.csv", dir / "report.json"));
    EXPECT_EQ(r.code, 0) << r.output;
    EXPECT_TRUE(fs::exists(dir / "report.json"));
    // A bad table leaves no output behind.
    write(dir / "bad.txt", "timestamp w x y z\n0 1 0 0 0\n0.5 1 0 x 0\n");
    CommandRun bad = run(kTool + " trace import --from " + (dir / "bad.txt").string() + " --to " +
                         (dir / "bad.csv").string());
    EXPECT_NE(bad.code, 0);
    EXPECT_FALSE(fs::exists(dir / "bad.csv"));
}

TEST(Cli, ReplaysBothFullRealTraces) {
    for (const char* user : {"1", "2"}) {
        const fs::path raw = fs::path(HMDNODE_SOURCE_DIR) / "tests/data/traces" /
                             (std::string("corbillon2018_user") + user + "_quaternion.txt");
        ASSERT_TRUE(fs::exists(raw)) << raw << " is missing";
        fs::path dir = temp_dir(std::string("shared_") + user);
        CommandRun imp = run(kTool + " trace import --source-frame z-up-x-forward --from " +
                             raw.string() + " --to " + (dir / "t.csv").string());
        ASSERT_EQ(imp.code, 0) << imp.output;
        CommandRun r = run(replay_cmd(kScene, dir / "t.csv", dir / "report.json") + " --start 100");
        EXPECT_EQ(r.code, 0) << r.output;
    }
}

TEST(Daemon, RunsTheFrameLoopFromAConfigFileAndWritesStatus) {
    fs::path dir = temp_dir("daemon");
    nlohmann::json cfg = {{"scene", kScene},
                          {"clock", "sim"},
                          {"tracker", {{"type", "sim"}, {"trace", kTrace}, {"loop", true}}},
                          {"display", {{"eye_width", 32}, {"eye_height", 32}}},
                          {"status", {{"path", (dir / "status.json").string()}, {"every_s", 0.5}}}};
    write(dir / "hmdnoded.json", cfg.dump(1));
    CommandRun r = run(std::string(HMDNODE_DAEMON) + " --config " +
                       (dir / "hmdnoded.json").string() + " --max-frames 120");
    ASSERT_EQ(r.code, 0) << r.output;
    std::ifstream in(dir / "status.json");
    nlohmann::json s = nlohmann::json::parse(in);
    EXPECT_GE(s["frames"].get<int>(), 45);
    EXPECT_EQ(s["errors"].get<int>(), 0);
    EXPECT_GT(s["time_unix_s"].get<double>(), 1.7e9);  // written after 2023
    EXPECT_GT(s["triangles"].get<int>(), 0);
    EXPECT_GE(s["lod_switches"].get<int>(), 0);
    EXPECT_EQ(s["renderer_backend"], "vulkan");
    EXPECT_EQ(s["lod_pops"].get<int>(), 0);  // level changes cross-fade by default
    EXPECT_EQ(s["lod_pops_per_min"].get<double>(), 0.0);
    EXPECT_NE(r.output.find("stopped after 120 frames"), std::string::npos) << r.output;
}

TEST(Daemon, RendersOnTheConfiguredBackendAndRefusesAnUnknownOne) {
    fs::path dir = temp_dir("daemon_gles");
    nlohmann::json cfg = {{"scene", kScene},
                          {"clock", "sim"},
                          {"tracker", {{"type", "sim"}, {"trace", kTrace}}},
                          {"display", {{"eye_width", 32}, {"eye_height", 32}}},
                          {"renderer", {{"backend", "gles"}}},
                          {"status", {{"path", (dir / "status.json").string()}, {"every_s", 0.2}}}};
    write(dir / "hmdnoded.json", cfg.dump(1));
    CommandRun r = run(std::string(HMDNODE_DAEMON) + " --config " +
                       (dir / "hmdnoded.json").string() + " --max-frames 40");
    ASSERT_EQ(r.code, 0) << r.output;
    std::ifstream in(dir / "status.json");
    nlohmann::json s = nlohmann::json::parse(in);
    EXPECT_EQ(s["renderer_backend"], "gles");
    EXPECT_GT(s["triangles"].get<int>(), 0);
    cfg["renderer"]["backend"] = "metal";
    write(dir / "hmdnoded.json", cfg.dump(1));
    r = run(std::string(HMDNODE_DAEMON) + " --config " + (dir / "hmdnoded.json").string());
    EXPECT_EQ(r.code, 2);
    EXPECT_NE(r.output.find("renderer.backend \"metal\" is not one of vulkan, gles"),
              std::string::npos)
        << r.output;
}

TEST(Daemon, BadConfigNamesTheKeyAndExitsNonZero) {
    fs::path dir = temp_dir("daemon_bad");
    write(dir / "hmdnoded.json",
          R"({"scene": "x.glb", "tracker": {"trace": "t.csv", "lop": true}})");
    CommandRun r =
        run(std::string(HMDNODE_DAEMON) + " --config " + (dir / "hmdnoded.json").string());
    EXPECT_EQ(r.code, 2);
    EXPECT_NE(r.output.find("tracker.lop"), std::string::npos) << r.output;
    write(dir / "hmdnoded.json", R"({"scene": "x.glb", )");
    r = run(std::string(HMDNODE_DAEMON) + " --config " + (dir / "hmdnoded.json").string());
    EXPECT_EQ(r.code, 2);
    EXPECT_NE(r.output.find("not valid JSON"), std::string::npos) << r.output;
}

TEST(DemoScene, HasTheRoomAndTheLodChainsTheDemoNeeds) {
    CommandRun r = run(kTool + " scene info " + kScene);
    ASSERT_EQ(r.code, 0) << r.output;
    for (const char* part : {"bunny", "spot", "sphere"})
        EXPECT_NE(r.output.find(part), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("69451"), std::string::npos) << r.output;  // the bunny's full level
}
