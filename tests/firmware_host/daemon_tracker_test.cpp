// hmdnoded's tracker config (docs/daemon.md): the simulated reference tracker through the device
// path (transport -> reference codec -> clock sync -> DeviceTracker) drives the frame loop, and
// the status file reports the tracker; a bad tracker.device names the key and exits 2.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include <nlohmann/json.hpp>

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
    fs::path d = fs::temp_directory_path() / ("hmdnode_daemon_tracker_test_" + name);
    fs::remove_all(d);
    fs::create_directories(d);
    return d;
}

TEST(DaemonTracker, sim_device_drives_the_frame_loop_and_reports_its_status) {
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
    EXPECT_NE(r.output.find("tracker sim-device 1209:0001"), std::string::npos) << r.output;
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

TEST(DaemonTracker, bad_device_names_the_key) {
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

}  // namespace
