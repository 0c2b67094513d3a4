// Baker throughput against the limit: rays per second of the whole lightmap bake (path tracing,
// validity rays, everything counted in BakeReport::rays over the tracing time) against plain
// rtcIntersect1 on the same Embree scene with the same threads (random origins in the scene's
// bounds, uniform directions: incoherent rays like the bake's bounces). Target: >= 60 %.
// Also the time to bake the demo scene at the default settings of `hmdnode bake`.
//
// usage: bench_bake_bench [scene.glb] [threads] [--write-docs]
//   (default: the built demo scene, all cores; --write-docs: also into
//   docs/results/bake-bench.md)
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

// One markdown table row for the scene, or an empty string (reason on stderr) when it fails.
std::string run(const char* name, Scene scene, int threads, const BakeOptions& options_in) {
    BakeOptions options = options_in;
    options.threads = threads;
    Result<PathTracer> tracer = PathTracer::build(scene, PathTracerOptions{});
    if (!tracer) {
        std::fprintf(stderr, "%s: %s\n", name, tracer.error().message.c_str());
        return {};
    }
    // Warm up, then the raw limit (best of 3).
    (void)tracer->raw_rays_per_second(200000, threads, 1);
    double raw = 0.0;
    for (int k = 0; k < 3; ++k)
        raw = std::max(raw, tracer->raw_rays_per_second(2000000, threads, k));
    Result<BakeReport> r = bake_scene(scene, options);
    if (!r) {
        std::fprintf(stderr, "%s: %s\n", name, r.error().message.c_str());
        return {};
    }
    char line[512];
    std::snprintf(line, sizeof line,
                  "| %s | %zu | %zu | %zu | %.2f | %.2f | %llu | %.2f | %.2f | %.1f %% |\n", name,
                  r->triangles, r->texels, r->vertices, r->seconds, r->trace_seconds,
                  static_cast<unsigned long long>(r->rays), r->rays_per_second / 1e6, raw / 1e6,
                  100.0 * r->rays_per_second / raw);
    return line;
}

}  // namespace

int main(int argc, char** argv) {
    const bool write_docs = bench::wants_docs(argc, argv);
    std::vector<std::string> args;  // positional: [scene.glb] [threads]
    for (int i = 1; i < argc; ++i)
        if (std::string(argv[i]) != "--write-docs") args.push_back(argv[i]);
    const std::string path = !args.empty() ? args[0] : HMDNODE_BINARY_DIR "/data/demo_room.glb";
    const int threads = args.size() > 1 ? std::atoi(args[1].c_str()) : 0;

    std::string command = "build/release/bench/bench_bake_bench";
    for (const std::string& a : args) {
        command += ' ';
        command += bench::in_tree(a);
    }
    if (write_docs) command += " --write-docs";

    const BakeOptions defaults;  // what `hmdnode bake` uses
    const std::string threads_text = std::to_string(resolve_threads(threads)) + " threads" +
                                     (threads == 0 ? " = all cores" : "");
    const std::string defaults_text =
        "`hmdnode bake`'s defaults: " + std::to_string(defaults.samples) + " paths per texel, " +
        (defaults.bounces < 0 ? std::string("bounces until Russian roulette")
                              : std::to_string(defaults.bounces) + " bounces") +
        ", " + std::to_string(defaults.denoise_iterations) + " denoiser passes";
    std::string out = "Measured by `" + command + "` (" + threads_text + "; " +
                      bench::build_kind() + "; " + bench::machine_facts() + "; " + defaults_text +
                      "):\n\n";
    // The results file names the command and the machine in its header.
    const size_t table_start = out.size();
    out +=
        "| scene | triangles | texels | vertices | bake (s) | trace (s) | rays | baker (Mrays/s) "
        "| raw rtcIntersect1 (Mrays/s) | baker / raw |\n"
        "|---|---|---|---|---|---|---|---|---|---|\n";
    std::string demo_row, cornell_row;
    if (Result<Scene> demo = load_gltf(path); demo) {
        const std::string file = std::filesystem::path(path).filename().string();
        demo_row = run(file == "demo_room.glb" ? "demo scene" : file.c_str(), std::move(*demo),
                       threads, defaults);
    } else {
        std::fprintf(stderr, "%s: %s\n", path.c_str(), demo.error().message.c_str());
    }
    cornell_row = run("cornell box", cornell_box_scene(64.0), threads, defaults);
    out += demo_row + cornell_row;
    out +=
        "\nbaker = every ray the bake traces (path, shadow and validity rays) over its tracing "
        "time; raw = plain `rtcIntersect1` on the same Embree scene and threads, origins uniform "
        "in the scene's bounds and directions uniform (incoherent, like the bake's bounces), "
        "best of 3 x 2 M rays. Target: baker / raw >= 60 % on the demo scene.\n";
    std::fputs(out.c_str(), stdout);
    if (demo_row.empty() || cornell_row.empty()) return 1;  // the results file keeps its table
    if (write_docs &&
        !bench::write_result(
            "bake-bench", "Baker throughput against raw Embree", command,
            "Settings: " + threads_text + "; " + defaults_text + ".\n\n" + out.substr(table_start)))
        return 1;
    return 0;
}
