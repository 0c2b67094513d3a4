// hmdnode replay: a recorded trace through the whole node on simulated devices.
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "cli/cli_checks.hpp"
#include "hmdnode/firmware_host/replay.hpp"
#include "hmdnode/firmware_host/wiring.hpp"
#include "tool/commands.hpp"

namespace hmdnode::tool {

void add_replay_command(CLI::App& app) {
    auto opt = std::make_shared<ReplayOptions>();
    auto frames_dir = std::make_shared<std::string>();
    auto clock = std::make_shared<std::string>("sim");
    auto quiet = std::make_shared<bool>(false);
    auto no_predict = std::make_shared<bool>(false);
    auto latency_us = std::make_shared<double>(1000.0);
    auto jitter_us = std::make_shared<double>(0.0);
    auto persistence_ms = std::make_shared<double>(2.0);
    auto no_warp = std::make_shared<bool>(false);
    auto no_distortion = std::make_shared<bool>(false);
    auto headset = std::make_shared<std::string>();
    auto mesh = std::make_shared<int>(0);
    auto frame_cost_ms = std::make_shared<double>(-1.0);
    auto warp_cost_ms = std::make_shared<double>(-1.0);
    auto allocator = std::make_shared<std::string>("threshold");
    auto backend = std::make_shared<std::string>();
    auto capture = std::make_shared<std::string>();
    auto eye_tracker = std::make_shared<std::string>("none");
    auto lens_pass = std::make_shared<std::string>("auto");
    auto cpu_wake = std::make_shared<std::string>("auto");
    auto no_ladder = std::make_shared<bool>(false);

    CLI::App* c = app.add_subcommand("replay",
                                     "Replay a head trace through tracking, LOD selection, "
                                     "stereo rendering and a mock headset; write a report");
    c->add_option("--scene", opt->scene, "Scene (.glb/.gltf)")->required();
    c->add_option("--tracker,--backend", *backend,
                  std::string("Tracker backend: ") + kTrackerBackendNames +
                      " (docs/daemon.md, \"Backends\"; default: trace, or capture with "
                      "--capture)");
    c->add_option("--trace", opt->trace,
                  "Trace in hmdnode CSV (see `hmdnode trace import`): --tracker trace replays it, "
                  "--tracker sim moves the simulated device along it");
    c->add_option("--from", opt->from,
                  "--tracker capture: the usbmon capture (pcap or pcap.gz); --tracker rec: the "
                  "libsurvive recording (.rec or .rec.gz)");
    c->add_option("--capture", *capture,
                  "Instead of --trace: a usbmon capture (pcap or pcap.gz) to replay (the same as "
                  "--tracker capture --from FILE)");
    c->add_option("--device", opt->device,
                  "VID:PID[:SERIAL] (hex) of the captured, simulated or live device; --tracker "
                  "rec: the recording's device name (T20, ...)");
    cli::add_eye_tracker_option(c, eye_tracker);
    c->add_option("--report", opt->report, "JSON report to write");
    c->add_option("--frames", *frames_dir, "Directory for PNG frames (both eyes side by side)");
    c->add_option("--frames-every", opt->display.frames_every, "Write every Nth frame")
        ->check(CLI::PositiveNumber);
    c->add_option("--clock", *clock, "sim: deterministic simulated clock; real: system clock")
        ->check(CLI::IsMember({"sim", "real"}));
    c->add_option("--start", opt->start_s,
                  "Start this many seconds into the trace (a capture: after its first report; "
                  "--clock sim only)")
        ->check(CLI::NonNegativeNumber);
    c->add_option("--duration", opt->duration_s, "Replay this many seconds (0: to the end)")
        ->check(CLI::NonNegativeNumber);
    c->add_option("--max-frames", opt->max_frames, "Stop after this many frames (0: no limit)");
    c->add_option("--renderer", opt->renderer.backend,
                  "Renderer backend: vulkan or gles (default: HMDNODE_RENDERER, else vulkan)")
        ->check(CLI::IsMember({"vulkan", "gles"}));
    c->add_option("--eye-width", opt->display.eye_width, "Pixels per eye")
        ->check(CLI::Range(1, 16384));
    c->add_option("--eye-height", opt->display.eye_height, "Pixels per eye")
        ->check(CLI::Range(1, 16384));
    c->add_option("--refresh", opt->display.refresh_hz, "Display refresh rate (Hz)")
        ->check(CLI::Range(1.0, 1000.0));
    c->add_option("--persistence-ms", *persistence_ms, "Panel persistence (ms)")
        ->check(CLI::NonNegativeNumber);
    c->add_option("--ipd", opt->node.rig.ipd_m, "Interpupillary distance (m)")
        ->check(CLI::Range(0.0, 0.1));
    c->add_flag("--no-prediction", *no_predict,
                "Render the newest sample's pose instead of predicting");
    // note: the resampled trace is made up front (SimTracker), so the rate is bounded by what a
    // tracker delivers (4 kHz is twice the fastest IMU report rate of docs/hardware.md's devices).
    c->add_option("--resample", opt->tracker.resample_hz,
                  "Resample the trace at this rate (Hz, at most 4000; 0: as recorded)")
        ->check(CLI::Range(0.0, kMaxResampleHz));
    c->add_option("--noise-deg", opt->tracker.noise_deg,
                  "Gaussian orientation noise (deg, std dev)")
        ->check(CLI::Range(0.0, 180.0));
    c->add_option("--latency-us", *latency_us, "Tracker transport latency (us)")
        ->check(CLI::Range(0.0, kMaxTrackerDelayUs));
    c->add_option("--jitter-us", *jitter_us, "Tracker arrival jitter (us, uniform)")
        ->check(CLI::Range(0.0, kMaxTrackerDelayUs));
    c->add_option("--seed", opt->tracker.seed, "Seed for noise and jitter");
    c->add_option("--lod-tolerance-px", opt->node.lod.tolerance_px,
                  "LOD pixel tolerance at the gaze point")
        ->check(CLI::NonNegativeNumber);
    c->add_option("--allocator", *allocator,
                  "LOD allocator: threshold (the perceptual selector's levels) greedy (coarsen "
                  "them until the learned render cost fits the frame budget, Funkhouser & Sequin) "
                  "or iga (the same trade by the immune genetic algorithm of He et al.)")
        ->check(CLI::IsMember({"threshold", "greedy", "iga"}));
    c->add_option("--lod-fade-frames", opt->node.lod_fade_frames,
                  "New frames a visible LOD level change cross-fades over (dithered, both levels "
                  "drawn; 0: off, changes pop; default 3)")
        ->check(CLI::Range(0, kMaxLodFadeFrames));
    c->add_option("--msaa", opt->renderer.msaa_samples,
                  "Samples per eye-buffer pixel: 1, or 4 (MSAA, resolved before the warp)")
        ->check(CLI::IsMember({1, 4}));
    c->add_flag("--no-warp", *no_warp,
                "No late warp: show each frame as rendered (a missed vsync repeats the old one)");
    c->add_flag("--no-distortion", *no_distortion,
                "No lens distortion or chromatic-aberration correction");
    c->add_option("--headset", *headset,
                  "Headset profile JSON for the lens (default: the built-in generic one; "
                  "data/headsets/valve-index.json for a Valve Index)");
    c->add_option("--mesh", *mesh,
                  "Distortion mesh cells per side (default 0: the coarsest mesh within 0.5 px of "
                  "the lens model at this eye size)")
        ->check(CLI::Range(0, 512));
    c->add_option("--lens-pass", *lens_pass,
                  "The late warp's pass: fused (the lens model per pixel, one full-screen "
                  "triangle per eye), mesh (the distortion mesh), or auto (fused unless the "
                  "start-up calibration measures the mesh at least 10 % faster)")
        ->check(CLI::IsMember({"auto", "fused", "mesh"}));
    c->add_option("--cpu-wake", *cpu_wake,
                  "System clock: keep the cores awake while the node runs, so the renderer's "
                  "threads do not pay a core's wake-up inside a warp: qos (PM QoS, "
                  "/dev/cpu_dma_latency at 0 us; root), spin (an idle-class spinning thread per "
                  "core: takes no time from others, costs power), auto (qos where a cpuidle driver "
                  "is present, else spin) or off")
        ->check(CLI::IsMember({"auto", "qos", "spin", "off"}));
    c->add_flag("--no-ladder", *no_ladder,
                "No pixel-cost ladder: full eye-buffer resolution and chromatic-aberration "
                "correction always (docs/latency.md)");
    c->add_option("--min-render-scale", opt->node.min_render_scale,
                  "The ladder's lowest eye-buffer resolution per axis (default 0.5)")
        ->check(CLI::Range(0.1, 1.0));
    c->add_option("--max-render-divisor", opt->node.pacing.max_divisor,
                  "The slowest render rate: new frames every N vsyncs at the least, re-warped "
                  "between (default 3; 1: a new frame for every vsync or none)")
        ->check(CLI::Range(1, 4));
    c->add_option("--frame-cost-ms", *frame_cost_ms,
                  "Simulated clock: a fixed render cost per frame instead of the model calibrated "
                  "on the renderer at start-up")
        ->check(CLI::Range(0.0, 10000.0));
    c->add_option("--warp-cost-ms", *warp_cost_ms,
                  "Simulated clock, with --frame-cost-ms: the warp pass's cost (default 0.5)")
        ->check(CLI::Range(0.0, 10000.0));
    c->add_flag("--recentre", opt->recentre,
                "Move a 6DoF trace so that it starts at the default head position (traces whose "
                "positions start at the floor)");
    c->add_option("--registration-distance", opt->node.registration_distance_m,
                  "Distance (m) at which position error counts in the registration error")
        ->check(CLI::Range(0.01, 1000.0));
    c->add_flag("--quiet", *quiet, "Print only the summary");

    // A later occurrence of an option wins, so scripts/demo's defaults can be overridden.
    for (CLI::Option* o : c->get_options())
        if (o->get_expected_max() == 1) o->multi_option_policy(CLI::MultiOptionPolicy::TakeLast);

    c->callback([=] {
        ReplayOptions o = *opt;
        // The one vocabulary (wiring.hpp); --capture FILE is --tracker capture --from FILE.
        std::string name = backend->empty() ? (capture->empty() ? "trace" : "capture") : *backend;
        std::string deprecation;
        Result<TrackerBackend> b =
            parse_tracker_backend(name, WiringKeys::command_line(), &deprecation);
        if (!deprecation.empty())
            std::fprintf(stderr, "hmdnode replay: warning: %s\n", deprecation.c_str());
        if (!b.ok() || (!capture->empty() && (*b != TrackerBackend::capture || !o.from.empty()))) {
            std::fprintf(stderr, "hmdnode replay: error: %s\n",
                         b.ok() ? "--capture FILE is --tracker capture --from FILE: give one"
                                : b.error().message.c_str());
            set_exit_code(2);
            return;
        }
        o.tracker_backend = *b;
        if (!capture->empty()) o.from = *capture;
        if (o.tracker_backend == TrackerBackend::trace && o.trace.empty()) {
            std::fprintf(stderr,
                         "hmdnode replay: error: give --trace FILE, or --capture FILE --device "
                         "VID:PID, or another --tracker (%s)\n",
                         kTrackerBackendNames);
            set_exit_code(2);
            return;
        }
        TrackerSpec spec;
        spec.backend = o.tracker_backend;
        spec.from = o.from;
        spec.trace_path = o.trace;
        spec.device = o.device;
        spec.start_s = o.start_s;
        if (Status st = check_tracker_spec(spec, *clock == "sim" ? ClockKind::sim : ClockKind::real,
                                           WiringKeys::command_line());
            !st.ok()) {
            std::fprintf(stderr, "hmdnode replay: error: %s\n", st.error().message.c_str());
            set_exit_code(2);
            return;
        }
        o.simulated_clock = *clock == "sim";
        o.node.warp = !*no_warp;
        o.node.lod_allocator = *parse_lod_allocator(*allocator);  // checked by IsMember
        o.eye_tracker = *parse_eye_tracker_backend(*eye_tracker, WiringKeys::command_line());
        o.node.distortion = !*no_distortion;
        o.node.mesh_cols = o.node.mesh_rows = *mesh;
        o.node.lens_pass = *parse_lens_pass_choice(*lens_pass);  // checked by IsMember
        o.node.cpu_wake = *parse_cpu_wake(*cpu_wake);            // checked by IsMember
        o.node.pixel_ladder = !*no_ladder;
        if (!headset->empty()) {
            Result<HeadsetProfile> p = load_headset_profile(*headset);
            if (!p.ok()) {
                std::fprintf(stderr, "hmdnode replay: error: %s\n", p.error().message.c_str());
                set_exit_code(1);
                return;
            }
            o.node.headset = *p;
        }
        if (*warp_cost_ms >= 0.0 && *frame_cost_ms < 0.0) {
            std::fprintf(stderr, "hmdnode replay: error: --warp-cost-ms needs --frame-cost-ms\n");
            set_exit_code(2);
            return;
        }
        if (*frame_cost_ms >= 0.0) {
            FrameCostModel m;
            m.base_ns = ms_to_ns(*frame_cost_ms);
            m.per_triangle_ns = 0.0;
            m.warp_ns = ms_to_ns(*warp_cost_ms >= 0.0 ? *warp_cost_ms : 0.5);
            o.frame_cost = m;
        }
        o.display.frames_dir = *frames_dir;
        o.display.persistence_ns = ms_to_ns(*persistence_ms);
        if (Status st = check_persistence(o.display); !st.ok()) {
            std::fprintf(stderr, "hmdnode replay: error: --persistence-ms %s\n",
                         st.error().message.c_str());
            set_exit_code(2);
            return;
        }
        o.node.predict = !*no_predict;
        o.tracker.latency_ns = int64_t(*latency_us * 1000.0);
        o.tracker.jitter_ns = int64_t(*jitter_us * 1000.0);
        if (!*quiet)
            o.on_frame = [](const FrameRecord& f) {
                if (f.index % 90 != 0) return;
                char error[32] = "n/a";  // no truth (a capture)
                if (std::isfinite(f.registration_error_deg))
                    std::snprintf(error, sizeof error, "%.2f deg", f.registration_error_deg);
                std::fprintf(stderr, "\rpresent %llu  latency %.1f ms  error %s   ",
                             (unsigned long long)f.index, f.latency_ms, error);
            };
        Result<ReplayResult> r = run_replay(o);
        if (!*quiet) std::fprintf(stderr, "\r%60s\r", "");
        if (!r.ok()) {
            std::fprintf(stderr, "hmdnode replay: error: %s\n", r.error().message.c_str());
            set_exit_code(1);
            return;
        }
        std::fputs(replay_summary_table(*r).c_str(), stdout);
        if (!o.report.empty()) std::printf("report: %s\n", o.report.c_str());
        if (!o.display.frames_dir.empty())
            std::printf("frames: %s\n", o.display.frames_dir.c_str());
    });
}

}  // namespace hmdnode::tool
