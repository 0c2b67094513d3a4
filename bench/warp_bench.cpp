// The late-warp + lens-distortion pass on its own: the cost per stereo frame of warp() (record,
// GPU, panel read-back) on the demo room, by panel size and distortion-mesh resolution, for the
// generic and the Valve Index profile, beside the target of 1.5 ms at 360x400 per eye (the
// compositor issue) and the scene render of the same frame. Medians and 99th percentiles of
// interleaved runs (one warp of each configuration per round), so machine drift hits all alike.
//
// Usage: bench_warp_bench [rounds=200] [--write-docs]   (--write-docs: also into docs/latency.md)
#include <algorithm>
#include <chrono>
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
    Result<Scene> scene = load_gltf(HMDNODE_BINARY_DIR "/data/demo_room.glb");
    if (!scene.ok()) {
        std::fprintf(stderr, "warp bench: %s\n", scene.error().message.c_str());
        return 1;
    }
    Result<HeadsetProfile> index =
        load_headset_profile(HMDNODE_SOURCE_DIR "/data/headsets/valve-index.json");
    if (!index.ok()) {
        std::fprintf(stderr, "warp bench: %s\n", index.error().message.c_str());
        return 1;
    }
    struct Config {
        const char* profile;
        int w, h, mesh;
    };
    const Config configs[] = {{"generic", 360, 400, 16},
                              {"generic", 360, 400, 32},
                              {"generic", 360, 400, 64},
                              {"valve-index", 360, 400, 64},
                              {"generic", 540, 600, 64},
                              {"valve-index", 1440, 1600, 64},
                              {"none", 360, 400, 1},
                              {"valve-index", 360, 400, 48},
                              {"generic", 360, 400, 24},
                              // The floors: three samples per pixel with no mesh overhead (one
                              // cell: far from the lens model, the cost only), and the fixed cost
                              // of a submit (an 8x8 panel).
                              {"generic", 360, 400, 1},
                              {"none", 8, 8, 1}};
    struct Bench {
        Config config;
        std::unique_ptr<Renderer> renderer;
        StereoViews views;
        std::vector<DrawItem> items;
        std::vector<double> scene_ms, warp_ms, warp_only_ms;
        StereoImage panel;
    };
    std::vector<Bench> benches;
    std::string device;
    for (const Config& c : configs) {
        Bench b;
        b.config = c;
        HeadsetProfile profile =
            std::string(c.profile) == "generic" ? generic_headset_profile() : *index;
        if (std::string(c.profile) == "none")  // warp only: no distortion, one cell
            for (int e = 0; e < 2; ++e) {
                profile.eye[e] = EyeLens{};
                profile.eye[e].fov = StereoRig::typical().eye[e];
            }
        RendererConfig rc;
        rc.eye_width = c.w;
        rc.eye_height = c.h;
        auto renderer = create_vulkan_renderer(rc);
        if (!renderer.ok()) {
            std::fprintf(stderr, "warp bench: %s\n", renderer.error().message.c_str());
            return 1;
        }
        b.renderer = std::move(*renderer);
        device = b.renderer->device_name();
        if (Status s = b.renderer->upload(*scene); !s.ok()) return 1;
        const DistortionMesh left = make_distortion_mesh(profile, 0, c.mesh, c.mesh);
        const DistortionMesh right = make_distortion_mesh(profile, 1, c.mesh, c.mesh);
        if (Status s = b.renderer->set_warp(c.w, c.h, left, right); !s.ok()) {
            std::fprintf(stderr, "warp bench: %s\n", s.error().message.c_str());
            return 1;
        }
        StereoRig rig = StereoRig::typical();
        rig.eye[0] = mesh_render_fov(left, 0.1);
        rig.eye[1] = mesh_render_fov(right, 0.1);
        Pose head;
        head.position = {0.0, 1.6, 0.0};
        for (int e = 0; e < 2; ++e) {
            b.views.view[e] = eye_view_matrix(rig, head, e);
            b.views.projection[e] = eye_projection(rig.eye[e], rig.near_m, rig.far_m);
        }
        for (const SceneObject& o : flatten_objects(*scene))
            b.items.push_back(DrawItem{o.levels.back().mesh, glm::mat4(o.world)});
        benches.push_back(std::move(b));
    }
    // Interleaved: one frame of every configuration per round (headset resolution every 10th).
    for (int i = 0; i < rounds + 3; ++i)
        for (Bench& b : benches) {
            if (b.config.w > 1000 && i % 10 != 3) continue;
            const int64_t t0 = now_ns();
            if (!b.renderer->render(b.views, b.items, nullptr).ok()) return 1;
            const int64_t t1 = now_ns();
            const glm::dquat delta =
                glm::angleAxis(deg_to_rad(0.5 * (i % 5)), glm::dvec3(0.0, 1.0, 0.0));
            if (!b.renderer->warp(delta, &b.panel).ok()) return 1;
            const int64_t t2 = now_ns();
            // Without the read-back (a display that scans out the panel image itself).
            if (!b.renderer->warp(delta, nullptr).ok()) return 1;
            const int64_t t3 = now_ns();
            if (i < 3) continue;  // warm-up (shader compilation)
            b.scene_ms.push_back(double(t1 - t0) * 1e-6);
            b.warp_ms.push_back(double(t2 - t1) * 1e-6);
            b.warp_only_ms.push_back(double(t3 - t2) * 1e-6);
        }
    std::string out;
    char line[512];
    std::snprintf(line, sizeof line,
                  "late warp + distortion pass per stereo frame (ms; record, GPU and read-back of "
                  "both eyes, and without the read-back), %d interleaved rounds\n",
                  rounds);
    out += line;
    std::snprintf(line, sizeof line, "%-12s %11s %5s %9s %9s %12s %12s %11s %9s %8s\n", "profile",
                  "eye", "mesh", "warp p50", "warp p99", "no-rb p50", "no-rb p99", "scene p50",
                  "target", "p50/tgt");
    out += line;
    for (const Bench& b : benches) {
        const Config& c = b.config;
        const double target = 1.5 * double(c.w) * c.h / (360.0 * 400.0);
        char eye[32];
        std::snprintf(eye, sizeof eye, "%dx%d", c.w, c.h);
        // A floor row (one cell, or a panel too small to scale the target to) has no target.
        const bool floor_row =
            (c.mesh == 1 && std::string(c.profile) != "none") || c.w * c.h < 1000;
        char target_text[32] = "-", ratio_text[32] = "-";
        if (!floor_row) {
            std::snprintf(target_text, sizeof target_text, "%.2f", target);
            std::snprintf(ratio_text, sizeof ratio_text, "%.2f",
                          quantile(b.warp_only_ms, 0.5) / target);
        }
        std::snprintf(line, sizeof line,
                      "%-12s %11s %5d %9.2f %9.2f %12.2f %12.2f %11.2f %9s %8s\n", c.profile, eye,
                      c.mesh, quantile(b.warp_ms, 0.5), quantile(b.warp_ms, 0.99),
                      quantile(b.warp_only_ms, 0.5), quantile(b.warp_only_ms, 0.99),
                      quantile(b.scene_ms, 0.5), target_text, ratio_text);
        out += line;
    }
    out += "device: " + device + "\n";
    out +=
        "target: 1.5 ms at 360x400 per eye (scaled by pixel count for other sizes), against "
        "no-rb p50; scene = the demo room at its coarsest levels, same run\n"
        "floors (no target): generic mesh 1 = three bilinear samples per pixel without the "
        "mesh's cost (one cell, not the lens model); none 8x8 = the fixed cost of a submit and "
        "its wait. none 360x400 mesh 1 (with its target) = the rotational warp alone, one sample "
        "per pixel\n";
    std::fputs(out.c_str(), stdout);
    if (write_docs && !bench::write_doc_table(HMDNODE_SOURCE_DIR "/docs/latency.md",
                                              "warp-bench-table", "```\n" + out + "```\n"))
        return 1;
    return 0;
}
