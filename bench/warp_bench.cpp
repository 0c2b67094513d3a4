// The late-warp + lens pass on its own: the cost per stereo frame of warp() on the demo room, for
// the generic and the Valve Index profile at three panel sizes, each pass beside its floor in the
// same run: the fused pass (the lens model per pixel; with and without chromatic-aberration
// correction), the distortion-mesh pass at the mesh the node would choose (the coarsest within
// 0.5 px of the model), and the floor (three bilinear samples per pixel, no lens model: the mesh
// pass over one cell), and the fused pass with the latency marker drawn (Renderer::
// set_latency_marker, docs/latency.md, "The overlay") beside it without (the fused row: off is the
// pass itself, nothing drawn). Targets: the fused pass <= 1.15x its floor; the marker adds <= 0.1
// ms (on lavapipe at 360x400 per eye). Every pass of a configuration
// runs on one renderer, in alternating blocks of warps (see below), so machine drift hits all
// alike; medians and 99th percentiles; the renderer is HMDNODE_RENDERER's (vulkan by default).
//
// Usage: bench_warp_bench [rounds=200] [--write-docs]   (--write-docs: also into
//        docs/results/warp-bench.md)
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
        int w, h;
    };
    const Config configs[] = {{"generic", 360, 400},       {"valve-index", 360, 400},
                              {"generic", 540, 600},       {"valve-index", 540, 600},
                              {"valve-index", 1440, 1600}, {"none", 360, 400}};
    enum Pass { fused, fused_marker, fused_no_ca, mesh_pass, floor_pass, kPasses };
    const char* pass_names[kPasses] = {"fused", "fused + marker", "fused, no CA", "mesh", "floor"};
    struct Bench {
        Config config;
        int mesh_cells = 0;
        std::unique_ptr<Renderer> renderer;  // one device: the passes differ in the pass alone
        HeadsetProfile profile;
        DistortionMesh mesh[2], one[2];
        StereoViews views;
        std::vector<DrawItem> items;
        std::vector<double> warp_ms[kPasses], scene_ms;
        LatencyMarkerOverlay marker;  // the node's place for it, 4 px cells
    };
    std::vector<Bench> benches;
    std::string device, backend;
    for (const Config& c : configs) {
        Bench b;
        b.config = c;
        HeadsetProfile profile =
            std::string(c.profile) == "generic" ? generic_headset_profile() : *index;
        if (std::string(c.profile) == "none")  // rotational warp only: no lens
            for (int e = 0; e < 2; ++e) {
                profile.eye[e] = EyeLens{};
                profile.eye[e].fov = StereoRig::typical().eye[e];
            }
        b.mesh_cells =
            std::string(c.profile) == "none" ? 1 : choose_mesh_cells(profile, c.w, c.h, 0.5);
        const DistortionMesh mesh[2] = {
            make_distortion_mesh(profile, 0, b.mesh_cells, b.mesh_cells),
            make_distortion_mesh(profile, 1, b.mesh_cells, b.mesh_cells)};
        const DistortionMesh one[2] = {make_distortion_mesh(profile, 0, 1, 1),
                                       make_distortion_mesh(profile, 1, 1, 1)};
        RendererConfig rc;
        rc.eye_width = c.w;
        rc.eye_height = c.h;
        auto renderer = create_renderer(rc);
        if (!renderer.ok()) {
            std::fprintf(stderr, "warp bench: %s\n", renderer.error().message.c_str());
            return 1;
        }
        b.renderer = std::move(*renderer);
        device = b.renderer->device_name();
        backend = b.renderer->backend_name();
        if (Status s = b.renderer->upload(*scene); !s.ok()) return 1;
        b.profile = profile;
        b.marker = default_latency_marker_overlay(c.w, c.h, 4);
        b.mesh[0] = mesh[0], b.mesh[1] = mesh[1], b.one[0] = one[0], b.one[1] = one[1];
        StereoRig rig = StereoRig::typical();
        rig.eye[0] = mesh_render_fov(mesh[0], 0.1);
        rig.eye[1] = mesh_render_fov(mesh[1], 0.1);
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
    // In blocks: per configuration and pass, the pass set up on the configuration's renderer
    // (untimed), two warps to warm it, then `block` timed warps without read-back (a display
    // scans the panel image out itself); the passes take turns at going first, and blocks of all
    // configurations alternate, so machine drift hits every pass alike. Headset resolution gets
    // a tenth of the warps.
    const int block = 10, blocks = std::max(1, rounds / block);
    auto set_up = [&](Bench& b, int p) -> Status {
        const Config& c = b.config;
        Renderer& r = *b.renderer;
        Status s = p == fused || p == fused_marker || p == fused_no_ca
                       ? r.set_lens_warp(c.w, c.h, b.profile)
                   : p == mesh_pass ? r.set_warp(c.w, c.h, b.mesh[0], b.mesh[1])
                                    : r.set_warp(c.w, c.h, b.one[0], b.one[1]);
        if (!s.ok()) return s;
        if (p == fused_no_ca) r.set_chromatic_aberration(false);
        r.set_latency_marker(p == fused_marker ? &b.marker : nullptr);
        return r.render(b.views, b.items, nullptr).ok() ? Status::success()
                                                        : make_error("render failed");
    };
    for (int i = 0; i < blocks; ++i)
        for (Bench& b : benches) {
            const int n = b.config.w > 1000 ? std::max(1, block / 10) : block;
            for (int k = 0; k < kPasses; ++k) {
                const int p = (k + i) % kPasses;
                if (Status s = set_up(b, p); !s.ok()) {
                    std::fprintf(stderr, "warp bench: %s\n", s.error().message.c_str());
                    return 1;
                }
                for (int j = 0; j < n + 2; ++j) {
                    const glm::dquat delta =
                        glm::angleAxis(deg_to_rad(0.5 * (j % 5)), glm::dvec3(0.0, 1.0, 0.0));
                    const int64_t t0 = now_ns();
                    if (p == fused_marker) b.marker.payload = make_latency_marker_payload(t0, j);
                    if (!b.renderer->warp(delta, nullptr).ok()) return 1;
                    if (j >= 2) b.warp_ms[p].push_back(double(now_ns() - t0) * 1e-6);
                }
            }
            const int64_t t0 = now_ns();
            if (!b.renderer->render(b.views, b.items, nullptr).ok()) return 1;
            b.scene_ms.push_back(double(now_ns() - t0) * 1e-6);
        }
    std::string out;
    char line[512];
    std::snprintf(line, sizeof line,
                  "late warp + lens pass per stereo frame (ms, no read-back), %d blocks of %d "
                  "warps per pass; floor = three bilinear samples per pixel, no lens model\n",
                  blocks, block);
    out += line;
    std::snprintf(line, sizeof line, "%-12s %10s %5s | %-14s %8s %8s %8s %8s\n", "profile", "eye",
                  "mesh", "pass", "p50", "p99", "x floor", "target");
    out += line;
    for (const Bench& b : benches) {
        const Config& c = b.config;
        char eye[32];
        std::snprintf(eye, sizeof eye, "%dx%d", c.w, c.h);
        const double floor_p50 = quantile(b.warp_ms[floor_pass], 0.5);
        for (int p = 0; p < kPasses; ++p) {
            const double p50 = quantile(b.warp_ms[p], 0.5);
            std::snprintf(line, sizeof line, "%-12s %10s %5d | %-14s %8.2f %8.2f %8.2f %8s\n",
                          p == 0 ? c.profile : "", p == 0 ? eye : "", b.mesh_cells, pass_names[p],
                          p50, quantile(b.warp_ms[p], 0.99), p50 / floor_p50,
                          p == fused ? "<= 1.15" : "");
            out += line;
        }
        // The marker side by side: on minus off (the fused row), per stereo frame.
        std::snprintf(line, sizeof line, "%-12s %10s %5s | %-14s %+8.3f %8s %8s %8s\n", "", "", "",
                      "(marker adds)",
                      quantile(b.warp_ms[fused_marker], 0.5) - quantile(b.warp_ms[fused], 0.5), "",
                      "", "<= +0.1");
        out += line;
        std::snprintf(line, sizeof line, "%-12s %10s %5s | %-14s %8.2f\n", "", "", "",
                      "(scene render)", quantile(b.scene_ms, 0.5));
        out += line;
    }
    out += "device: " + device + " (" + backend + ")\n";
    out +=
        "mesh: the coarsest mesh within 0.5 px of the lens model at that size (what the node "
        "chooses); none = the rotational warp alone (one sample per pixel in every pass); scene "
        "= the demo room at its coarsest levels, same run; marker = the latency marker (14x14 "
        "cells of 4 px) into both eyes, off in every other row\n";
    std::fputs(out.c_str(), stdout);
    if (write_docs &&
        !bench::write_result("warp-bench", "The late warp + lens pass beside its floor",
                             bench::command_line(argc, argv), "```\n" + out + "```\n",
                             device + " (" + backend + ")"))
        return 1;
    return 0;
}
