// `hmdnode capture info` and `hmdnode replay --capture` as a user runs them, on the real Vive
// capture in ../shared/data/traces (skipped when absent) and on bad input.
#include <gtest/gtest.h>

#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

namespace fs = std::filesystem;

namespace {

struct CommandRun {
    int code = -1;
    std::string output;  // stdout and stderr
};

CommandRun run(const std::string& cmd) {
    CommandRun r;
    FILE* p = popen((cmd + " 2>&1").c_str(), "r");
    if (!p) return r;
    std::array<char, 4096> buf;
    size_t n;
    while ((n = fread(buf.data(), 1, buf.size(), p)) > 0) r.output.append(buf.data(), n);
    const int st = pclose(p);
    r.code = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
    return r;
}

fs::path temp_dir(const std::string& name) {
    fs::path d = fs::temp_directory_path() / ("hmdnode_capture_cmd_test_" + name);
    fs::remove_all(d);
    fs::create_directories(d);
    return d;
}

const std::string kTool = HMDNODE_TOOL;
const std::string kScene = HMDNODE_DEMO_SCENE;
const fs::path kCapture = fs::path(HMDNODE_SHARED_DIR) / "data/traces/vive_cal.pcap.gz";

bool has(const std::string& s, const std::string& part) {
    return s.find(part) != std::string::npos;
}

TEST(CaptureCmd, InfoSummarisesTheRealViveCapture) {
    if (!fs::exists(kCapture)) GTEST_SKIP() << kCapture << " is absent";
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
    if (!fs::exists(kCapture)) GTEST_SKIP() << kCapture << " is absent";
    const fs::path dir = temp_dir("replay");
    const fs::path report = dir / "report.json";
    CommandRun r = run(kTool + " replay --quiet --eye-width 32 --eye-height 32 --max-frames 120 " +
                       "--scene " + kScene + " --capture " + kCapture.string() +
                       " --device 28de:2000 --report " + report.string());
    ASSERT_EQ(r.code, 0) << r.output;
    std::ifstream in(report);
    const nlohmann::json j = nlohmann::json::parse(in);
    EXPECT_EQ(j["summary"]["frames"], 120);
    // 120 frames at 90 Hz cover ~1.33 s of a ~987 samples/s capture.
    EXPECT_GT(j["trace_samples"].get<double>(), 1000.0);
    EXPECT_LT(j["trace_samples"].get<double>(), 1500.0);
    // The headset lies still on a table: the fused pose (and so the view) does not turn.
    EXPECT_LT(j["frames"].back()["angular_speed_dps"].get<double>(), 3.0);
}

TEST(CaptureCmd, ReplayNamesTheDevicesWhenTheOneAskedForIsAbsent) {
    if (!fs::exists(kCapture)) GTEST_SKIP() << kCapture << " is absent";
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

}  // namespace
