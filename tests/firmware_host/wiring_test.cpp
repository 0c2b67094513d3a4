// The one wiring place (firmware_host/include/hmdnode/firmware_host/wiring.hpp): one backend
// vocabulary, the same string in the daemon's config and on the command line; older spellings
// with a warning naming the new value; errors naming the key (config) or the flag (command line);
// the daemon replays the bundled capture and `hmdnode replay` takes the same backend.
#include "hmdnode/firmware_host/wiring.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>

#include <nlohmann/json.hpp>

#include "firmware_host/command_run.hpp"
#include "hmdnode/hal/tracking/base_station_placement.hpp"
#include "hmdnode/hal/tracking/device_tracker.hpp"

namespace hmdnode {
namespace {

namespace fs = std::filesystem;
const std::string kCapture = HMDNODE_SOURCE_DIR "/data/traces/vive_cal.pcap.gz";

bool contains(const std::string& s, const std::string& part) {
    return s.find(part) != std::string::npos;
}

TEST(Wiring, OneVocabularyWithTheOlderSpellingsWarned) {
    for (const char* name : {"trace", "sim", "capture", "rec", "hidapi", "libusb"}) {
        std::string warning;
        Result<TrackerBackend> b = parse_tracker_backend(name, WiringKeys::config(), &warning);
        ASSERT_TRUE(b.ok()) << name;
        EXPECT_STREQ(tracker_backend_name(*b), name);
        EXPECT_TRUE(warning.empty()) << warning;
    }
    std::string warning;
    Result<TrackerBackend> old =
        parse_tracker_backend("sim-device", WiringKeys::config(), &warning);
    ASSERT_TRUE(old.ok());
    EXPECT_EQ(*old, TrackerBackend::sim);
    EXPECT_EQ(warning,
              "tracker.backend \"sim-device\" is deprecated: write tracker.backend \"sim\"");
    old = parse_tracker_backend("sim-trace", WiringKeys::command_line(), &warning);
    ASSERT_TRUE(old.ok());
    EXPECT_EQ(*old, TrackerBackend::trace);
    EXPECT_EQ(warning, "--tracker \"sim-trace\" is deprecated: write --tracker \"trace\"");

    // An unknown name: the key (or flag) and the names.
    Result<TrackerBackend> bad = parse_tracker_backend("bluetooth", WiringKeys::config());
    ASSERT_FALSE(bad.ok());
    EXPECT_EQ(bad.error().message,
              "tracker.backend \"bluetooth\" is not one of trace, sim, capture, rec, hidapi, "
              "libusb");
    bad = parse_tracker_backend("bluetooth", WiringKeys::command_line());
    ASSERT_FALSE(bad.ok());
    EXPECT_TRUE(contains(bad.error().message, "--tracker \"bluetooth\"")) << bad.error().message;
    Result<ClockKind> c = parse_clock("wall", WiringKeys::command_line());
    ASSERT_FALSE(c.ok());
    EXPECT_EQ(c.error().message, "--clock \"wall\" is not real or sim");
}

TEST(Wiring, SpecErrorsNameTheKey) {
    TrackerSpec s;
    s.backend = TrackerBackend::capture;
    s.device = "28de:2000";
    Status st = check_tracker_spec(s, ClockKind::sim, WiringKeys::config());
    ASSERT_FALSE(st.ok());
    EXPECT_TRUE(contains(st.error().message,
                         "tracker.from is required for tracker.backend "
                         "capture"))
        << st.error().message;
    st = check_tracker_spec(s, ClockKind::sim, WiringKeys::command_line());
    ASSERT_FALSE(st.ok());
    EXPECT_TRUE(contains(st.error().message, "--from is required for --tracker capture"))
        << st.error().message;

    s.backend = TrackerBackend::hidapi;
    s.device = "1209:0001";
    st = check_tracker_spec(s, ClockKind::sim, WiringKeys::command_line());
    ASSERT_FALSE(st.ok());
    EXPECT_TRUE(contains(st.error().message, "it needs --clock real")) << st.error().message;
    s.device = "12x9:0001";
    st = check_tracker_spec(s, ClockKind::real, WiringKeys::config());
    ASSERT_FALSE(st.ok());
    EXPECT_TRUE(contains(st.error().message, "tracker.device")) << st.error().message;

    s = TrackerSpec();  // trace, no trace
    st = check_tracker_spec(s, ClockKind::sim, WiringKeys::config());
    ASSERT_FALSE(st.ok());
    EXPECT_EQ(st.error().message, "tracker.trace is required for tracker.backend trace");

    DisplaySpec d;
    d.type = "hologram";
    st = check_display_spec(d, WiringKeys::config());
    ASSERT_FALSE(st.ok());
    EXPECT_TRUE(contains(st.error().message,
                         "display.type \"hologram\" is not one of mock, kms, vk-display"))
        << st.error().message;
}

// The capture backend through the wiring: a device tracker over the capture's device, which
// delivers samples as the simulated clock passes their arrival.
TEST(Wiring, CaptureBackendMakesADeviceTracker) {
    if (!fs::exists(kCapture)) GTEST_SKIP() << kCapture << " is missing";
    std::unique_ptr<Clock> clock = make_clock(ClockKind::sim, kNsPerSecond);
    TrackerSpec s;
    s.backend = TrackerBackend::capture;
    s.from = kCapture;
    s.device = "28de:2000";
    Result<WiredTracker> t = make_tracker(s, *clock, WiringKeys::config());
    ASSERT_TRUE(t.ok()) << t.error().message;
    ASSERT_NE(t->device, nullptr);
    EXPECT_TRUE(contains(t->label, "28de:2000")) << t->label;
    ASSERT_TRUE(t->tracker->start().ok());
    auto* sim = static_cast<SimulatedClock*>(clock.get());
    std::vector<TrackerSample> buf(256);
    size_t got = 0;
    for (int i = 0; i < 300 && got == 0; ++i) {
        sim->advance_ns(10 * kNsPerMs);
        // note: the reader thread decodes what has arrived; a short wait for it (not a timing).
        for (int k = 0; k < 100 && got == 0; ++k) {
            got += t->tracker->read(buf);
            if (got == 0) std::this_thread::sleep_for(std::chrono::milliseconds(1));
        }
    }
    t->tracker->stop();
    EXPECT_GT(got, 0u);
    // A missing file names the key.
    s.from = "/no/such.pcap";
    t = make_tracker(s, *clock, WiringKeys::config());
    ASSERT_FALSE(t.ok());
    EXPECT_EQ(t.error().message, "tracker.from /no/such.pcap: no such file");
}

// tracker.place_base_stations with a setup file not there yet (a box's first start): the
// recording's tracker places the base stations itself from the device's still stretch,
// save_placed_setup writes them to the file, and the next start loads them as its stored setup.
TEST(Wiring, BaseStationsPlacedInTheTrackerAreStoredAndReusedOnTheNextStart) {
    const fs::path dir = fs::path(testing::TempDir()) / "wiring_place";
    fs::remove_all(dir);
    fs::create_directories(dir);
    std::unique_ptr<Clock> clock = make_clock(ClockKind::sim, kNsPerSecond);
    TrackerSpec s;
    s.backend = TrackerBackend::rec;
    s.from = HMDNODE_SOURCE_DIR "/data/traces/lh2_test_cal.rec.gz";
    s.device = "T20";
    s.base_stations = dir / "base_stations.json";
    s.place_base_stations = true;
    ASSERT_TRUE(check_tracker_spec(s, ClockKind::sim, WiringKeys::config()).ok());
    auto stored = stored_base_stations(s);
    ASSERT_TRUE(stored.ok()) << stored.error().message;
    EXPECT_EQ(*stored, 0u);
    Result<WiredTracker> t = make_tracker(s, *clock, WiringKeys::config());
    ASSERT_TRUE(t.ok()) << t.error().message;
    ASSERT_NE(t->device, nullptr);
    EXPECT_TRUE(t->tracker->info().provides_position);
    ASSERT_TRUE(t->tracker->start().ok());
    auto* sim = static_cast<SimulatedClock*>(clock.get());
    std::vector<TrackerSample> buf(1024);
    size_t with_position = 0;
    while (!t->tracker->finished()) {
        sim->advance_ns(10 * kNsPerMs);
        for (size_t n = t->tracker->read(buf); n > 0; n = t->tracker->read(buf))
            for (size_t i = 0; i < n; ++i) with_position += buf[i].position.has_value();
    }
    t->tracker->stop();
    EXPECT_GT(with_position, 500u);
    size_t count = *stored;
    ASSERT_TRUE(save_placed_setup(s, *t->device, &count).ok());
    EXPECT_EQ(count, 2u);  // the recording's two base stations
    auto loaded = lighthouse::load_base_station_setup(s.base_stations);
    ASSERT_TRUE(loaded.ok()) << loaded.error().message;
    ASSERT_EQ(loaded->size(), 2u);
    for (const lighthouse::BaseStationPlacement& b : *loaded) {
        EXPECT_TRUE(b.calibration.has_value());  // placed once its calibration had arrived
        EXPECT_GT(b.residual_rms_rad, 0.0);
        EXPECT_LT(b.residual_rms_rad, 1e-3);
        EXPECT_GT(b.solved_unix_s, 0);
    }
    // Nothing new: nothing written again.
    ASSERT_TRUE(save_placed_setup(s, *t->device, &count).ok());
    EXPECT_EQ(count, 2u);
    // The next start: the stored setup.
    stored = stored_base_stations(s);
    ASSERT_TRUE(stored.ok()) << stored.error().message;
    EXPECT_EQ(*stored, 2u);
    t = make_tracker(s, *clock, WiringKeys::config());
    ASSERT_TRUE(t.ok()) << t.error().message;
    EXPECT_TRUE(contains(t->label, "with the base stations of")) << t->label;
    // Placing needs the file to write to.
    s.base_stations.clear();
    Status st = check_tracker_spec(s, ClockKind::sim, WiringKeys::config());
    ASSERT_FALSE(st.ok());
    EXPECT_TRUE(contains(st.error().message,
                         "tracker.place_base_stations needs "
                         "tracker.base_stations"))
        << st.error().message;
    fs::remove_all(dir);
}

// The same backend string in the daemon's config and on replay's command line: the daemon
// replays the bundled capture, and so does `hmdnode replay --tracker capture`.
TEST(Wiring, DaemonAndReplayTakeTheSameBackendString) {
    if (!fs::exists(kCapture)) GTEST_SKIP() << kCapture << " is missing";
    const fs::path dir = test::fresh_temp_dir("hmdnode_wiring_same_string");
    const nlohmann::json cfg = {
        {"scene", HMDNODE_DEMO_SCENE},
        {"clock", "sim"},
        {"max_frames", 20},
        {"tracker", {{"backend", "capture"}, {"from", kCapture}, {"device", "28de:2000"}}},
        {"display", {{"eye_width", 32}, {"eye_height", 32}}},
        {"control", {{"path", ""}}}};
    std::ofstream(dir / "hmdnoded.json") << cfg.dump(1);
    const test::CommandRun d =
        test::run(std::string(HMDNODE_DAEMON) + " --config " + (dir / "hmdnoded.json").string());
    ASSERT_EQ(d.code, 0) << d.output;
    EXPECT_TRUE(contains(d.output, "tracker capture: 28de:2000 from capture " + kCapture))
        << d.output;
    EXPECT_TRUE(contains(d.output, "ready: first frame presented")) << d.output;
    EXPECT_TRUE(contains(d.output, "stopped after 20 frames (0 failed)")) << d.output;

    const test::CommandRun r =
        test::run(std::string(HMDNODE_TOOL) + " replay --quiet --scene " + HMDNODE_DEMO_SCENE +
                  " --tracker capture --from " + kCapture +
                  " --device 28de:2000 --clock sim --max-frames 20 --eye-width 32 --eye-height 32");
    ASSERT_EQ(r.code, 0) << r.output;
    EXPECT_TRUE(contains(r.output, "new frames")) << r.output;

    // A usage error in either names its key or flag.
    std::ofstream(dir / "bad.json") << R"({"scene": "x.glb", "tracker": {"backend": "capture"}})";
    const test::CommandRun bd =
        test::run(std::string(HMDNODE_DAEMON) + " --config " + (dir / "bad.json").string());
    EXPECT_EQ(bd.code, 2) << bd.output;
    EXPECT_TRUE(contains(bd.output, "tracker.from is required for tracker.backend capture"))
        << bd.output;
    const test::CommandRun br =
        test::run(std::string(HMDNODE_TOOL) + " replay --scene " + HMDNODE_DEMO_SCENE +
                  " --tracker capture --device 28de:2000");
    EXPECT_EQ(br.code, 2) << br.output;
    EXPECT_TRUE(contains(br.output, "--from is required for --tracker capture")) << br.output;
    const test::CommandRun live =
        test::run(std::string(HMDNODE_TOOL) + " replay --scene " + HMDNODE_DEMO_SCENE +
                  " --tracker hidapi --device 1209:0001");
    EXPECT_EQ(live.code, 2) << live.output;
    EXPECT_TRUE(contains(live.output, "it needs --clock real")) << live.output;
}

}  // namespace
}  // namespace hmdnode
