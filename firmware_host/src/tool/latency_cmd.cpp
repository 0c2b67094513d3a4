// `hmdnode latency`: motion-to-photon latency and registration error of the node under a head
// motion (synthetic step flicks or sine sweep, or a recorded trace), with prediction and late warp
// each on and off, side by side; optionally a JSON report and an SVG of the distributions
// (docs/latency.md). Each mode is one full replay (run_replay): on the real clock it takes the
// duration in wall time, plus the scene upload; memory is one FrameRecord per present per mode.
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <system_error>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "hmdnode/core/atomic_file.hpp"
#include "hmdnode/core/time.hpp"
#include "hmdnode/core/trace.hpp"
#include "hmdnode/firmware_host/latency_report.hpp"
#include "hmdnode/firmware_host/motion_profiles.hpp"
#include "hmdnode/firmware_host/replay.hpp"
#include "tool/cli_errors.hpp"
#include "tool/commands.hpp"

namespace hmdnode::tool {
namespace {

namespace fs = std::filesystem;

constexpr const char* kBundledTrace = "data/traces/corbillon2018_user1.csv";
constexpr double kBundledTraceStart = 20.0;

// Options are read as text and checked here, so that every usage error exits 2 with a message
// naming the option (CLI11's own checks exit with codes of 100 and up).
struct LatencyArgs {
    std::string scene, profile = "step", trace, start, duration = "10", clock = "real";
    std::string eye_width = "540", eye_height = "600", refresh = "90", tracker_hz = "1000";
    std::string mesh = "0";
    std::string modes = "all", report, plot, frame_cost_ms, warp_cost_ms;
    bool quiet = false;
};

const CliErrors errors{"latency"};

// A finite number in [lo, hi] from option `name`'s text, or an error message.
bool parse_number(const std::string& name, const std::string& text, double lo, double hi,
                  double* out, std::string* error) {
    char* end = nullptr;
    const double v = std::strtod(text.c_str(), &end);
    if (text.empty() || *end || !std::isfinite(v) || v < lo || v > hi) {
        char b[160];
        std::snprintf(b, sizeof b, "%s \"%s\": give a number in [%g, %g]", name.c_str(),
                      text.c_str(), lo, hi);
        *error = b;
        return false;
    }
    *out = v;
    return true;
}

// The bundled trace: from the working directory (the repository root), else beside the tool's
// build tree (build/<preset>/firmware_host/hmdnode -> the repository root).
fs::path find_bundled_trace() {
    if (fs::exists(kBundledTrace)) return kBundledTrace;
    std::error_code ec;
    fs::path dir = fs::read_symlink("/proc/self/exe", ec).parent_path();
    for (int i = 0; !ec && i < 5 && !dir.empty(); ++i, dir = dir.parent_path())
        if (fs::exists(dir / kBundledTrace)) return dir / kBundledTrace;
    return kBundledTrace;  // reported missing by the reader
}

// The options that are not numbers, each against the others: the first problem, or empty.
std::string check_option_words(const LatencyArgs& a, const std::vector<std::string>& extras) {
    if (!extras.empty()) return "unexpected argument \"" + extras.front() + "\"";
    if (a.scene.empty()) return "--scene is required";
    if (a.profile != "step" && a.profile != "sine-sweep" && a.profile != "trace")
        return "--profile \"" + a.profile + "\": give step, sine-sweep or trace";
    if (a.profile != "trace" && (!a.trace.empty() || !a.start.empty()))
        return "--trace and --start go with --profile trace";
    if (a.clock != "real" && a.clock != "sim")
        return "--clock \"" + a.clock + "\": give real or sim";
    if (!a.warp_cost_ms.empty() && a.frame_cost_ms.empty())
        return "--warp-cost-ms needs --frame-cost-ms";
    return {};
}

// The numeric options, checked and parsed.
struct LatencyNumbers {
    double duration = 0, start = 0, eye_w = 0, eye_h = 0, refresh = 0, tracker_hz = 0;
    double frame_cost = -1, warp_cost = 0.5, mesh = 0;
};

// Parses the numeric options into `n`: the first problem, or empty.
std::string parse_numbers(const LatencyArgs& a, LatencyNumbers* n) {
    std::string err;
    if (!parse_number("--duration", a.duration, 0.1, 3600, &n->duration, &err) ||
        (!a.start.empty() && !parse_number("--start", a.start, 0, 1e6, &n->start, &err)) ||
        !parse_number("--eye-width", a.eye_width, 1, 16384, &n->eye_w, &err) ||
        !parse_number("--eye-height", a.eye_height, 1, 16384, &n->eye_h, &err) ||
        !parse_number("--refresh", a.refresh, 1, 1000, &n->refresh, &err) ||
        !parse_number("--tracker-hz", a.tracker_hz, 0, 100000, &n->tracker_hz, &err) ||
        !parse_number("--mesh", a.mesh, 0, 512, &n->mesh, &err) ||
        (!a.frame_cost_ms.empty() &&
         !parse_number("--frame-cost-ms", a.frame_cost_ms, 0, 10000, &n->frame_cost, &err)) ||
        (!a.warp_cost_ms.empty() &&
         !parse_number("--warp-cost-ms", a.warp_cost_ms, 0, 10000, &n->warp_cost, &err)))
        return err;
    if (n->eye_w != std::floor(n->eye_w) || n->eye_h != std::floor(n->eye_h) ||
        n->mesh != std::floor(n->mesh))
        return "--eye-width, --eye-height and --mesh are whole numbers";
    if (n->frame_cost >= 0 && a.clock != "sim")
        return "--frame-cost-ms is the simulated clock's: give --clock sim";
    return {};
}

// The head motion, as a trace in memory, and its name in the table and report.
struct HeadMotion {
    std::shared_ptr<const Trace> trace;
    std::string name;
};

// A recorded trace (--profile trace: --trace, else the bundled one; n->start defaulted), or the
// synthetic profile over the duration.
Result<HeadMotion> load_head_motion(const LatencyArgs& a, LatencyNumbers* n) {
    if (a.profile != "trace") {
        Result<Trace> t = make_motion_profile(a.profile, n->duration);
        if (!t.ok()) return t.error();
        return HeadMotion{std::make_shared<const Trace>(std::move(t).value()), a.profile};
    }
    const fs::path path = a.trace.empty() ? find_bundled_trace() : fs::path(a.trace);
    if (a.start.empty()) n->start = a.trace.empty() ? kBundledTraceStart : 0.0;
    Result<Trace> t = read_trace_csv(path);
    if (!t.ok()) return t.error();
    const double length_s = ns_to_s(t->end_ns() - t->start_ns());
    if (t->samples.size() < 2 || n->start + 0.1 > length_s) {
        char b[64];
        std::snprintf(b, sizeof b, "%.1f", length_s);
        return make_error(path.string() + ": --start " + a.start + " leaves less than 0.1 s of a " +
                          b + " s trace");
    }
    return HeadMotion{std::make_shared<const Trace>(std::move(t).value()), path.string()};
}

// What every mode's replay shares.
ReplayOptions base_replay_options(const LatencyArgs& a, const LatencyNumbers& n,
                                  const HeadMotion& motion) {
    ReplayOptions base;
    base.scene = a.scene;
    base.trace_data = motion.trace;
    base.trace = motion.name;
    base.simulated_clock = a.clock == "sim";
    base.start_s = n.start;
    base.duration_s = n.duration;
    base.tracker.resample_hz = n.tracker_hz;
    base.display.eye_width = int(n.eye_w);
    base.display.eye_height = int(n.eye_h);
    base.display.refresh_hz = n.refresh;
    base.node.mesh_cols = base.node.mesh_rows = int(n.mesh);
    if (n.frame_cost >= 0) {
        FrameCostModel m;
        m.base_ns = ms_to_ns(n.frame_cost);
        m.per_triangle_ns = 0.0;
        m.warp_ns = ms_to_ns(n.warp_cost);
        base.frame_cost = m;
    }
    return base;
}

// The modes' runs, and what the last one used.
struct LatencyRuns {
    std::vector<LatencyModeResult> results;
    std::string renderer;
    int used_mesh = 0;
};

// One replay per mode, from `base` (a copy: the first mode's calibrated cost model goes to the
// others); the first that fails ends it with an error naming the mode.
Result<LatencyRuns> run_modes(const LatencyArgs& a, const std::vector<LatencyMode>& modes,
                              ReplayOptions base) {
    LatencyRuns runs;
    runs.used_mesh = base.node.mesh_cols;
    for (const LatencyMode& mode : modes) {
        ReplayOptions o = base;
        o.node.predict = mode.predict;
        o.node.warp = mode.warp;
        if (!a.quiet)
            std::fprintf(stderr,
                         "hmdnode latency: %s (prediction %s, warp %s): %.1f s on the %s "
                         "clock...\n",
                         mode.name.c_str(), mode.predict ? "on" : "off", mode.warp ? "on" : "off",
                         base.duration_s, a.clock.c_str());
        Result<ReplayResult> r = run_replay(o);
        if (!r.ok()) return make_error("mode " + mode.name + ": " + r.error().message);
        runs.renderer = r->device_name;
        runs.used_mesh = r->mesh_cols;
        // The simulated clock's cost model is calibrated once, by the first mode, and given to
        // the others: the modes then differ only in what they do, not in a noisy calibration.
        if (base.simulated_clock && !base.frame_cost) base.frame_cost = r->summary.frame_cost_model;
        LatencyModeResult m;
        m.mode = mode;
        m.summary = r->summary;
        m.period_ns = r->period_ns;
        m.on_time_vsyncs = m.summary.vsyncs - m.summary.missed_vsyncs;
        m.series = r->vsyncs;
        runs.results.push_back(std::move(m));
    }
    return runs;
}

// The table's (and the plot's) title line.
std::string latency_title(const LatencyArgs& a, const LatencyNumbers& n, const HeadMotion& motion,
                          int used_mesh) {
    char title[256];
    std::snprintf(title, sizeof title,
                  "hmdnode latency: %s, %.1f s, %dx%d per eye at %g Hz, mesh %d, tracker %g Hz, "
                  "%s clock",
                  a.profile == "trace" ? motion.name.c_str() : a.profile.c_str(), n.duration,
                  int(n.eye_w), int(n.eye_h), n.refresh, used_mesh, n.tracker_hz, a.clock.c_str());
    return title;
}

// The report's "options": what was run.
nlohmann::json report_options(const LatencyArgs& a, const LatencyNumbers& n,
                              const ReplayOptions& base, const HeadMotion& motion,
                              const std::vector<LatencyMode>& modes) {
    std::string mode_names;
    for (const LatencyMode& m : modes) mode_names += (mode_names.empty() ? "" : ",") + m.name;
    return {{"scene", a.scene},
            {"profile", a.profile},
            {"trace", a.profile == "trace" ? nlohmann::json(motion.name) : nlohmann::json()},
            {"start_s", n.start},
            {"duration_s", n.duration},
            {"clock", a.clock},
            {"eye_width", int(n.eye_w)},
            {"eye_height", int(n.eye_h)},
            {"refresh_hz", n.refresh},
            {"persistence_ms", ns_to_ms(base.display.persistence_ns)},
            {"tracker_hz", n.tracker_hz},
            {"tracker_latency_ms", ns_to_ms(base.tracker.latency_ns)},
            {"frame_cost_ms", n.frame_cost >= 0 ? nlohmann::json(n.frame_cost) : nlohmann::json()},
            {"warp_cost_ms", n.frame_cost >= 0 ? nlohmann::json(n.warp_cost) : nlohmann::json()},
            {"distortion",
             base.node.distortion ? nlohmann::json(base.node.headset.name) : nlohmann::json()},
            {"modes", mode_names}};
}

// The report, then the plot; if the plot cannot be written the report goes again. Reports a
// failure (exit 1) and returns false.
bool write_outputs(const LatencyArgs& a, const nlohmann::json& options, const LatencyRuns& runs,
                   const std::string& title, const std::string& subtitle) {
    if (!a.report.empty()) {
        const std::string text =
            latency_report_json(options, runs.renderer, runs.results).dump(1) + "\n";
        if (Status s = write_file_atomically(a.report, text); !s.ok()) {
            errors.fail(s.error().message + "; nothing written");
            return false;
        }
    }
    if (!a.plot.empty()) {
        if (Status s = write_file_atomically(a.plot, latency_svg(runs.results, title, subtitle));
            !s.ok()) {
            std::error_code ec;
            if (!a.report.empty()) fs::remove(a.report, ec);
            errors.fail(s.error().message + "; nothing written");
            return false;
        }
    }
    return true;
}

void run_latency(const LatencyArgs& a, const std::vector<std::string>& extras) {
    if (std::string e = check_option_words(a, extras); !e.empty()) return errors.usage(e);
    if (!errors.check_outputs({{"--report", a.report}, {"--plot", a.plot}})) return;
    LatencyNumbers n;
    if (std::string e = parse_numbers(a, &n); !e.empty()) return errors.usage(e);
    Result<std::vector<LatencyMode>> modes = parse_latency_modes(a.modes);
    if (!modes.ok()) return errors.usage(modes.error().message);
    if (!a.report.empty() && !a.plot.empty() && fs::absolute(a.report) == fs::absolute(a.plot))
        return errors.usage("--report and --plot name the same file");

    Result<HeadMotion> motion = load_head_motion(a, &n);
    if (!motion.ok()) return errors.fail(motion.error().message + "; nothing written");
    const ReplayOptions base = base_replay_options(a, n, *motion);
    Result<LatencyRuns> runs = run_modes(a, *modes, base);
    if (!runs.ok()) return errors.fail(runs.error().message + "; nothing written");

    const std::string title = latency_title(a, n, *motion, runs->used_mesh);
    const std::string subtitle = "renderer " + runs->renderer;
    std::printf("%s, %s\n%s", title.c_str(), subtitle.c_str(),
                latency_table(runs->results).c_str());
    if (!write_outputs(a, report_options(a, n, base, *motion, *modes), *runs, title, subtitle))
        return;
    if (!a.report.empty()) std::printf("report: %s\n", a.report.c_str());
    if (!a.plot.empty()) std::printf("plot: %s\n", a.plot.c_str());
}

void add_latency_command(CLI::App& app) {
    auto args = std::make_shared<LatencyArgs>();
    CLI::App* c = app.add_subcommand(
        "latency",
        "Measure motion-to-photon latency and registration error under a head motion, with "
        "prediction and late warp on and off, side by side");
    c->add_option("--scene", args->scene, "Scene (.glb/.gltf), required");
    c->add_option("--profile", args->profile,
                  "Head motion: step (30 deg flicks in 60 ms, 0.5 s holds), sine-sweep (20 deg, "
                  "0.2 -> 2 Hz), trace (a recorded trace)")
        ->capture_default_str();
    c->add_option("--trace", args->trace,
                  "With --profile trace: hmdnode trace CSV (default: the bundled "
                  "data/traces/corbillon2018_user1.csv from 20 s)");
    c->add_option("--start", args->start,
                  "With --profile trace: seconds into the trace (default 0; the bundled one: 20)");
    c->add_option("--duration", args->duration, "Seconds per mode")->capture_default_str();
    c->add_option("--clock", args->clock,
                  "real: the system clock (measured costs); sim: the deterministic simulated clock")
        ->capture_default_str();
    c->add_option("--eye-width", args->eye_width, "Pixels per eye")->capture_default_str();
    c->add_option("--eye-height", args->eye_height, "Pixels per eye")->capture_default_str();
    c->add_option("--refresh", args->refresh, "Display refresh rate (Hz)")->capture_default_str();
    c->add_option("--mesh", args->mesh,
                  "Distortion mesh cells per side (0: the coarsest within 0.5 px of the lens "
                  "model)")
        ->capture_default_str();
    c->add_option("--tracker-hz", args->tracker_hz,
                  "Tracker rate: the motion is resampled at this rate (0: as recorded)")
        ->capture_default_str();
    c->add_option("--modes", args->modes,
                  "all, or a comma-separated list of none, predict, warp, predict+warp")
        ->capture_default_str();
    c->add_option("--report", args->report, "JSON report (hmdnode-latency-report/1) to write");
    c->add_option("--plot", args->plot, "SVG of MTP histograms and error timelines to write");
    c->add_option("--frame-cost-ms", args->frame_cost_ms,
                  "--clock sim: a fixed render cost per frame instead of the calibrated model");
    c->add_option("--warp-cost-ms", args->warp_cost_ms,
                  "--clock sim, with --frame-cost-ms: the warp pass's cost (default 0.5)");
    c->add_flag("--quiet", args->quiet, "Print only the table");
    c->allow_extras();
    for (CLI::Option* o : c->get_options())
        if (o->get_expected_max() == 1) o->multi_option_policy(CLI::MultiOptionPolicy::TakeLast);
    c->callback([args, c] { run_latency(*args, c->remaining()); });
}

const CommandRegistration reg{15, add_latency_command};

}  // namespace
}  // namespace hmdnode::tool
