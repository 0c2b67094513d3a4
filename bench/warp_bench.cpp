// The late-warp + lens pass on its own: the cost per stereo frame of warp() on the demo room, for
// the generic and the Valve Index profile at three panel sizes, each pass beside its floor in the
// same run: the fused pass (the lens model per pixel; with and without chromatic-aberration
// correction), the distortion-mesh pass at the mesh the node would choose (the coarsest within
// 0.5 px of the model), and the floor (three bilinear samples per pixel, no lens model: the mesh
// pass over one cell), and the fused pass with the latency marker drawn (Renderer::
// set_latency_marker, docs/latency.md, "The overlay") beside it without (the fused row: off is the
// pass itself, nothing drawn). Targets: the fused pass <= 1.15x its floor; the marker adds <= 0.1
// ms (on lavapipe at 360x400 per eye), measured again in pairs (below) since a difference of two
// medians of ~7 ms passes is noise of a millisecond on a shared machine. Every pass of a
// configuration runs on one renderer, in alternating blocks of warps (see below), so machine drift
// hits all alike; medians and 99th percentiles; the renderer is HMDNODE_RENDERER's (vulkan by
// default).
//
// The marker in pairs: at 360x400, the fused pass with the marker and without in adjacent warps
// (the order alternating from pair to pair), the median of the pairs' differences in wall time
// and in the process's CPU time (lavapipe's worker threads included); with --write-docs the same
// again in a child with LP_NUM_THREADS=1 (lavapipe on the calling thread alone).
//
// Usage: bench_warp_bench [rounds=200] [--write-docs] [--marker-only]
//        (--write-docs: also into docs/results/warp-bench.md; --marker-only: the pairs alone)
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <ctime>
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

namespace {

// The process's CPU time (every thread: lavapipe's workers too), nanoseconds.
int64_t warp_bench_process_cpu_ns() {
    timespec t{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
    return int64_t(t.tv_sec) * 1000000000 + t.tv_nsec;
}

// `pairs` pairs of fused warps on `r` (set up for its lens pass and rendered), one with `marker`
// and one without, adjacent, the first of a pair alternating; returns the line of the table:
// median, 25th and 75th percentile of the pairs' differences (on - off), wall and CPU, in ms.
std::string warp_bench_marker_pairs(Renderer& r, LatencyMarkerOverlay& marker, int pairs,
                                    const char* profile, int w, int h) {
    std::vector<double> wall, cpu, off_ms;
    for (int i = 0; i < pairs + 2; ++i) {
        double wall_ms[2] = {0, 0}, cpu_ms[2] = {0, 0};
        for (int k = 0; k < 2; ++k) {
            const int on = (k + i) % 2;
            r.set_latency_marker(on ? &marker : nullptr);
            const glm::dquat delta =
                glm::angleAxis(deg_to_rad(0.5 * (i % 5)), glm::dvec3(0.0, 1.0, 0.0));
            const int64_t t0 = now_ns(), c0 = warp_bench_process_cpu_ns();
            if (on) marker.payload = make_latency_marker_payload(t0, uint32_t(i));
            if (!r.warp(delta, nullptr).ok()) return "";
            wall_ms[on] = double(now_ns() - t0) * 1e-6;
            cpu_ms[on] = double(warp_bench_process_cpu_ns() - c0) * 1e-6;
        }
        if (i < 2) continue;  // warm-up
        wall.push_back(wall_ms[1] - wall_ms[0]);
        cpu.push_back(cpu_ms[1] - cpu_ms[0]);
        off_ms.push_back(wall_ms[0]);
    }
    r.set_latency_marker(nullptr);
    char eye[32], line[256];
    std::snprintf(eye, sizeof eye, "%dx%d", w, h);
    std::snprintf(line, sizeof line,
                  "%-12s %10s %6d %8.2f | %+8.3f %+8.3f %+8.3f | %+8.3f %+8.3f %+8.3f %8s\n",
                  profile, eye, pairs, quantile(off_ms, 0.5), quantile(wall, 0.5),
                  quantile(wall, 0.25), quantile(wall, 0.75), quantile(cpu, 0.5),
                  quantile(cpu, 0.25), quantile(cpu, 0.75), "<= +0.1");
    return line;
}

std::string warp_bench_marker_header(const char* threads) {
    char line[512];
    std::string out;
    std::snprintf(line, sizeof line,
                  "the latency marker in pairs (%s): fused pass with minus without, adjacent "
                  "warps, per stereo frame (ms)\n",
                  threads);
    out += line;
    std::snprintf(line, sizeof line, "%-12s %10s %6s %8s | %8s %8s %8s | %8s %8s %8s %8s\n",
                  "profile", "eye", "pairs", "off p50", "wall p50", "p25", "p75", "CPU p50", "p25",
                  "p75", "target");
    return out + line;
}

// The pairs again in a child process whose lavapipe runs on one thread (LP_NUM_THREADS is read
// when the driver loads, so it cannot change in this process); "" when it cannot be run.
std::string warp_bench_single_thread_pairs(const char* self, int rounds) {
    const std::string cmd =
        "LP_NUM_THREADS=1 '" + std::string(self) + "' " + std::to_string(rounds) + " --marker-only";
    FILE* f = popen(cmd.c_str(), "r");
    if (!f) return "";
    std::string out;
    char buf[512];
    while (std::fgets(buf, sizeof buf, f)) out += buf;
    return pclose(f) == 0 ? out : "";
}

}  // namespace

int main(int argc, char** argv) {
    const bool write_docs = bench::wants_docs(argc, argv);
    bool marker_only = false;
    int rounds = 200;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--marker-only")
            marker_only = true;
        else if (a != "--write-docs")
            rounds = std::max(1, std::atoi(argv[i]));
    }
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
        if (marker_only && (c.w != 360 || std::string(c.profile) == "none")) continue;
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
    const int block = 10, blocks = marker_only ? 0 : std::max(1, rounds / block);
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
    // The marker in pairs, at 360x400 with a lens (2 x rounds pairs).
    std::string pairs_out;
    for (Bench& b : benches) {
        if (b.config.w != 360 || std::string(b.config.profile) == "none") continue;
        if (Status s = set_up(b, fused); !s.ok()) return 1;
        const std::string row = warp_bench_marker_pairs(*b.renderer, b.marker, 2 * rounds,
                                                        b.config.profile, b.config.w, b.config.h);
        if (row.empty()) return 1;
        pairs_out += row;
    }
    if (marker_only) {
        std::fputs(pairs_out.c_str(), stdout);
        return 0;
    }
    const char* lp = std::getenv("LP_NUM_THREADS");
    const std::string threads =
        lp ? "LP_NUM_THREADS=" + std::string(lp) : "lavapipe's default threads";
    pairs_out = warp_bench_marker_header(threads.c_str()) + pairs_out;
    if (write_docs && !lp) {
        const std::string one = warp_bench_single_thread_pairs(argv[0], rounds);
        if (one.empty()) {
            std::fprintf(stderr, "warp bench: the LP_NUM_THREADS=1 child failed\n");
            return 1;
        }
        pairs_out += warp_bench_marker_header("LP_NUM_THREADS=1") + one;
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
        std::snprintf(line, sizeof line, "%-12s %10s %5s | %-14s %8.2f\n", "", "", "",
                      "(scene render)", quantile(b.scene_ms, 0.5));
        out += line;
    }
    out += "\n" + pairs_out;
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
