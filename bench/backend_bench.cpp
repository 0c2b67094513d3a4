// The two renderer backends side by side: Vulkan (lavapipe) and OpenGL ES 3 on EGL (llvmpipe), both
// on Mesa's software rasteriser, at 360x400 per eye on the demo room, per stereo frame: the scene
// pass (both eyes, no read-back), the scene pass with the read-back of both eyes, the late warp +
// distortion pass (generic profile, 32x32 mesh, no read-back) and scene + warp together. Medians
// and 99th percentiles of interleaved rounds (one frame of each backend per round), so machine
// drift hits both alike, against the GLES backend's target: GLES <= 1.3x Vulkan.
//
// Usage: bench_backend_bench [rounds=200] [--write-docs]
//   (--write-docs: into docs/results/backend-bench.md)
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

#include "doc_table.hpp"
#include "hmdnode/core/gltf.hpp"
#include "hmdnode/core/stereo.hpp"
#include "hmdnode/render/lens.hpp"
#include "hmdnode/render/renderer.hpp"

using namespace hmdnode;

using bench::now_ns;
using bench::quantile;

int main(int argc, char** argv) {
    const bool write_docs = bench::wants_docs(argc, argv);
    const int rounds =
        argc > 1 && std::string(argv[1]) != "--write-docs" ? std::atoi(argv[1]) : 200;
    if (rounds < 1) {
        std::fprintf(stderr, "usage: bench_backend_bench [rounds>=1] [--write-docs]\n");
        return 2;
    }
    const std::string machine = bench::machine_facts();
    Result<Scene> scene = load_gltf(HMDNODE_BINARY_DIR "/data/demo_room.glb");
    if (!scene.ok()) {
        std::fprintf(stderr, "backend bench: %s\n", scene.error().message.c_str());
        return 1;
    }
    const int w = 360, h = 400, cells = 32;
    const HeadsetProfile profile = generic_headset_profile();
    const DistortionMesh left = make_distortion_mesh(profile, 0, cells, cells);
    const DistortionMesh right = make_distortion_mesh(profile, 1, cells, cells);
    StereoRig rig = StereoRig::typical();
    rig.eye[0] = mesh_render_fov(left, 0.1);
    rig.eye[1] = mesh_render_fov(right, 0.1);
    Pose head;
    head.position = {0.0, 1.6, 0.0};
    StereoViews views;
    for (int e = 0; e < 2; ++e) {
        views.view[e] = eye_view_matrix(rig, head, e);
        views.projection[e] = eye_projection(rig.eye[e], rig.near_m, rig.far_m);
    }
    // The finest level of every object: the scene's whole triangle count.
    std::vector<DrawItem> items;
    for (const SceneObject& o : flatten_objects(*scene))
        items.push_back(DrawItem{o.levels.front().mesh, glm::mat4(o.world)});

    struct Bench {
        std::string backend;
        std::unique_ptr<Renderer> renderer;
        std::vector<double> scene_ms, scene_rb_ms, warp_ms, frame_ms;
        uint64_t triangles = 0;
        StereoImage image;
    };
    Bench benches[2];
    benches[0].backend = "vulkan";
    benches[1].backend = "gles";
    for (Bench& b : benches) {
        RendererConfig rc;
        rc.eye_width = w;
        rc.eye_height = h;
        rc.backend = b.backend;
        auto renderer = create_renderer(rc);
        if (!renderer.ok()) {
            std::fprintf(stderr, "backend bench: %s\n", renderer.error().message.c_str());
            return 1;
        }
        b.renderer = std::move(*renderer);
        if (Status s = b.renderer->upload(*scene); !s.ok()) {
            std::fprintf(stderr, "backend bench: %s\n", s.error().message.c_str());
            return 1;
        }
        if (Status s = b.renderer->set_warp(w, h, left, right); !s.ok()) {
            std::fprintf(stderr, "backend bench: %s\n", s.error().message.c_str());
            return 1;
        }
    }
    for (int i = 0; i < rounds + 3; ++i)
        for (Bench& b : benches) {
            const int64_t t0 = now_ns();
            auto stats = b.renderer->render(views, items, nullptr);
            const int64_t t1 = now_ns();
            const glm::dquat delta =
                glm::angleAxis(deg_to_rad(0.5 * (i % 5)), glm::dvec3(0.0, 1.0, 0.0));
            if (!stats.ok() || !b.renderer->warp(delta, nullptr).ok()) return 1;
            const int64_t t2 = now_ns();
            if (!b.renderer->render(views, items, &b.image).ok()) return 1;
            const int64_t t3 = now_ns();
            if (i < 3) continue;  // warm-up (shader compilation, first-use allocations)
            b.triangles = stats->triangles;
            b.scene_ms.push_back(double(t1 - t0) * 1e-6);
            b.warp_ms.push_back(double(t2 - t1) * 1e-6);
            b.frame_ms.push_back(double(t2 - t0) * 1e-6);
            b.scene_rb_ms.push_back(double(t3 - t2) * 1e-6);
        }

    std::string out;
    char line[512];
    std::snprintf(line, sizeof line,
                  "renderer backends per stereo frame (ms), demo room at its finest levels (%llu "
                  "triangles), %dx%d per eye, warp mesh %dx%d (generic), %d interleaved rounds\n",
                  (unsigned long long)benches[0].triangles, w, h, cells, cells, rounds);
    out += line;
    std::snprintf(line, sizeof line, "%-8s %10s %10s %12s %12s %9s %9s %10s %10s\n", "backend",
                  "scene p50", "scene p99", "scene+rb p50", "scene+rb p99", "warp p50", "warp p99",
                  "frame p50", "frame p99");
    out += line;
    for (const Bench& b : benches) {
        std::snprintf(
            line, sizeof line, "%-8s %10.2f %10.2f %12.2f %12.2f %9.2f %9.2f %10.2f %10.2f\n",
            b.backend.c_str(), quantile(b.scene_ms, 0.5), quantile(b.scene_ms, 0.99),
            quantile(b.scene_rb_ms, 0.5), quantile(b.scene_rb_ms, 0.99), quantile(b.warp_ms, 0.5),
            quantile(b.warp_ms, 0.99), quantile(b.frame_ms, 0.5), quantile(b.frame_ms, 0.99));
        out += line;
    }
    const auto ratio = [&](const std::vector<double> Bench::*v) {
        return quantile(benches[1].*v, 0.5) / quantile(benches[0].*v, 0.5);
    };
    const double frame_ratio = ratio(&Bench::frame_ms);
    std::snprintf(line, sizeof line,
                  "gles/vulkan p50: scene %.2f, scene+rb %.2f, warp %.2f, frame %.2f (target "
                  "frame <= 1.30: %s)\n",
                  ratio(&Bench::scene_ms), ratio(&Bench::scene_rb_ms), ratio(&Bench::warp_ms),
                  frame_ratio, frame_ratio <= 1.3 ? "met" : "NOT met");
    out += line;
    const std::string devices = "vulkan " + benches[0].renderer->device_name() + ", gles " +
                                benches[1].renderer->device_name();
    out += "devices: " + devices + "\n";
    const std::string legend =
        "frame = scene (no read-back) + warp (no read-back); scene+rb = the scene pass with the "
        "read-back of both eyes\n";
    // The results file names the machine in its header: the table there is `out` and the legend.
    const std::string table = "```\n" + out + legend + "```\n";
    out += "machine: " + machine + "; " + bench::build_kind() + "\n";
    out += legend;
    std::fputs(out.c_str(), stdout);
    if (write_docs &&
        !bench::write_result("backend-bench",
                             "Renderer backends side by side: Vulkan against OpenGL ES 3, per "
                             "stereo frame",
                             bench::command_line(argc, argv), table, devices))
        return 1;
    return 0;
}
