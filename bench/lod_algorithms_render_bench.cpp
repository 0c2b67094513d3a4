// Every simplifier of `hmdnode lod` compared as H. Li, S. Kim, "Mesh Simplification Algorithms for
// Rendering Performance", International Journal of Engineering Research and Technology 13(6), 2020,
// compare theirs: by the render time they save and the image they keep. Per algorithm, the demo
// room's LOD chains are rebuilt with `hmdnode lod --algorithm A` (default ratios 0.5, 0.1, 0.01,
// measured errors), then `render-bench --compare full` (the node's selector, threshold allocator,
// 360x400 per eye, a short frame range of the bundled trace) renders each frame at the node's
// levels and at full detail from the same pose: LOD and full render ms (p50, both eyes, lavapipe),
// PSNR and SSIM against full detail, triangles drawn. Full detail is the same mesh for every
// algorithm; what differs is the levels the selector picks (by their measured errors) and how those
// levels look. `hmdnode lod` keeps the demo room's per-vertex light (_LIGHT_0) at level 0 and
// carries it to every level (docs/lod-generation.md), so the re-chained objects are lit like the
// room's own.
//
// Every row records the 1-minute load average at its start and end.
//
// Usage: bench_lod_algorithms_render_bench [--frames A:B] [--algorithms a,b,...] [--write-docs]
//        (--write-docs: into docs/results/lod-algorithms-render-bench.md)
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "doc_table.hpp"
#include "hmdnode/firmware_host/render_bench.hpp"

using namespace hmdnode;
namespace fs = std::filesystem;

int main(int argc, char** argv) {
    const bool write_docs = bench::wants_docs(argc, argv);
    std::string frames = "100:130";
    std::vector<std::string> algorithms = {"qem", "curvature-qem", "formula1", "melax",
                                           "ss",  "fad",           "vt",       "ivdd",
                                           "vtd", "fass",          "grid",     "openmesh-quadric"};
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        const bool has_value = i + 1 < argc;
        if (a == "--frames" && has_value) {
            frames = argv[++i];
        } else if (a == "--algorithms" && has_value) {
            algorithms.clear();
            std::stringstream list(argv[++i]);
            for (std::string name; std::getline(list, name, ',');)
                if (!name.empty()) algorithms.push_back(name);
        } else if (a != "--write-docs") {
            std::fprintf(stderr, "usage: %s [--frames A:B] [--algorithms a,b,...] [--write-docs]\n",
                         argv[0]);
            return 2;
        }
    }
    RenderBenchOptions base;
    if (!bench::parse_range(frames, &base.first_frame, &base.end_frame) || algorithms.empty()) {
        std::fprintf(stderr, "%s: --frames is A:B with A < B; --algorithms names at least one\n",
                     argv[0]);
        return 2;
    }
    const std::string trace = HMDNODE_SOURCE_DIR "/data/traces/corbillon2018_user1.csv";
    const std::string demo = HMDNODE_BINARY_DIR "/data/demo_room.glb";
    const fs::path dir = fs::temp_directory_path() / "hmdnode_lod_algorithms_render";
    fs::create_directories(dir);
    // The first line names the machine on the terminal; the results file names it in its header
    // and holds the rest.
    std::string out = "machine: " + bench::machine_facts() + "; " + bench::build_kind() + "\n";
    const size_t table_start = out.size();
    std::string device;
    char line[512];
    std::snprintf(line, sizeof line,
                  "demo room re-chained per algorithm (hmdnode lod, ratios 0.5/0.1/0.01); "
                  "render-bench --compare full, threshold allocator, 360x400 per eye, frames %s "
                  "of the bundled trace, lavapipe\n",
                  frames.c_str());
    out += line;
    std::snprintf(line, sizeof line, "%-17s %7s %8s %8s %7s %9s %9s %7s %9s %11s\n", "algorithm",
                  "lod s", "LOD ms", "full ms", "ratio", "PSNR med", "PSNR min", "SSIM",
                  "triangles", "load");
    out += line;
    std::fputs(out.c_str(), stderr);
    for (const std::string& alg : algorithms) {
        const fs::path scene = dir / ("demo_" + alg + ".glb");
        const double l0 = bench::load1();
        const fs::path log = dir / ("lod_" + alg + ".log");
        const std::string cmd = HMDNODE_TOOL " lod --no-progress --in " + demo + " --out " +
                                scene.string() + " --algorithm " + alg + " > /dev/null 2> " +
                                log.string();
        const int64_t t0 = bench::now_ns();
        if (std::system(cmd.c_str()) != 0) {
            // The tool's own last word (its error names the mesh and what went wrong).
            std::string last, l;
            for (std::ifstream in(log); std::getline(in, l);)
                if (!l.empty()) last = l;
            std::snprintf(line, sizeof line, "%-17s hmdnode lod failed: %s\n", alg.c_str(),
                          last.c_str());
            out += line;
            std::fputs(line, stderr);
            continue;
        }
        const double lod_s = double(bench::now_ns() - t0) * 1e-9;
        RenderBenchOptions opt = base;
        opt.scene = scene;
        opt.trace = trace;
        opt.compare_full = true;
        Result<RenderBenchResult> r = run_render_bench(opt);
        if (!r.ok()) {
            std::snprintf(line, sizeof line, "%-17s render-bench failed: %s\n", alg.c_str(),
                          r.error().message.c_str());
            out += line;
            std::fputs(line, stderr);
            continue;
        }
        device = r->device_name;
        const RenderBenchSummary& s = r->summary;
        std::snprintf(line, sizeof line,
                      "%-17s %7.1f %8.1f %8.1f %6.2fx %9.2f %9.2f %7.4f %9.0f %5.1f->%-5.1f\n",
                      alg.c_str(), lod_s, s.render_ms.p50, s.full_render_ms.p50, s.time_ratio,
                      s.psnr_median, s.psnr_min, s.ssim_median, s.triangles_mean, l0, s.load_end);
        out += line;
        std::fputs(line, stderr);
    }
    out +=
        "(lod s: wall time of hmdnode lod on the demo room; ms: render time per frame, both eyes, "
        "p50; ratio: full / LOD; triangles: drawn per LOD frame, mean)\n";
    std::fputs(out.c_str(), stdout);
    if (write_docs &&
        !bench::write_result("lod-algorithms-render-bench",
                             "Every simplifier's LOD chains on the demo room, against full detail",
                             bench::command_line(argc, argv),
                             "```\n" + out.substr(table_start) + "```\n", device))
        return 1;
    return 0;
}
