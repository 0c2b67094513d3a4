// The late-warp + lens pass on its own: the cost per stereo frame of warp() on the demo room, for
// the generic and the Valve Index profile at three panel sizes, each pass beside its floor in the
// same run: the fused pass (the lens model per pixel; with and without chromatic-aberration
// correction), the distortion-mesh pass at the mesh the node would choose (the coarsest within
// 0.5 px of the model), and the floor (three bilinear samples per pixel, no lens model: the mesh
// pass over one cell). Target: the fused pass <= 1.15x its floor. Medians and 99th percentiles of
// interleaved runs (one warp of each pass per round), so machine drift hits all alike; the
// renderer is HMDNODE_RENDERER's (vulkan by default).
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
        int w, h;
    };
    const Config configs[] = {{"generic", 360, 400},   {"valve-index", 360, 400},
                              {"generic", 540, 600},   {"valve-index", 540, 600},
                              {"valve-index", 1440, 1600}, {"none", 360, 400}};
    enum Pass { fused, fused_no_ca, mesh_pass, floor_pass, kPasses };
    const char* pass_names[kPasses] = {"fused", "fused, no CA", "mesh", "floor"};
    struct Bench {
        Config config;
        int mesh_cells = 0;
        std::unique_ptr<Renderer> renderer[kPasses];
        StereoViews views;
        std::vector<DrawItem> items;
        std::vector<double> warp_ms[kPasses], scene_ms;
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
        b.mesh_cells = std::string(c.profile) == "none"
                           ? 1
                           : choose_mesh_cells(profile, c.w, c.h, 0.5);
        const DistortionMesh mesh[2] = {make_distortion_mesh(profile, 0, b.mesh_cells, b.mesh_cells),
                                        make_distortion_mesh(profile, 1, b.mesh_cells, b.mesh_cells)};
        const DistortionMesh one[2] = {make_distortion_mesh(profile, 0, 1, 1),
                                       make_distortion_mesh(profile, 1, 1, 1)};
        for (int p = 0; p < kPasses; ++p) {
            RendererConfig rc;
            rc.eye_width = c.w;
            rc.eye_height = c.h;
            auto renderer = create_renderer(rc);
            if (!renderer.ok()) {
                std::fprintf(stderr, "warp bench: %s\n", renderer.error().message.c_str());
                return 1;
            }
            Renderer& r = **renderer;
            device = r.device_name();
            backend = r.backend_name();
            if (Status s = r.upload(*scene); !s.ok()) return 1;
            Status s = p == fused || p == fused_no_ca ? r.set_lens_warp(c.w, c.h, profile)
                       : p == mesh_pass               ? r.set_warp(c.w, c.h, mesh[0], mesh[1])
                                                      : r.set_warp(c.w, c.h, one[0], one[1]);
            if (!s.ok()) {
                std::fprintf(stderr, "warp bench: %s\n", s.error().message.c_str());
                return 1;
            }
            if (p == fused_no_ca) r.set_chromatic_aberration(false);
            b.renderer[p] = std::move(*renderer);
        }
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
        for (auto& r : b.renderer)
            if (!r->render(b.views, b.items, nullptr).ok()) return 1;
        benches.push_back(std::move(b));
    }
    // Interleaved: one warp of every pass of every configuration per round (headset resolution
    // every 10th), without read-back (a display scans the panel image out itself).
    for (int i = 0; i < rounds + 3; ++i)
        for (Bench& b : benches) {
            if (b.config.w > 1000 && i % 10 != 3) continue;
            const glm::dquat delta =
                glm::angleAxis(deg_to_rad(0.5 * (i % 5)), glm::dvec3(0.0, 1.0, 0.0));
            for (int p = 0; p < kPasses; ++p) {
                const int64_t t0 = now_ns();
                if (!b.renderer[p]->warp(delta, nullptr).ok()) return 1;
                const int64_t t1 = now_ns();
                if (i >= 3) b.warp_ms[p].push_back(double(t1 - t0) * 1e-6);  // after warm-up
            }
            if (i % 20 == 3) {
                const int64_t t0 = now_ns();
                if (!b.renderer[0]->render(b.views, b.items, nullptr).ok()) return 1;
                b.scene_ms.push_back(double(now_ns() - t0) * 1e-6);
            }
        }
    std::string out;
    char line[512];
    std::snprintf(line, sizeof line,
                  "late warp + lens pass per stereo frame (ms, no read-back), %d interleaved "
                  "rounds; floor = three bilinear samples per pixel, no lens model\n",
                  rounds);
    out += line;
    std::snprintf(line, sizeof line, "%-12s %10s %5s | %-13s %8s %8s %8s %8s\n", "profile", "eye",
                  "mesh", "pass", "p50", "p99", "x floor", "target");
    out += line;
    for (const Bench& b : benches) {
        const Config& c = b.config;
        char eye[32];
        std::snprintf(eye, sizeof eye, "%dx%d", c.w, c.h);
        const double floor_p50 = quantile(b.warp_ms[floor_pass], 0.5);
        for (int p = 0; p < kPasses; ++p) {
            const double p50 = quantile(b.warp_ms[p], 0.5);
            std::snprintf(line, sizeof line, "%-12s %10s %5d | %-13s %8.2f %8.2f %8.2f %8s\n",
                          p == 0 ? c.profile : "", p == 0 ? eye : "", b.mesh_cells, pass_names[p],
                          p50, quantile(b.warp_ms[p], 0.99), p50 / floor_p50,
                          p == fused ? "<= 1.15" : "");
            out += line;
        }
        std::snprintf(line, sizeof line, "%-12s %10s %5s | %-13s %8.2f\n", "", "", "",
                      "(scene render)", quantile(b.scene_ms, 0.5));
        out += line;
    }
    out += "device: " + device + " (" + backend + ")\n";
    out +=
        "mesh: the coarsest mesh within 0.5 px of the lens model at that size (what the node "
        "chooses); none = the rotational warp alone (one sample per pixel in every pass); scene "
        "= the demo room at its coarsest levels, same run\n";
    std::fputs(out.c_str(), stdout);
    if (write_docs && !bench::write_doc_table(HMDNODE_SOURCE_DIR "/docs/latency.md",
                                              "warp-bench-table", "```\n" + out + "```\n"))
        return 1;
    return 0;
}
