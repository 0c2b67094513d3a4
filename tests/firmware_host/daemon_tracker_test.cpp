// hmdnoded's tracker config (docs/daemon.md): the simulated reference tracker through the device
// path (transport -> reference codec -> clock sync -> DeviceTracker) drives the frame loop, and
// the status file reports the tracker; a bad tracker.device names the key and exits 2; a tracker
// that never delivers (a device that is not plugged in) leaves the daemon waiting in its frame
// loop, reporting it, and SIGTERM stops it cleanly.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>

#include <nlohmann/json.hpp>
#include "firmware_host/command_run.hpp"

namespace {

namespace fs = std::filesystem;

struct DaemonRun {
    int code = -1;
    std::string output;
};

DaemonRun run_daemon(const fs::path& config, int max_frames) {
    DaemonRun r;
    const std::string cmd = std::string(HMDNODE_DAEMON) + " --config " + config.string() +
                            " --max-frames " + std::to_string(max_frames) + " 2>&1";
    FILE* p = popen(cmd.c_str(), "r");
    if (!p) return r;
    char buf[4096];
    size_t n;
    while ((n = fread(buf, 1, sizeof buf, p)) > 0) r.output.append(buf, n);
    const int st = pclose(p);
    r.code = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
    return r;
}

fs::path temp_dir(const std::string& name) {
    return hmdnode::test::fresh_temp_dir("hmdnode_daemon_tracker_test_" + name);
}

TEST(DaemonTracker, SimDeviceDrivesTheFrameLoopAndReportsItsStatus) {
    const fs::path dir = temp_dir("sim_device");
    nlohmann::json cfg = {
        {"scene", HMDNODE_DEMO_SCENE},
        {"clock", "sim"},
        {"tracker", {{"backend", "sim-device"}, {"device", "1209:0001"}, {"serial", "D-1"}}},
        {"display", {{"eye_width", 32}, {"eye_height", 32}, {"refresh_hz", 90}}},
        {"status", {{"path", (dir / "status.json").string()}, {"every_s", 0.5}}}};
    std::ofstream(dir / "hmdnoded.json") << cfg.dump(1);
    const DaemonRun r = run_daemon(dir / "hmdnoded.json", 120);
    ASSERT_EQ(r.code, 0) << r.output;
    // The older spelling still works, with a warning naming the new value.
    EXPECT_NE(r.output.find("tracker sim: 1209:0001"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("tracker.backend \"sim-device\" is deprecated: write tracker.backend "
                            "\"sim\""),
              std::string::npos)
        << r.output;
    std::ifstream in(dir / "status.json");
    const nlohmann::json s = nlohmann::json::parse(in);
    EXPECT_EQ(s["errors"].get<int>(), 0);
    ASSERT_TRUE(s.contains("tracker")) << s.dump(1);
    const nlohmann::json& t = s["tracker"];
    EXPECT_TRUE(t["connected"].get<bool>());
    EXPECT_EQ(t["opens"].get<int>(), 1);
    EXPECT_EQ(t["disconnects"].get<int>(), 0);
    EXPECT_EQ(t["sequence_gaps"].get<int>(), 0);
    // 1 kHz: at least 45 frames at 90 Hz (0.5 s) worth of samples by the first status write.
    EXPECT_GE(t["samples"].get<int>(), 450);
}

TEST(DaemonTracker, BadDeviceNamesTheKey) {
    const fs::path dir = temp_dir("bad");
    std::ofstream(dir / "hmdnoded.json")
        << R"({"scene": "x.glb", "tracker": {"backend": "hidapi", "device": "28de-2000"}})";
    const DaemonRun r = run_daemon(dir / "hmdnoded.json", 1);
    EXPECT_EQ(r.code, 2);
    EXPECT_NE(r.output.find("tracker.device"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("28de-2000"), std::string::npos) << r.output;

    std::ofstream(dir / "hmdnoded.json")
        << R"({"scene": "x.glb", "tracker": {"backend": "bluetooth"}})";
    const DaemonRun b = run_daemon(dir / "hmdnoded.json", 1);
    EXPECT_EQ(b.code, 2);
    EXPECT_NE(b.output.find("tracker.backend \"bluetooth\""), std::string::npos) << b.output;
}

// A real-clock daemon whose hidapi device is absent (1209:0001 is the reference tracker's id; no
// such device is plugged into a test machine -- skipped where one is). Before the fix the frame
// loop waited for the first sample without looking at signals.
TEST(DaemonTracker, AbsentDeviceIsWaitedForAndSigtermStopsTheDaemon) {
    const fs::path dir = temp_dir("absent");
    const fs::path status = dir / "status.json";
    const fs::path log = dir / "daemon.log";
    nlohmann::json cfg = {{"scene", HMDNODE_DEMO_SCENE},
                          {"clock", "real"},
                          {"tracker", {{"backend", "hidapi"}, {"device", "1209:0001"}}},
                          {"display", {{"eye_width", 32}, {"eye_height", 32}, {"refresh_hz", 90}}},
                          {"status", {{"path", status.string()}, {"every_s", 0.2}}}};
    std::ofstream(dir / "hmdnoded.json") << cfg.dump(1);

    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 1, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_adddup2(&actions, 1, 2);
    const std::string daemon = HMDNODE_DAEMON, config = (dir / "hmdnoded.json").string();
    char* argv[] = {const_cast<char*>(daemon.c_str()), const_cast<char*>("--config"),
                    const_cast<char*>(config.c_str()), nullptr};
    pid_t pid = -1;
    ASSERT_EQ(posix_spawn(&pid, daemon.c_str(), &actions, nullptr, argv, environ), 0);
    posix_spawn_file_actions_destroy(&actions);
    auto read_log = [&] {
        std::ifstream in(log);
        std::stringstream ss;
        ss << in.rdbuf();
        return ss.str();
    };
    // Waits (bounded) for the child to exit; -1 while it still runs.
    auto wait_exit = [&](std::chrono::seconds limit) {
        const auto until = std::chrono::steady_clock::now() + limit;
        int st = 0;
        while (std::chrono::steady_clock::now() < until) {
            if (waitpid(pid, &st, WNOHANG) == pid) return WIFEXITED(st) ? WEXITSTATUS(st) : 128;
            std::this_thread::sleep_for(std::chrono::milliseconds(20));
        }
        return -1;
    };

    // The daemon is in its frame loop once it has written a status file (renderer start-up on a
    // loaded machine can take a while; the bound is generous).
    const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    while (!fs::exists(status) && std::chrono::steady_clock::now() < until) {
        int st = 0;
        if (waitpid(pid, &st, WNOHANG) == pid) FAIL() << "daemon exited early:\n" << read_log();
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    if (!fs::exists(status)) {
        kill(pid, SIGKILL);
        waitpid(pid, nullptr, 0);
        FAIL() << "no status file:\n" << read_log();
    }
    std::ifstream in(status);
    const nlohmann::json s = nlohmann::json::parse(in);
    if (s["tracker"]["samples"].get<int>() > 0) {
        kill(pid, SIGTERM);
        wait_exit(std::chrono::seconds(30));
        GTEST_SKIP() << "a device 1209:0001 is plugged in";
    }

    const auto term = std::chrono::steady_clock::now();
    ASSERT_EQ(kill(pid, SIGTERM), 0);
    // Promptly: the frame loop never waits more than about a display period (the bound here only
    // keeps a hung daemon from hanging the test; the time taken is printed, not asserted).
    const int code = wait_exit(std::chrono::seconds(10));
    if (code == -1) {
        kill(pid, SIGKILL);
        waitpid(pid, nullptr, 0);
        FAIL() << "hmdnoded did not stop on SIGTERM:\n" << read_log();
    }
    std::printf(
        "hmdnoded exited %.0f ms after SIGTERM\n",
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - term).count());
    EXPECT_EQ(code, 0) << read_log();
    const std::string out = read_log();
    EXPECT_NE(out.find("waiting for tracker 1209:0001 via hidapi"), std::string::npos) << out;
    EXPECT_NE(out.find("stopped after 0 frames (0 failed)"), std::string::npos) << out;
    EXPECT_EQ(s["frames"].get<int>(), 0) << s.dump(1);
    EXPECT_EQ(s["errors"].get<int>(), 0) << s.dump(1);
    EXPECT_FALSE(s["has_pose"].get<bool>()) << s.dump(1);
    EXPECT_GT(s["no_pose_frames"].get<int>(), 0) << s.dump(1);
    EXPECT_TRUE(s["latency_ms"]["p50"].is_null()) << s.dump(1);
    ASSERT_TRUE(s.contains("tracker")) << s.dump(1);
    EXPECT_FALSE(s["tracker"]["connected"].get<bool>()) << s.dump(1);
    EXPECT_EQ(s["tracker"]["opens"].get<int>(), 0) << s.dump(1);
}

}  // namespace
