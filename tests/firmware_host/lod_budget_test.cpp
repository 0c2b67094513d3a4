// The frame-budget controller in the frame loop, end to end on the simulated clock: a synthetic
// scene whose full detail costs more than a vsync period under the cost model, replayed with the
// threshold selector alone and with the greedy allocator.
#include <gtest/gtest.h>

#include <filesystem>
#include <glm/gtc/quaternion.hpp>
#include <nlohmann/json.hpp>

#include "firmware_host/command_run.hpp"
#include "hmdnode/core/gltf.hpp"
#include "hmdnode/core/trace.hpp"
#include "hmdnode/firmware_host/replay.hpp"

using namespace hmdnode;
namespace fs = std::filesystem;

namespace {

// A square of n x n quads (2 n^2 triangles), 0.5 m wide, facing +Z.
Primitive grid(int n) {
    Primitive p;
    for (int y = 0; y <= n; ++y)
        for (int x = 0; x <= n; ++x) {
            p.positions.push_back(
                {0.5f * (float(x) / float(n) - 0.5f), 0.5f * (float(y) / float(n) - 0.5f), 0.0f});
            p.normals.push_back({0.0f, 0.0f, 1.0f});
        }
    for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
            const uint32_t a = uint32_t(y * (n + 1) + x), b = a + 1, c = a + uint32_t(n + 1),
                           d = c + 1;
            p.indices.insert(p.indices.end(), {a, b, d, a, d, c});
        }
    p.material = 0;
    return p;
}

// 20 objects in front of the viewer, each with levels of 128, 32, 8 and 2 triangles whose errors
// (0, 0.1, 0.2, 0.4 m) all show at a 0.01 px tolerance: the selector wants full detail everywhere.
fs::path write_heavy_scene(const fs::path& dir) {
    Scene s;
    Material m;
    m.base_color_factor = {0.6f, 0.7f, 0.8f, 1.0f};
    m.double_sided = true;
    s.materials.push_back(m);
    const int sizes[] = {8, 4, 2, 1};
    for (int n : sizes) {
        Mesh mesh;
        mesh.name = "grid" + std::to_string(n);
        mesh.primitives.push_back(grid(n));
        s.meshes.push_back(mesh);
    }
    const double errors[] = {0.0, 0.1, 0.2, 0.4};
    for (int i = 0; i < 20; ++i) {
        const glm::dvec3 at{-1.6 + 0.8 * (i % 5), 1.0 + 0.4 * (i / 5), -3.0 - 0.3 * (i % 3)};
        Node head;
        head.name = "object" + std::to_string(i);
        head.translation = at;
        head.mesh = 0;
        head.geometric_error_m = errors[0];
        const int first = int(s.nodes.size());
        head.lod_ids = {first + 1, first + 2, first + 3};
        s.nodes.push_back(head);
        s.roots.push_back(first);
        for (int l = 1; l < 4; ++l) {
            Node level;
            level.mesh = l;
            level.geometric_error_m = errors[l];
            level.translation = at;
            s.nodes.push_back(level);
        }
    }
    fs::path p = dir / "heavy.glb";
    Status st = save_glb(s, p);
    EXPECT_TRUE(st.ok()) << st.error().message;
    return p;
}

ReplayOptions heavy_options(const fs::path& dir, LodAllocator allocator) {
    ReplayOptions o;
    o.scene = write_heavy_scene(dir);
    Trace t;  // a still head for 6 s
    for (int i = 0; i <= 6 * 100; ++i) {
        TraceSample ts;
        ts.time_ns = s_to_ns(i / 100.0);
        t.samples.push_back(ts);
    }
    o.trace_data = std::make_shared<const Trace>(std::move(t));
    o.display.eye_width = 48;
    o.display.eye_height = 48;
    o.node.lod.tolerance_px = 0.01;
    o.node.lod_allocator = allocator;
    o.node.warp = false;  // a missed vsync repeats the old frame: on time means a new frame
    // Full detail (20 x 128 triangles) costs 2 + 12.8 ms and the warp 1 ms: more than the 11.1 ms
    // period at 90 Hz; the coarsest levels cost 2.2 ms.
    FrameCostModel cost;
    cost.base_ns = 2 * kNsPerMs;
    cost.per_triangle_ns = 5000.0;
    cost.warp_ns = kNsPerMs;
    o.frame_cost = cost;
    return o;
}

}  // namespace

