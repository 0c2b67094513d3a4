// hmdnode replay: a recorded trace through the whole node on simulated devices. The options are
// added in groups, one per concern, in the order `hmdnode replay --help` lists them; the callback
// checks the tracker's wiring, then the node's settings, then runs run_replay and prints its
// summary. Errors go through CliErrors: usage errors exit 2, a scene, trace or headset profile
// that cannot be read (or a replay that fails) exits 1.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include "cli/cli_checks.hpp"
#include "hmdnode/firmware_host/replay.hpp"
#include "hmdnode/firmware_host/wiring.hpp"
#include "tool/cli_errors.hpp"
#include "tool/commands.hpp"

namespace hmdnode::tool {
namespace {

const CliErrors errors{"replay"};

// The command line: ReplayOptions where an option maps onto it directly, the rest as given
// (turned into options by make_replay_options).
struct ReplayArgs {
    ReplayOptions opt;
    std::string frames_dir;
    std::string clock = "sim";
    bool quiet = false;
    bool no_predict = false;
    double latency_us = 1000.0;
    double jitter_us = 0.0;
    double persistence_ms = 2.0;
    bool no_warp = false;
    bool no_distortion = false;
    std::string headset;
    int mesh = 0;
    double frame_cost_ms = -1.0;
    double warp_cost_ms = -1.0;
    std::string allocator = "threshold";
    std::string backend;
    std::string capture;
    std::string eye_tracker = "none";
    std::string lens_pass = "auto";
    std::string cpu_wake = "auto";
    bool no_ladder = false;
};

// Where the poses (and the gaze) come from, and the scene.
void add_source_options(CLI::App* c, const std::shared_ptr<ReplayArgs>& a) {
    c->add_option("--scene", a->opt.scene, "Scene (.glb/.gltf)")->required();
    c->add_option("--tracker,--backend", a->backend,
                  std::string("Tracker backend: ") + kTrackerBackendNames +
                      " (docs/daemon.md, \"Backends\"; default: trace, or capture with "
                      "--capture)");
    c->add_option("--trace", a->opt.trace,
                  "Trace in hmdnode CSV (see `hmdnode trace import`): --tracker trace replays it, "
                  "--tracker sim moves the simulated device along it");
    c->add_option("--from", a->opt.from,
                  "--tracker capture: the usbmon capture (pcap or pcap.gz); --tracker rec: the "
                  "libsurvive recording (.rec or .rec.gz)");
    c->add_option("--base-stations", a->opt.base_stations,
                  "--tracker rec, capture, hidapi, libusb: a stored base-station setup (JSON, "
                  "docs/formats.md): the recording's, the capture's or the device's light "
                  "tracked too, 6DoF (docs/tracking.md section 12)");
    c->add_option("--capture", a->capture,
                  "Instead of --trace: a usbmon capture (pcap or pcap.gz) to replay (the same as "
                  "--tracker capture --from FILE)");
    c->add_option("--device", a->opt.device,
                  "VID:PID[:SERIAL] (hex) of the captured, simulated or live device; --tracker "
                  "rec: the recording's device name (T20, ...)");
    cli::add_eye_tracker_option(c, std::shared_ptr<std::string>(a, &a->eye_tracker));
}

// What is written: the JSON report and PNG frames.
void add_output_options(CLI::App* c, const std::shared_ptr<ReplayArgs>& a) {
    c->add_option("--report", a->opt.report, "JSON report to write");
    c->add_option("--frames", a->frames_dir, "Directory for PNG frames (both eyes side by side)");
    c->add_option("--frames-every", a->opt.display.frames_every, "Write every Nth frame")
        ->check(CLI::PositiveNumber);
}

// Which clock, and which part of the trace.
void add_span_options(CLI::App* c, const std::shared_ptr<ReplayArgs>& a) {
    c->add_option("--clock", a->clock, "sim: deterministic simulated clock; real: system clock")
        ->check(CLI::IsMember({"sim", "real"}));
    c->add_option("--start", a->opt.start_s,
                  "Start this many seconds into the trace (a capture: after its first report; "
                  "--clock sim only)")
        ->check(CLI::NonNegativeNumber);
    c->add_option("--duration", a->opt.duration_s, "Replay this many seconds (0: to the end)")
        ->check(CLI::NonNegativeNumber);
    c->add_option("--max-frames", a->opt.max_frames, "Stop after this many frames (0: no limit)");
}

// The renderer and the mock headset's panel.
void add_display_options(CLI::App* c, const std::shared_ptr<ReplayArgs>& a) {
    c->add_option("--renderer", a->opt.renderer.backend,
                  "Renderer backend: vulkan or gles (default: HMDNODE_RENDERER, else vulkan)")
        ->check(CLI::IsMember({"vulkan", "gles"}));
    c->add_option("--eye-width", a->opt.display.eye_width, "Pixels per eye")
        ->check(CLI::Range(1, 16384));
    c->add_option("--eye-height", a->opt.display.eye_height, "Pixels per eye")
        ->check(CLI::Range(1, 16384));
    c->add_option("--refresh", a->opt.display.refresh_hz, "Display refresh rate (Hz)")
        ->check(CLI::Range(1.0, 1000.0));
    c->add_option("--persistence-ms", a->persistence_ms, "Panel persistence (ms)")
        ->check(CLI::NonNegativeNumber);
    c->add_option("--ipd", a->opt.node.rig.ipd_m, "Interpupillary distance (m)")
        ->check(CLI::Range(0.0, 0.1));
}

// Prediction, and the simulated tracker's rate, noise and transport.
void add_tracking_options(CLI::App* c, const std::shared_ptr<ReplayArgs>& a) {
    c->add_flag("--no-prediction", a->no_predict,
                "Render the newest sample's pose instead of predicting");
    // note: the resampled trace is made up front (SimTracker), so the rate is bounded by what a
    // tracker delivers (4 kHz is twice the fastest IMU report rate of docs/hardware.md's devices).
    c->add_option("--resample", a->opt.tracker.resample_hz,
                  "Resample the trace at this rate (Hz, at most 4000; 0: as recorded)")
        ->check(CLI::Range(0.0, kMaxResampleHz));
    c->add_option("--noise-deg", a->opt.tracker.noise_deg,
                  "Gaussian orientation noise (deg, std dev)")
        ->check(CLI::Range(0.0, 180.0));
    c->add_option("--latency-us", a->latency_us, "Tracker transport latency (us)")
        ->check(CLI::Range(0.0, kMaxTrackerDelayUs));
    c->add_option("--jitter-us", a->jitter_us, "Tracker arrival jitter (us, uniform)")
        ->check(CLI::Range(0.0, kMaxTrackerDelayUs));
    c->add_option("--seed", a->opt.tracker.seed, "Seed for noise and jitter");
}

// LOD selection and the budget allocator, cross-fades, MSAA.
void add_lod_options(CLI::App* c, const std::shared_ptr<ReplayArgs>& a) {
    c->add_option("--lod-tolerance-px", a->opt.node.lod.tolerance_px,
                  "LOD pixel tolerance at the gaze point")
        ->check(CLI::NonNegativeNumber);
    c->add_option("--allocator", a->allocator,
                  "LOD allocator: threshold (the perceptual selector's levels) greedy (coarsen "
                  "them until the learned render cost fits the frame budget, Funkhouser & Sequin) "
                  "or iga (the same trade by the immune genetic algorithm of He et al.)")
        ->check(CLI::IsMember({"threshold", "greedy", "iga"}));
    c->add_option("--lod-fade-frames", a->opt.node.lod_fade_frames,
                  "New frames a visible LOD level change cross-fades over (dithered, both levels "
                  "drawn; 0: off, changes pop; default 3)")
        ->check(CLI::Range(0, kMaxLodFadeFrames));
    c->add_option("--msaa", a->opt.renderer.msaa_samples,
                  "Samples per eye-buffer pixel: 1, or 4 (MSAA, resolved before the warp)")
        ->check(CLI::IsMember({1, 4}));
}

// The late warp and the lens: distortion, headset profile, mesh or fused pass.
void add_warp_options(CLI::App* c, const std::shared_ptr<ReplayArgs>& a) {
    c->add_flag("--no-warp", a->no_warp,
                "No late warp: show each frame as rendered (a missed vsync repeats the old one)");
    c->add_flag("--no-distortion", a->no_distortion,
                "No lens distortion or chromatic-aberration correction");
    c->add_option("--headset", a->headset,
                  "Headset profile JSON for the lens (default: the built-in generic one; "
                  "data/headsets/valve-index.json for a Valve Index)");
    c->add_option("--mesh", a->mesh,
                  "Distortion mesh cells per side (default 0: the coarsest mesh within 0.5 px of "
                  "the lens model at this eye size)")
        ->check(CLI::Range(0, 512));
    c->add_option("--lens-pass", a->lens_pass,
                  "The late warp's pass: fused (the lens model per pixel, one full-screen "
                  "triangle per eye), mesh (the distortion mesh), or auto (fused unless the "
                  "start-up calibration measures the mesh at least 10 % faster)")
        ->check(CLI::IsMember({"auto", "fused", "mesh"}));
}

// Pacing: the cores kept awake, the pixel-cost ladder, the render rate, the simulated costs.
void add_pacing_options(CLI::App* c, const std::shared_ptr<ReplayArgs>& a) {
    c->add_option("--cpu-wake", a->cpu_wake,
                  "System clock: keep the cores awake while the node runs, so the renderer's "
                  "threads do not pay a core's wake-up inside a warp: qos (PM QoS, "
                  "/dev/cpu_dma_latency at 0 us; root), spin (an idle-class spinning thread per "
                  "core: takes no time from others, costs power), auto (qos where a cpuidle driver "
                  "is present, else spin) or off")
        ->check(CLI::IsMember({"auto", "qos", "spin", "off"}));
    c->add_flag("--no-ladder", a->no_ladder,
                "No pixel-cost ladder: full eye-buffer resolution and chromatic-aberration "
                "correction always (docs/latency.md)");
    c->add_option("--min-render-scale", a->opt.node.min_render_scale,
                  "The ladder's lowest eye-buffer resolution per axis (default 0.5)")
        ->check(CLI::Range(0.1, 1.0));
    c->add_option("--max-render-divisor", a->opt.node.pacing.max_divisor,
                  "The slowest render rate: new frames every N vsyncs at the least, re-warped "
                  "between (default 3; 1: a new frame for every vsync or none)")
        ->check(CLI::Range(1, 4));
    c->add_option("--frame-cost-ms", a->frame_cost_ms,
                  "Simulated clock: a fixed render cost per frame instead of the model calibrated "
                  "on the renderer at start-up")
        ->check(CLI::Range(0.0, 10000.0));
    c->add_option("--warp-cost-ms", a->warp_cost_ms,
                  "Simulated clock, with --frame-cost-ms: the warp pass's cost (default 0.5)")
        ->check(CLI::Range(0.0, 10000.0));
}

// The registration error's truth: where a trace starts, how far position error counts.
void add_registration_options(CLI::App* c, const std::shared_ptr<ReplayArgs>& a) {
    c->add_flag("--recentre", a->opt.recentre,
                "Move a 6DoF trace so that it starts at the default head position (traces whose "
                "positions start at the floor)");
    c->add_option("--registration-distance", a->opt.node.registration_distance_m,
                  "Distance (m) at which position error counts in the registration error")
        ->check(CLI::Range(0.01, 1000.0));
}

// The tracker backend and its inputs, checked against the clock (wiring.hpp's one vocabulary;
// --capture FILE is --tracker capture --from FILE). Reports a usage error and returns false when
// they do not go together.
bool wire_tracker(const ReplayArgs& a, ReplayOptions* o) {
    const std::string name =
        a.backend.empty() ? (a.capture.empty() ? "trace" : "capture") : a.backend;
    std::string deprecation;
    Result<TrackerBackend> b =
        parse_tracker_backend(name, WiringKeys::command_line(), &deprecation);
    if (!deprecation.empty()) errors.warning(deprecation);
    if (!b.ok() || (!a.capture.empty() && (*b != TrackerBackend::capture || !o->from.empty()))) {
        errors.usage(b.ok() ? "--capture FILE is --tracker capture --from FILE: give one"
                            : b.error().message);
        return false;
    }
    o->tracker_backend = *b;
    if (!a.capture.empty()) o->from = a.capture;
    if (o->tracker_backend == TrackerBackend::trace && o->trace.empty()) {
        errors.usage(std::string("give --trace FILE, or --capture FILE --device VID:PID, or "
                                 "another --tracker (") +
                     kTrackerBackendNames + ")");
        return false;
    }
    TrackerSpec spec;
    spec.backend = o->tracker_backend;
    spec.from = o->from;
    spec.trace_path = o->trace;
    spec.device = o->device;
    spec.start_s = o->start_s;
    if (Status st = check_tracker_spec(spec, a.clock == "sim" ? ClockKind::sim : ClockKind::real,
                                       WiringKeys::command_line());
        !st.ok()) {
        errors.usage(st.error().message);
        return false;
    }
    return true;
}

// The node, display and tracker settings from the options given as text or flags. Reports an
// unreadable headset profile (exit 1) or options that do not go together (exit 2) and returns
// false.
bool apply_node_settings(const ReplayArgs& a, ReplayOptions* o) {
    o->simulated_clock = a.clock == "sim";
    o->node.warp = !a.no_warp;
    o->node.lod_allocator = *parse_lod_allocator(a.allocator);  // checked by IsMember
    o->eye_tracker = *parse_eye_tracker_backend(a.eye_tracker, WiringKeys::command_line());
    o->node.distortion = !a.no_distortion;
    o->node.mesh_cols = o->node.mesh_rows = a.mesh;
    o->node.lens_pass = *parse_lens_pass_choice(a.lens_pass);  // checked by IsMember
    o->node.cpu_wake = *parse_cpu_wake(a.cpu_wake);            // checked by IsMember
    o->node.pixel_ladder = !a.no_ladder;
    if (!a.headset.empty()) {
        Result<HeadsetProfile> p = load_headset_profile(a.headset);
        if (!p.ok()) {
            errors.fail(p.error().message);
            return false;
        }
        o->node.headset = *p;
    }
    if (a.warp_cost_ms >= 0.0 && a.frame_cost_ms < 0.0) {
        errors.usage("--warp-cost-ms needs --frame-cost-ms");
        return false;
    }
    if (a.frame_cost_ms >= 0.0) {
        FrameCostModel m;
        m.base_ns = ms_to_ns(a.frame_cost_ms);
        m.per_triangle_ns = 0.0;
        m.warp_ns = ms_to_ns(a.warp_cost_ms >= 0.0 ? a.warp_cost_ms : 0.5);
        o->frame_cost = m;
    }
    o->display.frames_dir = a.frames_dir;
    o->display.persistence_ns = ms_to_ns(a.persistence_ms);
    if (Status st = check_persistence(o->display); !st.ok()) {
        errors.usage("--persistence-ms " + st.error().message);
        return false;
    }
    o->node.predict = !a.no_predict;
    o->tracker.latency_ns = int64_t(a.latency_us * 1000.0);
    o->tracker.jitter_ns = int64_t(a.jitter_us * 1000.0);
    return true;
}

// Progress on stderr, every 90th present.
void print_progress(const FrameRecord& f) {
    if (f.index % 90 != 0) return;
    char error[32] = "n/a";  // no truth (a capture)
    if (std::isfinite(f.registration_error_deg))
        std::snprintf(error, sizeof error, "%.2f deg", f.registration_error_deg);
    std::fprintf(stderr, "\rpresent %llu  latency %.1f ms  error %s   ",
                 (unsigned long long)f.index, f.latency_ms, error);
}

void run_replay_command(const ReplayArgs& a) {
    ReplayOptions o = a.opt;
    if (!wire_tracker(a, &o) || !apply_node_settings(a, &o)) return;
    if (!a.quiet) o.on_frame = print_progress;
    Result<ReplayResult> r = run_replay(o);
    if (!a.quiet) std::fprintf(stderr, "\r%60s\r", "");
    if (!r.ok()) return errors.fail(r.error().message);
    std::fputs(replay_summary_table(*r).c_str(), stdout);
    if (!o.report.empty()) std::printf("report: %s\n", o.report.c_str());
    if (!o.display.frames_dir.empty()) std::printf("frames: %s\n", o.display.frames_dir.c_str());
}

}  // namespace

void add_replay_command(CLI::App& app) {
    auto args = std::make_shared<ReplayArgs>();
    CLI::App* c = app.add_subcommand("replay",
                                     "Replay a head trace through tracking, LOD selection, "
                                     "stereo rendering and a mock headset; write a report");
    add_source_options(c, args);
    add_output_options(c, args);
    add_span_options(c, args);
    add_display_options(c, args);
    add_tracking_options(c, args);
    add_lod_options(c, args);
    add_warp_options(c, args);
    add_pacing_options(c, args);
    add_registration_options(c, args);
    c->add_flag("--quiet", args->quiet, "Print only the summary");

    // A later occurrence of an option wins, so scripts/demo's defaults can be overridden.
    for (CLI::Option* o : c->get_options())
        if (o->get_expected_max() == 1) o->multi_option_policy(CLI::MultiOptionPolicy::TakeLast);

    c->callback([args] { run_replay_command(*args); });
}

}  // namespace hmdnode::tool
