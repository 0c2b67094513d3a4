// Gaze-driven LOD in the frame loop (docs/lod-selection.md, "Gaze"): a replay whose trace carries
// gaze, with the eye tracker on, measures eccentricity from the gaze (an object at the gaze gets a
// finer level than one 30 degrees off it); with no eye tracker, or while the gaze is not valid,
// from the lens centre; the report says which.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <glm/gtc/quaternion.hpp>
#include <nlohmann/json.hpp>

#include "hmdnode/core/atomic_file.hpp"
#include "hmdnode/core/gltf.hpp"
#include "hmdnode/core/pose.hpp"
#include "hmdnode/core/trace.hpp"
#include "hmdnode/firmware_host/replay.hpp"

using namespace hmdnode;
namespace fs = std::filesystem;

namespace {

const double kYaw30 = deg_to_rad(30.0);
const glm::dvec3 kLeft30{-std::sin(kYaw30), 0.0, -std::cos(kYaw30)};  // head frame and world

// Two objects 3 m away at eye height: "ahead" on the lens centre and "left30" 30 degrees to the
// left. Each a 0.2 m quad with levels whose errors are 0, 1, 2.5 and 10 cm: at 360x400 per eye
// the selector wants level 1 where the eye looks and level 2 at 30 degrees (acuity).
fs::path write_scene(const fs::path& dir) {
    Scene s;
    Material m;
    m.double_sided = true;
    s.materials.push_back(m);
    Mesh mesh;
    Primitive p;
    p.positions = {
        {-0.1f, -0.1f, 0.0f}, {0.1f, -0.1f, 0.0f}, {0.1f, 0.1f, 0.0f}, {-0.1f, 0.1f, 0.0f}};
    p.normals.assign(4, {0.0f, 0.0f, 1.0f});
    p.indices = {0, 1, 2, 0, 2, 3};
    p.material = 0;
    mesh.primitives.push_back(p);
    s.meshes.push_back(mesh);
    const double errors[] = {0.0, 0.01, 0.025, 0.1};
    const std::pair<const char*, glm::dvec3> objects[] = {
        {"ahead", glm::dvec3(0.0, 1.6, -3.0)},
        {"left30", glm::dvec3(0.0, 1.6, 0.0) + 3.0 * kLeft30}};
    for (const auto& [name, at] : objects) {
        const int first = int(s.nodes.size());
        Node head;
        head.name = name;
        head.translation = at;
        head.mesh = 0;
        head.geometric_error_m = errors[0];
        head.lod_ids = {first + 1, first + 2, first + 3};
        s.nodes.push_back(head);
        s.roots.push_back(first);
        for (int l = 1; l < 4; ++l) {
            Node level;
            level.mesh = 0;
            level.geometric_error_m = errors[l];
            level.translation = at;
            s.nodes.push_back(level);
        }
    }
    fs::path path = dir / "gaze_scene.glb";
    Status st = save_glb(s, path);
    EXPECT_TRUE(st.ok()) << st.error().message;
    return path;
}

// A still head looking ahead for 1 s at 100 Hz, the eyes 30 degrees to the left (confidence
// `confidence`).
std::shared_ptr<const Trace> still_head_gazing_left(double confidence) {
    auto t = std::make_shared<Trace>();
    for (int i = 0; i <= 100; ++i) {
        TraceSample s;
        s.time_ns = s_to_ns(i / 100.0);
        s.gaze = TraceGaze{kLeft30, confidence};
        t->samples.push_back(s);
    }
    return t;
}

// note: one folder per test: CTest runs the tests of this file in parallel, and a shared report
// path let one test read another's report.
fs::path test_dir() {
    const fs::path dir = fs::path(HMDNODE_BINARY_DIR) / "test_tmp" / "gaze_lod" /
                         ::testing::UnitTest::GetInstance()->current_test_info()->name();
    fs::create_directories(dir);
    return dir;
}

struct GazeRun {
    ReplayResult result;
    nlohmann::json report;
};

GazeRun replay(EyeTrackerBackend eye_tracker, double confidence) {
    const fs::path dir = test_dir();
    ReplayOptions o;
    o.scene = write_scene(dir);
    o.trace_data = still_head_gazing_left(confidence);
    o.eye_tracker = eye_tracker;
    o.display.eye_width = 360;
    o.display.eye_height = 400;
    o.node.warp = false;
    o.node.distortion = false;
    o.node.lod_fade_frames = 0;
    o.max_frames = 12;
    o.frame_cost = FrameCostModel{};
    o.report = dir / "report.json";
    Result<ReplayResult> r = run_replay(o);
    EXPECT_TRUE(r.ok()) << r.error().message;
    GazeRun run{std::move(r).value(), {}};
    run.report = nlohmann::json::parse(*read_file(o.report));
    return run;
}

size_t index_of(const ReplayResult& r, const std::string& name) {
    for (size_t i = 0; i < r.object_names.size(); ++i)
        if (r.object_names[i] == name) return i;
    ADD_FAILURE() << "no object " << name;
    return 0;
}

}  // namespace