TEST(LodBudget, GreedyAllocatorKeepsEveryVsyncWhereFullDetailMissesHalf) {
    const fs::path dir = hmdnode::test::fresh_temp_dir("hmdnode_lod_budget_test");
    auto threshold = run_replay(heavy_options(dir, LodAllocator::threshold));
    ASSERT_TRUE(threshold.ok()) << threshold.error().message;
    auto greedy = run_replay(heavy_options(dir, LodAllocator::greedy));
    ASSERT_TRUE(greedy.ok()) << greedy.error().message;

    EXPECT_NEAR(threshold->summary.triangles_mean, 20 * 128, 1e-9);
    EXPECT_LT(threshold->summary.on_time_rate, 0.6);
    EXPECT_GE(greedy->summary.on_time_rate, 0.99);
    EXPECT_GE(greedy->summary.new_frames_per_vsync, 0.99);
    // It spends the budget: (11.1 - 1) x 0.9 = 9.1 ms holds about 1,400 triangles; everything at
    // its coarsest would be 40.
    EXPECT_GT(greedy->summary.triangles_mean, 1000.0);
    EXPECT_LT(greedy->summary.triangles_mean, 20 * 128);
    size_t within = 0, frames = 0;
    for (const FrameRecord& f : greedy->frames) {
        if (f.kind != FrameKind::new_frame || f.frame < 5) continue;
        ++frames;
        within += f.predicted_render_ms <= ns_to_ms(greedy->period_ns) - 1.0;
        EXPECT_GT(f.lod_coarsened, 0u);
    }
    EXPECT_EQ(within, frames);

    // On the simulated clock the learned cost is the model the clock advances by (the greedy run
    // draws varying triangle counts; the threshold run's one count cannot tell base from slope,
    // and charges everything to the triangles).
    ASSERT_TRUE(greedy->summary.lod_cost_fit);
    EXPECT_NEAR(greedy->summary.lod_cost_fit->base_ms, 2.0, 1e-6);
    EXPECT_NEAR(greedy->summary.lod_cost_fit->per_triangle_ms, 5e-3, 1e-9);
    ASSERT_TRUE(threshold->summary.lod_cost_fit);
    EXPECT_NEAR(threshold->summary.lod_cost_fit->per_triangle_ms * 2560, 14.8, 1e-6);

    // The report says which allocator ran, and the greedy frames' budget and prediction.
    ReplayOptions o = heavy_options(dir, LodAllocator::greedy);
    nlohmann::json j = replay_report_json(o, *greedy);
    EXPECT_EQ(j["lod_allocator"], "greedy");
    EXPECT_TRUE(j["frames"].back()["lod_budget_ms"].is_number());
    EXPECT_TRUE(j["frames"].back()["predicted_render_ms"].is_number());
    EXPECT_NEAR(j["summary"]["lod_cost_fit_ms"]["render_per_1k_triangles"].get<double>(), 5.0,
                1e-6);
    EXPECT_EQ(replay_report_json(o, *threshold)["lod_allocator"], "threshold");
}

TEST(LodBudget, IgaAllocatorKeepsEveryVsyncWhereFullDetailMissesHalf) {
    // The immune genetic allocator in the same loop: the same budget, learned cost and feedback.
    const fs::path dir = hmdnode::test::fresh_temp_dir("hmdnode_lod_budget_iga_test");
    const ReplayOptions o = heavy_options(dir, LodAllocator::iga);
    auto iga = run_replay(o);
    ASSERT_TRUE(iga.ok()) << iga.error().message;
    // (0.98: the pixel-cost ladder tries its steps while the allocator learns, and a step that
    // turns the chromatic-aberration correction back on costs up to three late frames while the
    // warp's estimate relearns; 0.985 measured.)
    EXPECT_GE(iga->summary.on_time_rate, 0.98);
    EXPECT_GE(iga->summary.new_frames_per_vsync, 0.98);
    EXPECT_GT(iga->summary.triangles_mean, 1000.0);
    EXPECT_LT(iga->summary.triangles_mean, 20 * 128);
    size_t within = 0, frames = 0;
    for (const FrameRecord& f : iga->frames) {
        if (f.kind != FrameKind::new_frame || f.frame < 5) continue;
        ++frames;
        within += f.predicted_render_ms <= ns_to_ms(iga->period_ns) - 1.0;
        EXPECT_GT(f.lod_coarsened, 0u);
    }
    EXPECT_EQ(within, frames);
    EXPECT_EQ(replay_report_json(o, *iga)["lod_allocator"], "iga");
    // Deterministic: the same replay on the simulated clock draws the same levels.
    auto again = run_replay(o);
    ASSERT_TRUE(again.ok()) << again.error().message;
    ASSERT_EQ(again->frames.size(), iga->frames.size());
    for (size_t i = 0; i < iga->frames.size(); ++i)
        EXPECT_EQ(again->frames[i].levels, iga->frames[i].levels) << "frame " << i;
}
