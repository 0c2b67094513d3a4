// End-to-end replays on the simulated clock: trace -> simulated tracker -> node runtime ->
// Vulkan (lavapipe) -> mock display -> report.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <glm/gtc/quaternion.hpp>
#include <nlohmann/json.hpp>

#include "firmware_host/command_run.hpp"
#include "hmdnode/core/gltf.hpp"
#include "hmdnode/core/trace.hpp"
#include "hmdnode/firmware_host/replay.hpp"

using namespace hmdnode;
namespace fs = std::filesystem;

namespace {

fs::path temp_dir(const std::string& name) {
    return hmdnode::test::fresh_temp_dir("hmdnode_replay_test_" + name);
}

// A turn about `axis` (default +Y) at dps, sampled at rate_hz; sign_flip alternates q and -q.
Trace yaw_trace(double rate_hz, double seconds, double dps, bool sign_flip = false,
                glm::dvec3 axis = {0, 1, 0}) {
    Trace t;
    for (int i = 0; i <= int(rate_hz * seconds); ++i) {
        TraceSample s;
        s.time_ns = s_to_ns(i / rate_hz);
        s.orientation = glm::angleAxis(deg_to_rad(dps * i / rate_hz), axis) *
                        ((sign_flip && i % 2) ? -1.0 : 1.0);
        t.samples.push_back(s);
    }
    return t;
}

// A box (12 triangles) with a two-level LOD chain (levels differ only in their stated error).
Primitive box(glm::vec3 lo, glm::vec3 hi) {
    Primitive p;
    const glm::vec3 c[8] = {{lo.x, lo.y, lo.z}, {hi.x, lo.y, lo.z}, {hi.x, hi.y, lo.z},
                            {lo.x, hi.y, lo.z}, {lo.x, lo.y, hi.z}, {hi.x, lo.y, hi.z},
                            {hi.x, hi.y, hi.z}, {lo.x, hi.y, hi.z}};
    for (const glm::vec3& v : c) {
        p.positions.push_back(v);
        p.normals.push_back(glm::normalize(v - 0.5f * (lo + hi)));
    }
    p.indices = {0, 2, 1, 0, 3, 2, 4, 5, 6, 4, 6, 7, 0, 1, 5, 0, 5, 4,
                 3, 6, 2, 3, 7, 6, 0, 4, 7, 0, 7, 3, 1, 2, 6, 1, 6, 5};
    p.material = 0;
    return p;
}

fs::path write_scene(const fs::path& dir) {
    Scene s;
    Material m;
    m.base_color_factor = {0.8f, 0.5f, 0.3f, 1.0f};
    m.double_sided = true;
    s.materials.push_back(m);
    for (int i = 0; i < 3; ++i) {
        Mesh mesh;
        mesh.name = "box" + std::to_string(i);
        mesh.primitives.push_back(box({-0.2f, -0.2f, -0.2f}, {0.2f, 0.2f + 0.1f * i, 0.2f}));
        s.meshes.push_back(mesh);
    }
    // Object 0 straight ahead with levels {mesh0, mesh1, mesh2}; object 1 to the side.
    Node a;
    a.name = "ahead";
    a.translation = {0, 1.6, -2};
    a.mesh = 0;
    a.geometric_error_m = 0.0;
    a.lod_ids = {2, 3};
    Node b;
    b.name = "side";
    b.translation = {2, 1.6, 0};
    b.mesh = 2;
    Node l1, l2;
    l1.mesh = 1;
    l1.geometric_error_m = 0.02;
    l1.translation = a.translation;
    l2.mesh = 2;
    l2.geometric_error_m = 0.2;
    l2.translation = a.translation;
    s.nodes = {a, b, l1, l2};
    s.roots = {0, 1};
    fs::path p = dir / "scene.glb";
    Status st = save_glb(s, p);
    EXPECT_TRUE(st.ok()) << st.error().message;
    return p;
}

ReplayOptions options(const fs::path& dir, const Trace& trace) {
    ReplayOptions o;
    o.scene = write_scene(dir);
    o.trace = dir / "trace.csv";
    EXPECT_TRUE(write_trace_csv(trace, o.trace).ok());
    o.display.eye_width = 48;
    o.display.eye_height = 48;
    // A fixed cost model keeps the simulated clock independent of this machine's speed.
    FrameCostModel cost;
    cost.base_ns = 3 * kNsPerMs;
    cost.per_triangle_ns = 100.0;
    cost.warp_ns = kNsPerMs;
    o.frame_cost = cost;
    return o;
}

}  // namespace

