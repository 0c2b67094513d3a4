// The runtime LOD targets (docs/lod-selection.md, "Measuring LOD"), measured in one run on this
// machine's renderer (lavapipe here):
//
//  1. LOD against full detail on pose-identical frames (render-bench, --compare full): render
//     time ratio (full / LOD, p50), PSNR and SSIM, on the demo room and on the heavy scene
//     (`hmdnode scene stress`).
//  2. The heavy scene on the real clock at 360x400 per eye, 90 Hz, for `seconds` of the bundled
//     trace: vsyncs on time with the greedy allocator against full detail (threshold at
//     tolerance 0, the selector's finest).
//  3. 1440x1600 per eye on the real clock with the greedy allocator: render time against the
//     budget the controller was given, and vsyncs on time.
//
// Every row records the 1-minute load average at its start and end: on a loaded machine the
// render times (and so the ratios and on-time rates) are the machine's, not the renderer's.
//
// Usage: bench_lod_targets_bench --heavy SCENE.glb [--demo-frames A:B] [--heavy-frames A:B]
//        [--seconds S] [--write-docs]
//        (--write-docs: 1. into docs/results/lod-targets-compare.md, 2. and 3. into
//        docs/results/lod-targets-real-clock.md)
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <tuple>
#include <vector>

#include "doc_table.hpp"
#include "hmdnode/core/gltf.hpp"
#include "hmdnode/firmware_host/render_bench.hpp"
#include "hmdnode/firmware_host/replay.hpp"

using namespace hmdnode;

