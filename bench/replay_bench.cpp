// Replay throughput and render time per frame on the demo scene, side by side with the reference
// figures of a small headless Vulkan benchmark on the same kind of machine (docs/DESIGN.md §9:
// multiview, depth, a textured lightmap-like fetch x vertex colour; medians per stereo frame).
//
// Usage: bench_replay_bench [seconds_of_trace_per_run=4] [--write-docs]   (--write-docs: also into
// docs/results/replay-bench.md)
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <string>
#include <vector>

#include "doc_table.hpp"
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
    const bool write_docs = bench::wants_docs(argc, argv);
    const double seconds =
        argc > 1 && std::string(argv[1]) != "--write-docs" ? std::atof(argv[1]) : 4.0;
    ReplayOptions base;
    base.scene = HMDNODE_BINARY_DIR "/data/demo_room.glb";
    base.trace = HMDNODE_SOURCE_DIR "/data/traces/corbillon2018_user1.csv";
    base.start_s = 20.0;
    base.duration_s = seconds;

    std::string rows, device;
    char line[512];
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
        std::snprintf(line, sizeof line,
                      "| %dx%d | %zu | %zu | %.0f | %.2f | %.2f | %.1f | %.2f | %.1f |\n", r.w, r.h,
                      s.vsyncs, s.new_frames, s.triangles_mean, s.render_ms.p50, s.render_ms.p95,
                      ref, s.render_ms.p50 / ref, double(s.frames) / s.wall_s);
        rows += line;
    }
    std::snprintf(line, sizeof line, "build/release/bench/bench_replay_bench %g --write-docs",
                  seconds);
    const std::string command = line;
    std::snprintf(line, sizeof line,
                  "demo scene, Corbillon 2018 user 1 from t = 20 s, %g s of trace per run, "
                  "simulated clock with the frame-cost model calibrated at start-up",
                  seconds);
    const std::string settings = line;
    // The results file names the command and the renderer in its header.
    std::string table =
        "| eye | vsyncs | new frames | triangles/frame | render p50 (ms) | render p95 (ms) | "
        "reference (ms) | ours/ref | replay fps |\n"
        "|---|---|---|---|---|---|---|---|---|\n";
    table += rows;
    table +=
        "\nrender = the scene pass alone, both eyes, no read-back; reference = DESIGN.md §9's "
        "table at the same triangle count (log-linear between its points); replay fps = presents "
        "(new frames and re-warps) per wall second, the start-up calibration, warp + distortion, "
        "tracking, LOD and pacing included.\n";
    const std::string out =
        "Measured by `" + command + "` (renderer " + device + "; " + settings + "):\n\n" + table;
    std::fputs(out.c_str(), stdout);
    if (write_docs &&
        !bench::write_result("replay-bench", "Replay throughput and render time per frame", command,
                             "Settings: " + settings + ".\n\n" + table, device))
        return 1;
    return 0;
}