TEST(Replay, SameTraceGivesTheSameReportTwice) {
    fs::path dir = temp_dir("determinism");
    Trace t = yaw_trace(60, 1.5, 90);
    ReplayOptions o = options(dir, t);
    o.tracker.noise_deg = 0.2;
    o.tracker.jitter_ns = 2 * kNsPerMs;
    auto a = run_replay(o);
    auto b = run_replay(o);
    ASSERT_TRUE(a.ok()) << a.error().message;
    ASSERT_TRUE(b.ok());
    nlohmann::json ja = replay_report_json(o, *a), jb = replay_report_json(o, *b);
    // Only the measured wall times may differ.
    for (nlohmann::json* j : {&ja, &jb}) {
        for (const char* k : {"render_ms", "warp_ms", "wall_s"}) (*j)["summary"].erase(k);
        for (auto& f : (*j)["frames"]) {
            f.erase("render_ms");
            f.erase("warp_ms");
        }
    }
    EXPECT_EQ(ja, jb);
    EXPECT_GT(a->summary.frames, 120u);
}

TEST(Replay, StillHeadGivesZeroRegistrationError) {
    fs::path dir = temp_dir("still");
    auto r = run_replay(options(dir, yaw_trace(60, 1.0, 0.0)));
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_LT(r->summary.registration_error_deg.max, 1e-6);
    EXPECT_DOUBLE_EQ(r->summary.on_time_rate, 1.0);
}

TEST(Replay, PredictedPosesMatchTheTraceAtPhotonTime) {
    fs::path dir = temp_dir("constant_turn");
    // A constant 120 deg/s turn: constant-velocity prediction is exact, so the pose each frame was
    // rendered for equals the trace at the frame's photon time (slerp of the truth).
    ReplayOptions o = options(dir, yaw_trace(1000, 1.0, 120));
    auto r = run_replay(o);
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_LT(r->summary.registration_error_deg.max, 0.01);
    // Without prediction the error is the rotation during the motion-to-photon latency.
    o.node.predict = false;
    auto raw = run_replay(o);
    ASSERT_TRUE(raw.ok());
    for (const FrameRecord& f : raw->frames) {
        if (f.index < 5 || std::isnan(f.registration_error_deg)) continue;
        EXPECT_NEAR(f.registration_error_deg, 120.0 * f.latency_ms / 1000.0, 0.05) << f.index;
    }
    EXPECT_GT(raw->summary.registration_error_deg.p50, 0.5);
}

TEST(Replay, SignFlipsCauseNoJumps) {
    fs::path dir = temp_dir("sign_flips");
    auto r = run_replay(options(dir, yaw_trace(60, 1.0, 60, /*sign_flip=*/true)));
    ASSERT_TRUE(r.ok()) << r.error().message;
    // From the first frame that had two samples to estimate velocity from, prediction is exact.
    int checked = 0;
    for (const FrameRecord& f : r->frames) {
        if (f.pose_sample_time_ns < s_to_ns(1.0 / 60.0) || std::isnan(f.registration_error_deg))
            continue;
        EXPECT_NEAR(f.angular_speed_dps, 60.0, 1e-4) << f.index;  // timestamps are whole ns
        EXPECT_LT(f.registration_error_deg, 1e-5) << f.index;
        ++checked;
    }
    EXPECT_GT(checked, 80);
}

TEST(Replay, FastHeadTurnsCoarsenTheLevels) {
    fs::path dir = temp_dir("speed");
    // Rolling about the view axis keeps the object at the gaze centre: only the speed changes.
    const glm::dvec3 roll(0, 0, 1);
    // 48-px eyes (0.35 px per degree): level 1 projects to ~0.24 px at 1.65 m, over the 0.1 px
    // floor; a 200 deg/s turn smears 1.6 degrees = 0.56 px during an 8 ms persistence (a
    // full-persistence panel), so level 1 is hidden then.
    ReplayOptions still = options(dir, yaw_trace(60, 0.5, 0.0, false, roll));
    still.node.lod.tolerance_px = 0.1;
    still.display.persistence_ns = 8'000'000;
    // (Without cross-fades, whose frames draw both levels and so more triangles for a moment.)
    still.node.lod_fade_frames = 0;
    auto slow = run_replay(still);
    ReplayOptions turning = options(dir, yaw_trace(60, 0.5, 200.0, false, roll));
    turning.node.lod.tolerance_px = 0.1;
    turning.display.persistence_ns = 8'000'000;
    turning.node.lod_fade_frames = 0;
    auto fast = run_replay(turning);
    ASSERT_TRUE(slow.ok() && fast.ok());
    EXPECT_NEAR(fast->frames[10].eccentricity_deg[0], slow->frames[10].eccentricity_deg[0], 1e-6);
    // Object 0 ("ahead"): level 0 while still; a coarser level while turning at 200 deg/s.
    EXPECT_EQ(slow->frames.back().levels[0], 0);
    EXPECT_GT(fast->frames[10].levels[0], 0);
    EXPECT_LT(fast->summary.triangles_mean, slow->summary.triangles_mean + 1e-9);
}