TEST(GazeLod, AnObjectAtTheGazeGetsAFinerLevelThanOne30DegreesOffIt) {
    const GazeRun run = replay(EyeTrackerBackend::trace, 1.0);
    const ReplayResult& r = run.result;
    ASSERT_FALSE(r.frames.empty());
    const FrameRecord& f = r.frames.back();
    const size_t ahead = index_of(r, "ahead"), left = index_of(r, "left30");
    EXPECT_EQ(f.gaze_source, GazeSource::eye_tracker);
    EXPECT_NEAR(f.gaze_eccentricity_deg, 30.0, 1e-6);
    // Eccentricity from the gaze: 0 for the object it falls on, 30 degrees less the angular
    // radius (0.1414 m at 3 m: 2.7 degrees) for the other.
    EXPECT_NEAR(f.eccentricity_deg[left], 0.0, 1e-6);
    EXPECT_NEAR(f.eccentricity_deg[ahead], 30.0 - rad_to_deg(std::asin(0.1414 / 3.0)), 0.05);
    EXPECT_EQ(f.levels[left], 1);
    EXPECT_EQ(f.levels[ahead], 2);
    // Every new frame once the first gaze sample has arrived; the report says so.
    EXPECT_GE(r.summary.gaze_frames + 1, r.summary.new_frames);
    EXPECT_EQ(run.report["eye_tracker"], "trace");
    EXPECT_EQ(run.report["frames"].back()["gaze_source"], "eye_tracker");
    EXPECT_EQ(run.report["summary"]["gaze_frames"], r.summary.gaze_frames);
}

TEST(GazeLod, WithoutAnEyeTrackerTheLensCentreIsUsedAndReported) {
    const GazeRun run = replay(EyeTrackerBackend::none, 1.0);
    const ReplayResult& r = run.result;
    ASSERT_FALSE(r.frames.empty());
    const FrameRecord& f = r.frames.back();
    const size_t ahead = index_of(r, "ahead"), left = index_of(r, "left30");
    EXPECT_EQ(f.gaze_source, GazeSource::lens_centre);
    EXPECT_NEAR(f.eccentricity_deg[ahead], 0.0, 1e-6);
    EXPECT_EQ(f.levels[ahead], 1);
    EXPECT_EQ(f.levels[left], 2);
    EXPECT_EQ(r.summary.gaze_frames, 0u);
    EXPECT_EQ(run.report["eye_tracker"], "none");
    EXPECT_EQ(run.report["summary"]["gaze_source"], "lens_centre");
}

TEST(GazeLod, AGazeThatIsNotValidFallsBackToTheLensCentre) {
    // The tracker runs but every sample has confidence 0 (eyes closed, track lost).
    const GazeRun run = replay(EyeTrackerBackend::trace, 0.0);
    const ReplayResult& r = run.result;
    ASSERT_FALSE(r.frames.empty());
    const size_t ahead = index_of(r, "ahead"), left = index_of(r, "left30");
    for (const FrameRecord& f : r.frames) {
        EXPECT_EQ(f.gaze_source, GazeSource::lens_centre);
        EXPECT_EQ(f.levels[ahead], 1);
        EXPECT_EQ(f.levels[left], 2);
    }
    EXPECT_EQ(run.report["summary"]["gaze_source"], "lens_centre");
}

TEST(GazeLod, TheEyeTrackerNeedsATraceWithGaze) {
    ReplayOptions o;
    const fs::path dir = test_dir();
    o.scene = write_scene(dir);
    auto head_only = std::make_shared<Trace>(*still_head_gazing_left(1.0));
    for (TraceSample& s : head_only->samples) s.gaze.reset();
    o.trace_data = head_only;
    o.trace = "head_only.csv";
    o.eye_tracker = EyeTrackerBackend::trace;
    o.frame_cost = FrameCostModel{};
    Result<ReplayResult> r = run_replay(o);
    ASSERT_FALSE(r.ok());
    EXPECT_NE(r.error().message.find("--eye-tracker trace: head_only.csv"), std::string::npos)
        << r.error().message;
    EXPECT_NE(r.error().message.find("no gaze columns"), std::string::npos);
}
