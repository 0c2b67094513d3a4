// The baker against raw Embree on the baker's own rays (docs/baking.md "Benchmark",
// docs/results/bake-replay-bench.md): each round
// bakes the scene at `hmdnode bake`'s defaults while recording every k-th ray each thread casts
// (bounce, shadow, validity, coplanar re-query; start_ray_recording), then replays those rays
// through raw Embree right after (interleaved in time, so both see the same machine load): single
// rays (rtcIntersect1 / rtcOccluded1), packets of 8 and streams of 64 (rtcOccluded8 /
// rtcIntersect8, rtcOccluded1M / rtcIntersect1M) for the shadow and validity rays. The baker
// casts its shadow and validity rays as streams (a texel's or vertex sample's at once), its bounce
// rays single, so "raw streams" is the like-for-like reference; single rays stay beside it.
// Rates are rays over wall time; CPU time beside them. Both scenes also run single-threaded.
//
// usage: bench_bake_replay_bench [scene.glb] [threads] [--rounds R] [--write-docs]
//   (default: the built demo scene, all cores, 2 rounds; --write-docs: into
//   docs/results/bake-replay-bench.md)
#include <time.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "doc_table.hpp"
#include "hmdnode/bake/bake.hpp"
#include "hmdnode/bake/cornell_box.hpp"
#include "hmdnode/bake/path_tracer.hpp"
#include "hmdnode/core/gltf.hpp"

using namespace hmdnode;