// Per-eye frustum culling: "side" (2 m to the right, 80 degrees beyond the 50-degree outer edge
// of the right eye's field less its angular radius) is never drawn while the head faces -z;
// facing +z, "ahead" (2 m behind) is not drawn either. Culled objects keep a level.
TEST(Replay, ObjectsOutsideBothEyesAreNotDrawn) {
    fs::path dir = temp_dir("cull");
    auto forward = run_replay(options(dir, yaw_trace(60, 0.3, 0.0)));
    Trace back = yaw_trace(60, 0.3, 0.0);
    for (TraceSample& t : back.samples)
        t.orientation = glm::angleAxis(deg_to_rad(180.0), glm::dvec3(0, 1, 0));
    auto behind = run_replay(options(dir, back));
    ASSERT_TRUE(forward.ok() && behind.ok());
    for (const FrameRecord& f : forward->frames) {
        if (f.kind != FrameKind::new_frame) continue;
        EXPECT_EQ(f.culled, 1u);
        EXPECT_EQ(f.triangles, 12u);  // "ahead" alone, a 12-triangle box at every level
        EXPECT_EQ(f.levels.size(), 2u);
    }
    for (const FrameRecord& f : behind->frames) {
        if (f.kind != FrameKind::new_frame) continue;
        EXPECT_EQ(f.culled, 2u);
        EXPECT_EQ(f.triangles, 0u);
    }
}

TEST(Replay, WritesAReportWithTheDocumentedFields) {
    fs::path dir = temp_dir("report");
    ReplayOptions o = options(dir, yaw_trace(60, 0.5, 30));
    o.report = dir / "report.json";
    o.display.frames_dir = dir / "frames";
    o.display.frames_every = 10;
    auto r = run_replay(o);
    ASSERT_TRUE(r.ok()) << r.error().message;
    std::ifstream in(o.report);
    nlohmann::json j = nlohmann::json::parse(in);
    for (const char* k : {"latency_ms", "registration_error_deg"})
        for (const char* p : {"p50", "p95", "p99", "max"})
            EXPECT_TRUE(j["summary"][k][p].is_number()) << k << p;
    EXPECT_EQ(j["summary"]["frames"], r->summary.frames);
    EXPECT_TRUE(j["summary"]["on_time_rate"].is_number());
    EXPECT_TRUE(j["summary"]["triangles_mean"].is_number());
    const auto& f = j["frames"][3];
    for (const char* k : {"pose_sample_time_ns", "predicted_photon_time_ns", "latency_ms",
                          "registration_error_deg", "triangles", "render_ms"})
        EXPECT_TRUE(f[k].is_number()) << k;
    EXPECT_TRUE(f["lod"]["ahead"].is_number());
    EXPECT_TRUE(f["lod"]["side"].is_number());
    EXPECT_TRUE(fs::exists(o.display.frames_dir / "frame_000010.png"));
    // Latency is photon time minus the newest sample's time.
    EXPECT_NEAR(f["latency_ms"].get<double>(),
                (f["photon_time_ns"].get<double>() - f["pose_sample_time_ns"].get<double>()) * 1e-6,
                1e-9);
}

TEST(Replay, RecentreMovesA6DofTraceToTheDefaultHeadPosition) {
    fs::path dir = temp_dir("recentre");
    // A still head standing at the floor, 0.5 m to the side.
    Trace t = yaw_trace(60, 0.5, 0.0);
    for (TraceSample& s : t.samples) s.position = glm::dvec3(0.5, 0.0, 0.3);
    ReplayOptions o = options(dir, t);
    auto as_recorded = run_replay(o);
    ASSERT_TRUE(as_recorded.ok()) << as_recorded.error().message;
    EXPECT_NEAR(as_recorded->frames.back().shown_pose.position.y, 0.0, 1e-9);
    o.recentre = true;
    auto moved = run_replay(o);
    ASSERT_TRUE(moved.ok()) << moved.error().message;
    const glm::dvec3 p = moved->frames.back().shown_pose.position;
    EXPECT_NEAR(glm::length(p - o.node.default_head_position), 0.0, 1e-9);
    // The truth moved with it: a still head stays registered, position included.
    EXPECT_LT(moved->summary.registration_error_deg.max, 1e-6);
    // A trace without positions cannot be recentred.
    ReplayOptions plain = options(dir, yaw_trace(60, 0.5, 0.0));
    plain.recentre = true;
    auto refused = run_replay(plain);
    ASSERT_FALSE(refused.ok());
    EXPECT_NE(refused.error().message.find("--recentre"), std::string::npos);
}
