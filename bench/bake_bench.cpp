// Baker throughput against the limit: rays per second of the whole lightmap bake (path tracing,
// validity rays, everything counted in BakeReport::rays over the tracing time) against plain
// rtcIntersect1 on the same Embree scene with the same threads (random origins in the scene's
// bounds, uniform directions: incoherent rays like the bake's bounces). Target: >= 60 %.
// Also the time to bake the demo scene at the default settings of `hmdnode bake`.
//
// usage: bench_bake_bench [scene.glb] [threads]   (default: the built demo scene, all cores)
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "hmdnode/bake/bake.hpp"
#include "hmdnode/bake/cornell_box.hpp"
#include "hmdnode/bake/path_tracer.hpp"
#include "hmdnode/core/gltf.hpp"

using namespace hmdnode;

namespace {

void run(const char* name, Scene scene, int threads, const BakeOptions& options_in) {
    BakeOptions options = options_in;
    options.threads = threads;
    Result<PathTracer> tracer = PathTracer::build(scene, PathTracerOptions{});
    if (!tracer) {
        std::fprintf(stderr, "%s: %s\n", name, tracer.error().message.c_str());
        return;
    }
    // Warm up, then the raw limit (best of 3).
    (void)tracer->raw_rays_per_second(200000, threads, 1);
    double raw = 0.0;
    for (int k = 0; k < 3; ++k)
        raw = std::max(raw, tracer->raw_rays_per_second(2000000, threads, k));
    Result<BakeReport> r = bake_scene(scene, options);
    if (!r) {
        std::fprintf(stderr, "%s: %s\n", name, r.error().message.c_str());
        return;
    }
    std::printf(
        "%-12s %8zu tris %8zu texels %6zu verts | bake %7.2f s (trace %6.2f s) %11llu rays"
        " | baker %7.2f Mrays/s  raw rtcIntersect1 %7.2f Mrays/s  ratio %5.1f %%\n",
        name, r->triangles, r->texels, r->vertices, r->seconds, r->trace_seconds,
        static_cast<unsigned long long>(r->rays), r->rays_per_second / 1e6, raw / 1e6,
        100.0 * r->rays_per_second / raw);
}

}  // namespace

int main(int argc, char** argv) {
    const std::string path = argc > 1 ? argv[1] : HMDNODE_BINARY_DIR "/data/demo_room.glb";
    const int threads = argc > 2 ? std::atoi(argv[2]) : 0;
    std::printf("hmdnode bake benchmark: %d threads (0 = all cores = %d)\n", threads,
                resolve_threads(threads));
    BakeOptions defaults;  // what `hmdnode bake` uses: 64 samples, 3 bounces, denoiser on
    Result<Scene> demo = load_gltf(path);
    if (demo) {
        run("demo scene", std::move(*demo), threads, defaults);
    } else {
        std::fprintf(stderr, "demo scene: %s (skipped)\n", demo.error().message.c_str());
    }
    run("cornell box", cornell_box_scene(64.0), threads, defaults);
    return 0;
}