namespace {

double cpu_now() {
    timespec ts{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

struct Sums {
    double baker_rays = 0, baker_wall = 0, baker_cpu = 0;
    double rays[3] = {0, 0, 0}, wall[3] = {0, 0, 0}, cpu[3] = {0, 0, 0};
    size_t recorded = 0, mix[4] = {0, 0, 0, 0};
};

// One table row (empty on failure, reason on stderr).
std::string run(const char* name, const Scene& scene, int threads, uint32_t every, int rounds) {
    Result<PathTracer> tracer = PathTracer::build(scene, PathTracerOptions{});
    if (!tracer) {
        std::fprintf(stderr, "%s: %s\n", name, tracer.error().message.c_str());
        return {};
    }
    BakeOptions options;  // `hmdnode bake`'s defaults
    options.threads = threads;
    Sums s;
    for (int round = 0; round < rounds; ++round) {
        Scene copy = scene;
        start_ray_recording(every);
        const double c0 = cpu_now();
        Result<BakeReport> r = bake_scene(copy, options);
        const double c1 = cpu_now();
        const std::vector<RecordedRay> rays = stop_ray_recording();
        if (!r) {
            std::fprintf(stderr, "%s: %s\n", name, r.error().message.c_str());
            return {};
        }
        s.baker_rays += double(r->rays);
        s.baker_wall += r->trace_seconds;
        s.baker_cpu += (c1 - c0) * r->trace_seconds / std::max(1e-9, r->seconds);
        s.recorded += rays.size();
        for (const RecordedRay& x : rays) ++s.mix[int(x.kind)];
        const ReplayMode modes[3] = {ReplayMode::Single, ReplayMode::Packet8, ReplayMode::Stream};
        for (int m = 0; m < 3; ++m) {
            const ReplayTiming t = tracer->replay_rays(rays, threads, modes[m]);
            s.rays[m] += double(t.rays);
            s.wall[m] += t.wall_seconds;
            s.cpu[m] += t.cpu_seconds;
        }
    }
    const double baker = s.baker_rays / s.baker_wall;
    double rate[3];
    for (int m = 0; m < 3; ++m) rate[m] = s.rays[m] / std::max(1e-9, s.wall[m]);
    const double n = double(std::max<size_t>(1, s.recorded));
    char line[1024];
    std::snprintf(
        line, sizeof line,
        "| %s | %d | %.0f / %.0f / %.0f / %.1f %% | %.2f (%.1f s CPU per s) | %.2f (%.2f) "
        "| %.1f %% | %.2f (%.2f) | %.2f (%.2f) | %.1f %% |\n",
        name, resolve_threads(threads), 100.0 * double(s.mix[0]) / n, 100.0 * double(s.mix[2]) / n,
        100.0 * double(s.mix[1]) / n, 100.0 * double(s.mix[3]) / n, baker / 1e6,
        s.baker_cpu / std::max(1e-9, s.baker_wall), rate[0] / 1e6,
        s.cpu[0] / std::max(1e-9, s.wall[0]), 100.0 * baker / rate[0], rate[1] / 1e6,
        s.cpu[1] / std::max(1e-9, s.wall[1]), rate[2] / 1e6, s.cpu[2] / std::max(1e-9, s.wall[2]),
        100.0 * baker / rate[2]);
    return line;
}

}  // namespace

int main(int argc, char** argv) {
    const bool write_docs = bench::wants_docs(argc, argv);
    std::vector<std::string> args;
    int rounds = 2;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--write-docs") continue;
        if (a == "--rounds" && i + 1 < argc) {
            rounds = std::max(1, std::atoi(argv[++i]));
            continue;
        }
        args.push_back(a);
    }
    const std::string path = !args.empty() ? args[0] : HMDNODE_BINARY_DIR "/data/demo_room.glb";
    const int threads = args.size() > 1 ? std::atoi(args[1].c_str()) : 0;
    std::string command = "build/release/bench/bench_bake_replay_bench";
    for (const std::string& a : args) command += ' ' + bench::in_tree(a);
    command += " --rounds " + std::to_string(rounds);
    if (write_docs) command += " --write-docs";

    const std::string machine = bench::machine_facts();
    std::string rows;
    Result<Scene> demo = load_gltf(path);
    if (!demo) {
        std::fprintf(stderr, "%s: %s\n", path.c_str(), demo.error().message.c_str());
        return 1;
    }
    const std::string file = std::filesystem::path(path).filename().string();
    const char* demo_name = file == "demo_room.glb" ? "demo scene" : file.c_str();
    const std::string d1 = run(demo_name, *demo, 1, 64, rounds);
    const std::string demo_row = run(demo_name, *demo, threads, 64, rounds);
    const Scene cornell = cornell_box_scene(64.0);
    const std::string c1 = run("cornell box", cornell, 1, 1, rounds);
    const std::string cn = run("cornell box", cornell, threads, 1, rounds);
    if (d1.empty() || demo_row.empty() || c1.empty() || cn.empty()) return 1;
    const std::string settings =
        "`hmdnode bake`'s defaults; mean over the rounds; the demo scene records every 64th ray "
        "of each thread, the Cornell box every ray";
    // The results file names the command and the machine in its header: the table follows the
    // settings there.
    const std::string table =
        "| scene | threads | ray mix: bounce / shadow / validity / coplanar | baker (Mrays/s) | "
        "raw "
        "single rays (Mrays/s) | baker / raw single | raw packets of 8 (Mrays/s) | raw streams of "
        "64 "
        "(Mrays/s) | baker / raw streams |\n|---|---|---|---|---|---|---|---|---|\n" +
        d1 + demo_row + c1 + cn +
        "\nbaker = the bake's rays over its tracing time (every pass after the atlas: validity, "
        "paths, filters, vertex fits); raw = the recorded rays replayed through Embree right "
        "after each bake, on the same threads. In brackets: CPU seconds per wall second (the "
        "machine's load shows as less than the thread count). Packets and streams apply to "
        "the shadow and validity rays; bounce and coplanar rays stay single in every column. The "
        "baker "
        "casts as the streams column does: shadow rays (a texel's paths' or a vertex sample's "
        "paths' at once, rtcOccluded1M) and validity rays (a texel's, rtcIntersect1M) as streams, "
        "bounce and coplanar rays single; baker / raw streams is the like-for-like ratio.\n";
    const std::string out = "Measured by `" + command + "` (" + bench::build_kind() + "; " +
                            machine + "; " + settings + "):\n\n" + table;
    std::fputs(out.c_str(), stdout);
    if (write_docs &&
        !bench::write_result("bake-replay-bench", "The baker against raw Embree on its own rays",
                             command, "Settings: " + settings + ".\n\n" + table))
        return 1;
    return 0;
}
