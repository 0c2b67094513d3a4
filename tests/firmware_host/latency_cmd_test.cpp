// `hmdnode latency` as a user runs it on the deterministic simulated clock (fixed frame cost, tiny
// eyes, short runs): the four modes, warp beating no warp on head flicks, per-vsync accounting,
// the SVG; bad options exit 2, a bad trace exits 1 and writes nothing. And the motion profiles'
// formulas: peak speeds, continuity, the sweep's frequencies.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "firmware_host/command_run.hpp"
#include "hmdnode/core/pose.hpp"
#include "hmdnode/firmware_host/latency_report.hpp"
#include "hmdnode/firmware_host/motion_profiles.hpp"

namespace fs = std::filesystem;
using hmdnode::test::CommandRun;
using hmdnode::test::run;

namespace {

const std::string kTool = HMDNODE_TOOL;
const std::string kScene = HMDNODE_DEMO_SCENE;
const std::string kSim =
    " --clock sim --frame-cost-ms 4 --eye-width 64 --eye-height 64 --quiet --scene " + kScene;

std::string slurp(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

// Yaw (degrees) of a yaw-only orientation.
double yaw_deg(const glm::dquat& q) {
    return hmdnode::rad_to_deg(2.0 * std::atan2(q.y, q.w));
}

// Largest |yaw step| / dt between consecutive samples, deg/s.
double max_speed_dps(const hmdnode::Trace& t) {
    double m = 0.0;
    for (size_t i = 1; i < t.samples.size(); ++i) {
        const double dt = double(t.samples[i].time_ns - t.samples[i - 1].time_ns) * 1e-9;
        m = std::max(
            m, hmdnode::angle_between_deg(t.samples[i].orientation, t.samples[i - 1].orientation) /
                   dt);
    }
    return m;
}

// Tags open and close in order (self-closing ones count as both), nothing after the root.
bool balanced_xml(const std::string& s) {
    std::vector<std::string> stack;
    size_t i = 0;
    bool closed_root = false;
    while ((i = s.find('<', i)) != std::string::npos) {
        if (closed_root) return false;
        const size_t end = s.find('>', i);
        if (end == std::string::npos) return false;
        const std::string tag = s.substr(i + 1, end - i - 1);
        i = end + 1;
        if (tag.empty()) return false;
        if (tag[0] == '/') {
            if (stack.empty() || stack.back() != tag.substr(1)) return false;
            stack.pop_back();
            closed_root = stack.empty();
        } else if (tag.back() != '/') {
            stack.push_back(tag.substr(0, tag.find_first_of(" \n\t")));
        }
    }
    return stack.empty() && closed_root;
}

const nlohmann::json& mode(const nlohmann::json& report, const std::string& name) {
    for (const nlohmann::json& m : report["modes"])
        if (m["name"] == name) return m;
    static const nlohmann::json none;
    ADD_FAILURE() << "no mode " << name;
    return none;
}

}  // namespace

TEST(MotionProfiles, StepFlicksPeakAtTwiceTheMeanSpeedAndAreContinuous) {
    const hmdnode::StepProfile p;  // 30 deg in 60 ms, 0.5 s holds
    const hmdnode::Trace t = hmdnode::make_step_trace(p, 2.3, 1000.0);
    ASSERT_EQ(t.samples.size(), 2301u);
    EXPECT_EQ(t.samples[1].time_ns, 1'000'000);
    EXPECT_FALSE(t.samples[0].position.has_value());
    // Holds at 0 and 30 deg, the turns between.
    EXPECT_NEAR(yaw_deg(t.samples[400].orientation), 0.0, 1e-9);
    EXPECT_NEAR(yaw_deg(t.samples[530].orientation), 15.0, 1e-9);  // half way: half the turn
    EXPECT_NEAR(yaw_deg(t.samples[800].orientation), 30.0, 1e-9);
    EXPECT_NEAR(yaw_deg(t.samples[1150].orientation), 0.0, 1e-9);    // back after the second turn
    EXPECT_NEAR(hmdnode::step_yaw(p, 0.53).rate_dps, 1000.0, 1e-9);  // 2A/T
    EXPECT_NEAR(hmdnode::step_yaw(p, 1.09).rate_dps, -1000.0, 1e-9);
    // Finite differences: the peak speed, and no jump anywhere (1 ms at 1000 deg/s = 1 deg).
    EXPECT_NEAR(max_speed_dps(t), 1000.0, 2.0);
    // Speed is continuous at the ends of a turn (raised cosine): tiny at 1 ms into it.
    EXPECT_LT(hmdnode::step_yaw(p, 0.501).rate_dps, 6.0);
    EXPECT_LT(std::abs(hmdnode::step_yaw(p, 0.559).rate_dps), 6.0);
}

TEST(MotionProfiles, SineSweepGoesFromPointTwoToTwoHertzAtTwentyDegrees) {
    const hmdnode::SineSweepProfile p;
    const double d = 10.0;
    const hmdnode::Trace t = hmdnode::make_sine_sweep_trace(p, d, 1000.0);
    ASSERT_EQ(t.samples.size(), 10001u);
    double max_yaw = 0.0;
    for (const hmdnode::TraceSample& s : t.samples)
        max_yaw = std::max(max_yaw, std::abs(yaw_deg(s.orientation)));
    EXPECT_NEAR(max_yaw, 20.0, 0.01);
    EXPECT_NEAR(hmdnode::sine_sweep_yaw(p, d, 0.0).rate_dps, 20.0 * 2 * hmdnode::kPi * 0.2, 1e-9);
    // Peak speed A 2 pi f1 is approached near the end; never exceeded.
    EXPECT_LT(max_speed_dps(t), 20.0 * 2 * hmdnode::kPi * 2.0 + 1.0);
    EXPECT_GT(max_speed_dps(t), 0.9 * 20.0 * 2 * hmdnode::kPi * 2.0);
    // Numerical derivative of the yaw matches the stated rate.
    for (double ts : {0.5, 3.3, 7.7, 9.9}) {
        const double h = 1e-6;
        const double num = (hmdnode::sine_sweep_yaw(p, d, ts + h).yaw_deg -
                            hmdnode::sine_sweep_yaw(p, d, ts - h).yaw_deg) /
                           (2 * h);
        EXPECT_NEAR(num, hmdnode::sine_sweep_yaw(p, d, ts).rate_dps, 1e-3) << ts;
    }
    EXPECT_FALSE(hmdnode::make_motion_profile("zigzag", 1.0).ok());
}

TEST(LatencyModes, ParsesListsAndRejectsUnknownNames) {
    EXPECT_EQ(hmdnode::parse_latency_modes("all")->size(), 4u);
    auto two = hmdnode::parse_latency_modes("warp,predict");
    ASSERT_TRUE(two.ok());
    EXPECT_TRUE((*two)[0].warp && !(*two)[0].predict);
    EXPECT_TRUE((*two)[1].predict && !(*two)[1].warp);
    EXPECT_FALSE(hmdnode::parse_latency_modes("warp,warp").ok());
    EXPECT_FALSE(hmdnode::parse_latency_modes("fast").ok());
    EXPECT_FALSE(hmdnode::parse_latency_modes("").ok());
}

TEST(LatencyCommand, WarpBeatsNoWarpOnHeadFlicksAndEveryVsyncIsCounted) {
    const fs::path dir = hmdnode::test::fresh_temp_dir("hmdnode_latency_cmd_test_step");
    const fs::path report = dir / "r.json", plot = dir / "p.svg";
    const CommandRun r = run(kTool + " latency" + kSim + " --profile step --duration 2 --report " +
                             report.string() + " --plot " + plot.string());
    ASSERT_EQ(r.code, 0) << r.output;
    EXPECT_NE(r.output.find("predict+warp"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("MTP p99 (ms)"), std::string::npos) << r.output;
    const nlohmann::json j = nlohmann::json::parse(slurp(report));
    EXPECT_EQ(j["format"], "hmdnode-latency-report/1");
    EXPECT_EQ(j["options"]["clock"], "sim");
    ASSERT_EQ(j["modes"].size(), 4u);
    for (const nlohmann::json& m : j["modes"]) {
        const nlohmann::json& s = m["summary"];
        const size_t vsyncs = s["vsyncs"];
        EXPECT_GT(vsyncs, 150u) << m["name"];  // 2 s at 90 Hz
        EXPECT_EQ(vsyncs, s["missed_vsyncs"].get<size_t>() + s["on_time_vsyncs"].get<size_t>());
        EXPECT_NEAR(s["on_time_rate"].get<double>(),
                    s["on_time_vsyncs"].get<double>() / double(vsyncs), 1e-12);
        // The series is the same vsync walk the summary counts.
        const nlohmann::json& series = m["series"];
        ASSERT_EQ(series["latency_ms"].size(), vsyncs);
        ASSERT_EQ(series["registration_error_deg"].size(), vsyncs);
        size_t on_time = 0;
        std::vector<double> lat;
        double err_max = 0.0;
        for (size_t i = 0; i < vsyncs; ++i) {
            on_time += series["on_time"][i].get<bool>() ? 1 : 0;
            lat.push_back(series["latency_ms"][i]);
            if (!series["registration_error_deg"][i].is_null())
                err_max = std::max(err_max, series["registration_error_deg"][i].get<double>());
        }
        EXPECT_EQ(on_time, s["on_time_vsyncs"].get<size_t>());
        std::sort(lat.begin(), lat.end());
        EXPECT_NEAR(lat.back(), s["latency_ms"]["max"].get<double>(), 1e-3);
        EXPECT_NEAR(err_max, s["registration_error_deg"]["max"].get<double>(), 1e-3);
    }
    // Warp: the image is corrected to a pose sampled just before the latch.
    for (const auto& [on, off] : {std::pair{"warp", "none"}, {"predict+warp", "predict"}}) {
        const nlohmann::json& w = mode(j, on)["summary"];
        const nlohmann::json& n = mode(j, off)["summary"];
        EXPECT_LT(w["registration_error_deg"]["p99"].get<double>(),
                  n["registration_error_deg"]["p99"].get<double>())
            << on << " vs " << off;
        EXPECT_LT(w["latency_ms"]["p50"].get<double>(), n["latency_ms"]["p50"].get<double>())
            << on << " vs " << off;
    }
    // Prediction helps too, with and without the warp.
    // (p50 is 0 everywhere: most of the time the head holds still.)
    EXPECT_LT(mode(j, "predict+warp")["summary"]["registration_error_deg"]["p95"].get<double>(),
              mode(j, "warp")["summary"]["registration_error_deg"]["p95"].get<double>());
    EXPECT_LT(mode(j, "predict")["summary"]["registration_error_deg"]["p95"].get<double>(),
              mode(j, "none")["summary"]["registration_error_deg"]["p95"].get<double>());

    const std::string svg = slurp(plot);
    ASSERT_EQ(svg.rfind("<svg", 0), 0u) << svg.substr(0, 80);
    EXPECT_TRUE(balanced_xml(svg));
    for (const char* name : {"none", "predict", "warp", "predict+warp", "% of vsyncs"})
        EXPECT_NE(svg.find(name), std::string::npos) << name;
}

TEST(LatencyCommand, SimClockRunsAreDeterministicAndModesCanBePicked) {
    const fs::path dir = hmdnode::test::fresh_temp_dir("hmdnode_latency_cmd_test_modes");
    auto once = [&](const std::string& name) {
        const fs::path report = dir / name;
        const CommandRun r =
            run(kTool + " latency" + kSim +
                " --profile sine-sweep --duration 1 --modes warp,none --report " + report.string());
        EXPECT_EQ(r.code, 0) << r.output;
        nlohmann::json j = nlohmann::json::parse(slurp(report));
        // Everything but the measured wall times (render and warp calls, the whole run).
        for (nlohmann::json& m : j["modes"])
            for (const char* k : {"wall_s", "render_ms", "warp_ms"}) m["summary"].erase(k);
        return j;
    };
    const nlohmann::json a = once("a.json"), b = once("b.json");
    ASSERT_EQ(a["modes"].size(), 2u);
    EXPECT_EQ(a["modes"][0]["name"], "warp");
    EXPECT_EQ(a["modes"][1]["name"], "none");
    EXPECT_EQ(a, b);
}

TEST(LatencyCommand, RecordedTraceProfile) {
    const fs::path dir = hmdnode::test::fresh_temp_dir("hmdnode_latency_cmd_test_trace");
    const fs::path report = dir / "r.json";
    const CommandRun r =
        run(kTool + " latency" + kSim + " --profile trace --trace " +
            HMDNODE_SOURCE_DIR "/data/traces/corbillon2018_user1.csv" +
            " --start 20 --duration 1 --modes predict+warp --report " + report.string());
    ASSERT_EQ(r.code, 0) << r.output;
    const nlohmann::json j = nlohmann::json::parse(slurp(report));
    EXPECT_EQ(j["options"]["start_s"], 20.0);
    EXPECT_GT(j["modes"][0]["summary"]["vsyncs"].get<int>(), 80);
}

TEST(LatencyCommand, BadOptionsExitTwoAndBadInputExitsOneWritingNothing) {
    const fs::path dir = hmdnode::test::fresh_temp_dir("hmdnode_latency_cmd_test_bad");
    const fs::path report = dir / "r.json", plot = dir / "p.svg";
    const std::string outs = " --report " + report.string() + " --plot " + plot.string();
    struct Case {
        std::string args, names;
    };
    for (const Case& c : std::vector<Case>{
             {" --profile zigzag", "--profile"},
             {" --modes warp,fast", "fast"},
             {" --duration -1", "--duration"},
             {" --duration abc", "--duration"},
             {" --eye-width 0", "--eye-width"},
             {" --trace x.csv", "--trace"},  // without --profile trace
             {" --bogus 1", "--bogus"},
         }) {
        const CommandRun r = run(kTool + " latency" + kSim + c.args + outs);
        EXPECT_EQ(r.code, 2) << c.args << "\n" << r.output;
        EXPECT_NE(r.output.find(c.names), std::string::npos) << c.args << "\n" << r.output;
    }
    const CommandRun no_scene = run(kTool + " latency --clock sim" + outs);
    EXPECT_EQ(no_scene.code, 2) << no_scene.output;
    EXPECT_NE(no_scene.output.find("--scene"), std::string::npos) << no_scene.output;

    // A trace that is not one, a missing trace, a missing scene: exit 1 naming the file.
    std::ofstream(dir / "bad.csv") << "time_ns,qw,qx,qy,qz\n0,1,0,0,0\nbanana\n";
    for (const std::string& args :
         std::vector<std::string>{" --profile trace --trace " + (dir / "bad.csv").string(),
                                  " --profile trace --trace " + (dir / "missing.csv").string(),
                                  " --profile trace --trace " HMDNODE_SOURCE_DIR
                                  "/data/traces/corbillon2018_user1.csv --start 100000"}) {
        const CommandRun r = run(kTool + " latency" + kSim + args + outs);
        EXPECT_EQ(r.code, 1) << args << "\n" << r.output;
        EXPECT_NE(r.output.find(".csv"), std::string::npos) << r.output;
    }
    const CommandRun bad_scene =
        run(kTool +
            " latency --clock sim --frame-cost-ms 4 --eye-width 64 --eye-height 64 "
            "--duration 0.5 --scene " +
            (dir / "nothing.glb").string() + outs);
    EXPECT_EQ(bad_scene.code, 1) << bad_scene.output;
    EXPECT_NE(bad_scene.output.find("nothing.glb"), std::string::npos) << bad_scene.output;
    EXPECT_FALSE(fs::exists(report));
    EXPECT_FALSE(fs::exists(plot));
    size_t files = 0;
    for (const auto& e : fs::directory_iterator(dir)) files += e.path() != dir / "bad.csv";
    EXPECT_EQ(files, 0u);  // no temporary left behind either
}