int main(int argc, char** argv) {
    const bool write_docs = bench::wants_docs(argc, argv);
    std::string heavy;
    std::string demo_frames = "100:1100", heavy_frames = "100:1100";
    double seconds = 60.0;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        const bool has_value = i + 1 < argc;
        if (a == "--heavy" && has_value)
            heavy = argv[++i];
        else if (a == "--demo-frames" && has_value)
            demo_frames = argv[++i];
        else if (a == "--heavy-frames" && has_value)
            heavy_frames = argv[++i];
        else if (a == "--seconds" && has_value)
            seconds = std::atof(argv[++i]);
        else if (a != "--write-docs") {
            std::fprintf(stderr,
                         "usage: %s --heavy SCENE.glb [--demo-frames A:B] [--heavy-frames A:B] "
                         "[--seconds S] [--write-docs]\n",
                         argv[0]);
            return 2;
        }
    }
    RenderBenchOptions demo_opt, heavy_opt;
    if (heavy.empty() || !(seconds > 0.0) ||
        !bench::parse_range(demo_frames, &demo_opt.first_frame, &demo_opt.end_frame) ||
        !bench::parse_range(heavy_frames, &heavy_opt.first_frame, &heavy_opt.end_frame)) {
        std::fprintf(stderr, "%s: --heavy is required; ranges are A:B with A < B; seconds > 0\n",
                     argv[0]);
        return 2;
    }
    const std::string trace = HMDNODE_SOURCE_DIR "/data/traces/corbillon2018_user1.csv";
    const std::string demo = HMDNODE_BINARY_DIR "/data/demo_room.glb";
    // The first line names the machine on the terminal; the results files name it in their
    // headers and hold the heavy scene's line and one part each.
    std::string out = "machine: " + bench::machine_facts() + "; " + bench::build_kind() + "\n";
    std::string heavy_line, device;
    char line[512];
    {
        Result<Scene> s = load_gltf(heavy);
        if (!s.ok()) {
            std::fprintf(stderr, "%s\n", s.error().message.c_str());
            return 1;
        }
        size_t objects = 0, full = 0, coarse = 0;
        for (const SceneObject& o : flatten_objects(*s)) {
            ++objects;
            full += o.levels.front().triangles;
            coarse += o.levels.back().triangles;
        }
        std::snprintf(line, sizeof line,
                      "heavy scene: %s, %zu objects, %zu triangles at full detail, %zu at the "
                      "coarsest levels\n\n",
                      std::filesystem::path(heavy).filename().c_str(), objects, full, coarse);
        heavy_line = line;
        out += line;
    }

    // 1. Pose-identical frames.
    const size_t compare_start = out.size();
    out += "LOD (auto, threshold) against full detail, 360x400 per eye, bundled trace\n";
    std::snprintf(line, sizeof line, "%-8s %-10s %8s %8s %7s %9s %9s %7s %7s %11s\n", "scene",
                  "frames", "LOD ms", "full ms", "ratio", "PSNR med", "PSNR min", "SSIM", "min",
                  "load");
    out += line;
    for (auto [name, scene, opt] :
         {std::tuple{"demo", demo, demo_opt}, std::tuple{"heavy", heavy, heavy_opt}}) {
        opt.scene = scene;
        opt.trace = trace;
        opt.compare_full = true;
        Result<RenderBenchResult> r = run_render_bench(opt);
        if (!r.ok()) {
            std::fprintf(stderr, "%s: %s\n", name, r.error().message.c_str());
            return 1;
        }
        device = r->device_name;
        const RenderBenchSummary& s = r->summary;
        std::snprintf(line, sizeof line,
                      "%-8s %-10s %8.1f %8.1f %6.2fx %9.2f %9.2f %7.4f %7.4f %5.1f->%-5.1f\n", name,
                      (std::to_string(opt.first_frame) + ":" +
                       std::to_string(opt.first_frame + int64_t(s.frames)))
                          .c_str(),
                      s.render_ms.p50, s.full_render_ms.p50, s.time_ratio, s.psnr_median,
                      s.psnr_min, s.ssim_median, s.ssim_min, s.load_start, s.load_end);
        out += line;
        std::fputs(line, stderr);
    }

    // 2 and 3. Real clock.
    out += "\n";
    const size_t real_clock_start = out.size();
    out += "heavy scene, real clock, " + std::to_string(int(seconds)) +
           " s of the bundled trace, 90 Hz\n";
    std::snprintf(line, sizeof line, "%-34s %9s %9s %9s %10s %11s\n", "run", "on time",
                  "render p50", "p95", "budget p50", "load");
    out += line;
    struct Run {
        const char* name;
        int w, h;
        LodAllocator alloc;
        double tolerance;
    };
    for (const Run& run :
         {Run{"360x400 full detail (tolerance 0)", 360, 400, LodAllocator::threshold, 0.0},
          Run{"360x400 greedy", 360, 400, LodAllocator::greedy, 1.0},
          Run{"1440x1600 greedy", 1440, 1600, LodAllocator::greedy, 1.0}}) {
        ReplayOptions ro;
        ro.scene = heavy;
        ro.trace = trace;
        ro.simulated_clock = false;
        ro.duration_s = seconds;
        ro.display.eye_width = run.w;
        ro.display.eye_height = run.h;
        ro.node.lod_allocator = run.alloc;
        ro.node.lod.tolerance_px = run.tolerance;
        const double l0 = bench::load1();
        Result<ReplayResult> r = run_replay(ro);
        const double l1 = bench::load1();
        if (!r.ok()) {
            std::fprintf(stderr, "%s: %s\n", run.name, r.error().message.c_str());
            return 1;
        }
        std::vector<double> budget;
        for (const FrameRecord& f : r->frames)
            if (f.kind == FrameKind::new_frame && std::isfinite(f.lod_budget_ms))
                budget.push_back(f.lod_budget_ms);
        char budget_text[32] = "-";
        if (!budget.empty())
            std::snprintf(budget_text, sizeof budget_text, "%.1f", bench::quantile(budget, 0.5));
        const ReplaySummary& s = r->summary;
        std::snprintf(line, sizeof line, "%-34s %8.1f%% %9.1f %9.1f %10s %5.1f->%-5.1f\n", run.name,
                      100.0 * s.on_time_rate, s.render_ms.p50, s.render_ms.p95, budget_text, l0,
                      l1);
        out += line;
        std::fputs(line, stderr);
    }
    const size_t real_clock_end = out.size();
    const std::string legend =
        "(ms: render time per frame, both eyes; ratio: full / LOD p50; on time: vsyncs that "
        "showed a new or re-warped frame on time)\n";
    out += legend;
    std::fputs(out.c_str(), stdout);
    if (write_docs) {
        const std::string command = bench::command_line(argc, argv);
        const std::string compare = out.substr(compare_start, real_clock_start - 1 - compare_start);
        const std::string real_clock =
            out.substr(real_clock_start, real_clock_end - real_clock_start);
        if (!bench::write_result("lod-targets-compare",
                                 "LOD targets: LOD against full detail on pose-identical frames",
                                 command, "```\n" + heavy_line + compare + legend + "```\n",
                                 device) ||
            !bench::write_result("lod-targets-real-clock",
                                 "LOD targets: the heavy scene on the real clock", command,
                                 "```\n" + heavy_line + real_clock + legend + "```\n", device))
            return 1;
    }
    return 0;
}
