// Replay throughput and render time per frame on the demo scene, side by side with the reference
// figures of a small headless Vulkan benchmark on the same kind of machine (docs/DESIGN.md §9:
// multiview, depth, a textured lightmap-like fetch x vertex colour; medians per stereo frame).
//
// Usage: bench_replay_bench [seconds_of_trace_per_run=4]
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <vector>

#include "hmdnode/firmware_host/replay.hpp"

using namespace hmdnode;

namespace {

// DESIGN §9 medians (ms per stereo frame) by eye size and triangle count.
struct RefRow {
    int w, h;
    std::vector<std::pair<double, double>> tri_ms;  // (triangles, ms)
};
const RefRow kReference[] = {
    {270, 300, {{1e3, 5}, {1e4, 9}, {3e4, 27}}},
    {540, 600, {{1e3, 13}, {1e4, 16}, {3e4, 33}, {1e5, 81}, {1e6, 270}}},
    {1080, 1200, {{1e3, 40}, {1e5, 113}, {1e6, 389}}},
};

// Reference ms at a triangle count: linear in log(triangles) between the measured points.
double reference_ms(const RefRow& r, double tri) {
    const auto& p = r.tri_ms;
    if (tri <= p.front().first) return p.front().second;
    for (size_t i = 1; i < p.size(); ++i)
        if (tri <= p[i].first) {
            const double f = std::log(tri / p[i - 1].first) / std::log(p[i].first / p[i - 1].first);
            return p[i - 1].second + f * (p[i].second - p[i - 1].second);
        }
    return p.back().second;
}

}  // namespace

int main(int argc, char** argv) {
    const double seconds = argc > 1 ? std::atof(argv[1]) : 4.0;
    ReplayOptions base;
    base.scene = HMDNODE_BINARY_DIR "/data/demo_room.glb";
    base.trace = HMDNODE_SOURCE_DIR "/data/traces/corbillon2018_user1.csv";
    base.start_s = 20.0;
    base.duration_s = seconds;

    std::printf(
        "hmdnode replay benchmark: demo scene, Corbillon 2018 user 1 from t=20 s, %.1f s of trace "
        "per run\n",
        seconds);
    std::printf(
        "render time per stereo frame (median of the frames of one run; reference = DESIGN §9 at "
        "the same triangles)\n");
    std::printf("%-11s %10s %10s %10s %10s %8s %12s %10s\n", "eye", "new frames", "tri/frame",
                "render p50", "render p95", "ref ms", "ours/ref", "replay fps");
    std::string device;
    for (const RefRow& r : kReference) {
        ReplayOptions o = base;
        o.display.eye_width = r.w;
        o.display.eye_height = r.h;
        Result<ReplayResult> res = run_replay(o);
        if (!res.ok()) {
            std::fprintf(stderr, "replay failed: %s\n", res.error().message.c_str());
            return 1;
        }
        device = res->device_name;
        const ReplaySummary& s = res->summary;
        const double ref = reference_ms(r, s.triangles_mean);
        std::printf("%4dx%-6d %10zu %10.0f %10.2f %10.2f %8.1f %12.2f %10.1f\n", r.w, r.h,
                    s.new_frames, s.triangles_mean, s.render_ms.p50, s.render_ms.p95, ref,
                    s.render_ms.p50 / ref, double(s.frames) / s.wall_s);
    }
    std::printf("device: %s\n", device.c_str());
    std::printf(
        "render = the scene pass alone (no read-back); replay fps = presents (new frames and\n"
        "re-warps) per wall second on the simulated clock, the start-up calibration, warp +\n"
        "distortion, tracking, LOD and pacing included.\n");
    return 0;
}
