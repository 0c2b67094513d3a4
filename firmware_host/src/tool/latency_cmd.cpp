// `hmdnode latency`: motion-to-photon latency and registration error of the node under a head
// motion (synthetic step flicks or sine sweep, or a recorded trace), with prediction and late warp
// each on and off, side by side; optionally a JSON report and an SVG of the distributions
// (docs/latency.md). Each mode is one full replay (run_replay): on the real clock it takes the
// duration in wall time, plus the scene upload; memory is one FrameRecord per present per mode.
// With --observer camera each mode's panel is filmed (observed_replay.hpp: the simulated camera
// over the mock display, or a V4L2 device) and the decoded marker's latency is reported per
// camera frame beside the node's figure; --calibrate-flash measures the camera's own delay.
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
#include "hmdnode/firmware_host/observed_replay.hpp"
#include "hmdnode/firmware_host/replay.hpp"
#include "hmdnode/hal/camera.hpp"
#include "hmdnode/hal/camera/panel_camera.hpp"
#include "hmdnode/render/renderer.hpp"
#include "tool/cli_errors.hpp"
#include "tool/commands.hpp"

namespace hmdnode::tool {
namespace {

namespace fs = std::filesystem;

constexpr const char* kBundledTrace = "data/traces/corbillon2018_user1.csv";
constexpr double kBundledTraceStart = 20.0;

// The camera observer's options (docs/latency.md, "The observer"), as given (empty: not given;
// the defaults are applied where they are parsed).
struct CameraArgs {
    std::string observer, camera, fps, exposure_ms, shutter, line_us, stamp, phase_ms, jitter_ms,
        delay_ms, size, format, cell_px, flashes;
    bool calibrate_flash = false;
};

// Options are read as text and checked here, so that every usage error exits 2 with a message
// naming the option (CLI11's own checks exit with codes of 100 and up).
struct LatencyArgs {
    std::string scene, profile = "step", trace, start, duration = "10", clock = "real";
    // Empty: not given (540, 600, 90 on the mock display; a real panel's mode sets them).
    std::string eye_width, eye_height, refresh, tracker_hz = "1000";
    // The display presented to (ReplayOptions::display_type) and, for a real panel, which.
    std::string display = "mock", display_device, display_connector, display_mode,
                display_persistence_ms;
    std::string mesh = "0";
    std::string modes = "all", report, plot, frame_cost_ms, warp_cost_ms;
    bool quiet = false;
    CameraArgs cam;
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
    if (a.scene.empty() && !a.cam.calibrate_flash) return "--scene is required";
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

// The display options, against the others: the first problem, or empty. A real panel (kms,
// vk-display) runs on the real clock, sets the size and rate by its mode, and is filmed by a
// camera device: the simulated camera films the mock display alone.
std::string check_display_words(const LatencyArgs& a) {
    const bool real = a.display != "mock";
    if (real && a.display != "kms" && a.display != "vk-display")
        return "--display \"" + a.display + "\": give mock, kms or vk-display";
    const std::pair<const char*, const std::string*> panel_options[] = {
        {"--display-device", &a.display_device},
        {"--display-connector", &a.display_connector},
        {"--display-mode", &a.display_mode},
        {"--display-persistence-ms", &a.display_persistence_ms}};
    for (const auto& [flag, value] : panel_options)
        if (!value->empty() && !real)
            return std::string(flag) + " goes with --display kms or vk-display";
    if (!real) return {};
    if (a.display == "vk-display" && !a.display_device.empty())
        return "--display-device goes with --display kms (vk-display picks its panel by "
               "--display-connector)";
    if (a.clock != "real") return "--display " + a.display + " is a real panel: give --clock real";
    const std::pair<const char*, const std::string*> mock_options[] = {
        {"--eye-width", &a.eye_width}, {"--eye-height", &a.eye_height}, {"--refresh", &a.refresh}};
    for (const auto& [flag, value] : mock_options)
        if (!value->empty())
            return std::string(flag) + ": with --display " + a.display +
                   " the panel's mode sets it (--display-mode WxH@HZ)";
    if (!a.cam.observer.empty() && (a.cam.camera.empty() || a.cam.camera == "sim"))
        return "--camera sim films the mock display only: give a camera device (--camera "
               "/dev/videoN) with --display " +
               a.display;
    return {};
}

// The numeric options, checked and parsed.
struct LatencyNumbers {
    double duration = 0, start = 0, eye_w = 0, eye_h = 0, refresh = 0, tracker_hz = 0;
    double frame_cost = -1, warp_cost = 0.5, mesh = 0;
    double display_persistence_ms = -1;  // -1: not given (the display's default)
};

std::string or_default(const std::string& given, const std::string& fallback) {
    return given.empty() ? fallback : given;
}

// Parses the numeric options into `n`: the first problem, or empty.
std::string parse_numbers(const LatencyArgs& a, LatencyNumbers* n) {
    std::string err;
    if (!parse_number("--duration", a.duration, 0.1, 3600, &n->duration, &err) ||
        (!a.start.empty() && !parse_number("--start", a.start, 0, 1e6, &n->start, &err)) ||
        !parse_number("--eye-width", or_default(a.eye_width, "540"), 1, 16384, &n->eye_w, &err) ||
        !parse_number("--eye-height", or_default(a.eye_height, "600"), 1, 16384, &n->eye_h, &err) ||
        !parse_number("--refresh", or_default(a.refresh, "90"), 1, 1000, &n->refresh, &err) ||
        (!a.display_persistence_ms.empty() &&
         !parse_number("--display-persistence-ms", a.display_persistence_ms, 0, 100,
                       &n->display_persistence_ms, &err)) ||
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

// The camera options given, by flag, in the order they are checked.
std::vector<std::pair<const char*, const std::string*>> camera_options_given(const CameraArgs& c) {
    std::vector<std::pair<const char*, const std::string*>> all = {
        {"--camera", &c.camera},
        {"--camera-fps", &c.fps},
        {"--camera-exposure-ms", &c.exposure_ms},
        {"--camera-shutter", &c.shutter},
        {"--camera-line-us", &c.line_us},
        {"--camera-stamp", &c.stamp},
        {"--camera-phase-ms", &c.phase_ms},
        {"--camera-jitter-ms", &c.jitter_ms},
        {"--camera-delay-ms", &c.delay_ms},
        {"--camera-size", &c.size},
        {"--camera-format", &c.format},
        {"--marker-cell-px", &c.cell_px},
        {"--flashes", &c.flashes}};
    std::vector<std::pair<const char*, const std::string*>> given;
    for (const auto& o : all)
        if (!o.second->empty()) given.push_back(o);
    return given;
}

// The camera options' words, each against the others and the clock: the first problem, or empty.
std::string check_camera_words(const LatencyArgs& a) {
    const CameraArgs& c = a.cam;
    const auto given = camera_options_given(c);
    if (c.observer.empty()) {
        if (c.calibrate_flash) return "--calibrate-flash goes with --observer camera";
        if (!given.empty())
            return std::string(given.front().first) + " goes with --observer camera";
        return {};
    }
    if (c.observer != "camera") return "--observer \"" + c.observer + "\": give camera";
    const bool sim = c.camera.empty() || c.camera == "sim";
    for (const auto& [flag, value] : given) {
        const std::string f = flag;
        const bool sim_only = f == "--camera-fps" || f == "--camera-shutter" ||
                              f == "--camera-line-us" || f == "--camera-stamp" ||
                              f == "--camera-phase-ms" || f == "--camera-jitter-ms" ||
                              f == "--camera-delay-ms";
        if (sim_only && !sim)
            return f + " is the simulated camera's (--camera sim); a device streams as it is set";
        if ((f == "--camera-size" || f == "--camera-format") && sim)
            return f + " goes with a camera device (--camera /dev/videoN)";
        if (f == "--flashes" && !c.calibrate_flash) return "--flashes goes with --calibrate-flash";
    }
    if (!sim && a.clock != "real")
        return "--camera " + c.camera + " films in real time: give --clock real";
    if (!c.shutter.empty() && c.shutter != "global" && c.shutter != "rolling")
        return "--camera-shutter \"" + c.shutter + "\": give global or rolling";
    if (!c.line_us.empty() && c.shutter != "rolling")
        return "--camera-line-us goes with --camera-shutter rolling";
    if (!c.stamp.empty() && c.stamp != "start" && c.stamp != "middle" && c.stamp != "end")
        return "--camera-stamp \"" + c.stamp + "\": give start, middle or end";
    if (!c.format.empty() && c.format != "yuyv" && c.format != "grey")
        return "--camera-format \"" + c.format + "\": give yuyv or grey";
    if (c.calibrate_flash && a.modes != "all")
        return "--calibrate-flash runs no modes: drop --modes";
    // A rolling shutter's first lit frame waits for its rows to line up with the scan-out: up to
    // a panel period late, which the flash's timing cannot tell from the camera's delay.
    if (c.calibrate_flash && c.shutter == "rolling")
        return "--calibrate-flash times a global shutter: drop --camera-shutter rolling";
    return {};
}

// What the observer runs with: the simulated camera's configuration or a device's, the marker.
struct ObserverSetup {
    bool on = false;
    bool sim = true;
    std::string device;
    PanelCameraConfig sim_camera;
    V4l2CameraConfig v4l2;
    int64_t exposure_ns = 0;  // a device's: 0 unless --camera-exposure-ms
    int cell_px = 4;
    int flashes = 12;
};

// "WxH" into w, h (each in [1, 16384]).
bool parse_size(const std::string& text, uint32_t* w, uint32_t* h) {
    unsigned a = 0, b = 0;
    char x = 0, tail = 0;
    if (std::sscanf(text.c_str(), "%u%c%u%c", &a, &x, &b, &tail) != 3 || x != 'x') return false;
    if (a < 1 || b < 1 || a > 16384 || b > 16384) return false;
    *w = a;
    *h = b;
    return true;
}

// The camera options' numbers into *o (defaults where not given): the first problem, or empty.
std::string parse_camera_numbers(const LatencyArgs& a, const LatencyNumbers& n, ObserverSetup* o) {
    const CameraArgs& c = a.cam;
    o->on = !c.observer.empty();
    if (!o->on) return {};
    o->sim = c.camera.empty() || c.camera == "sim";
    o->device = o->sim ? "sim" : c.camera;
    auto opt = [](const std::string& v, const char* def) {
        return v.empty() ? std::string(def) : v;
    };
    double fps = 0, exposure = 0, line = 0, phase = 0, jitter = 0, delay = 0, cell = 0, flashes = 0;
    std::string err;
    if (!parse_number("--camera-fps", opt(c.fps, "240"), 0.1, 10000, &fps, &err) ||
        !parse_number("--camera-exposure-ms", opt(c.exposure_ms, "1"), 0.001, 1000, &exposure,
                      &err) ||
        (!c.line_us.empty() && !parse_number("--camera-line-us", c.line_us, 0, 1e5, &line, &err)) ||
        !parse_number("--camera-phase-ms", opt(c.phase_ms, "0"), 0, 1e4, &phase, &err) ||
        !parse_number("--camera-jitter-ms", opt(c.jitter_ms, "0"), 0, 1e3, &jitter, &err) ||
        !parse_number("--camera-delay-ms", opt(c.delay_ms, "0"), 0, 1e4, &delay, &err) ||
        !parse_number("--marker-cell-px", opt(c.cell_px, "4"), 1, 64, &cell, &err) ||
        !parse_number("--flashes", opt(c.flashes, "12"), 1, 1000, &flashes, &err))
        return err;
    if (cell != std::floor(cell) || flashes != std::floor(flashes))
        return "--marker-cell-px and --flashes are whole numbers";
    o->cell_px = int(cell);
    o->flashes = int(flashes);
    const int side = latency_marker_size_px(o->cell_px);
    if (!c.calibrate_flash && (side > int(n.eye_w) || side + int(n.eye_h) / 10 > int(n.eye_h))) {
        char b[160];
        std::snprintf(b, sizeof b,
                      "--marker-cell-px %d: the marker (%d px) does not fit a %dx%d eye",
                      o->cell_px, side, int(n.eye_w), int(n.eye_h));
        return b;
    }
    PanelCameraConfig& p = o->sim_camera;
    p.fps = fps;
    p.exposure_ns = ms_to_ns(exposure);
    // A rolling shutter follows the scan-out unless told: a panel period over its rows.
    if (c.shutter == "rolling")
        p.line_time_ns =
            c.line_us.empty() ? std::llround(1e9 / n.refresh / n.eye_h) : std::llround(line * 1e3);
    p.timestamp = c.stamp == "start"    ? CameraTimestamp::exposure_start
                  : c.stamp == "middle" ? CameraTimestamp::exposure_middle
                                        : CameraTimestamp::exposure_end;
    p.phase_ns = ms_to_ns(phase);
    p.jitter_ns = ms_to_ns(jitter);
    p.stamp_delay_ns = ms_to_ns(delay);
    if (!o->sim) {
        o->v4l2.device = c.camera;
        if (!c.size.empty() && !parse_size(c.size, &o->v4l2.width, &o->v4l2.height))
            return "--camera-size \"" + c.size + "\": give WIDTHxHEIGHT, e.g. 640x480";
        o->v4l2.fourcc = c.format == "grey" ? kFourccGrey : kFourccYuyv;
        if (!c.exposure_ms.empty()) o->exposure_ns = ms_to_ns(exposure);
    }
    return {};
}

// The report's "observer": what filmed the panel.
nlohmann::json observer_options_json(const ObserverSetup& o) {
    if (!o.on) return nullptr;
    nlohmann::json j = {{"camera", o.device}, {"marker_cell_px", o.cell_px}};
    if (o.sim) {
        const PanelCameraConfig& p = o.sim_camera;
        j["fps"] = p.fps;
        j["exposure_ms"] = ns_to_ms(p.exposure_ns);
        j["shutter"] = p.line_time_ns > 0 ? "rolling" : "global";
        j["line_us"] = double(p.line_time_ns) * 1e-3;
        j["stamp"] = camera_timestamp_name(p.timestamp);
        j["phase_ms"] = ns_to_ms(p.phase_ns);
        j["jitter_ms"] = ns_to_ms(p.jitter_ns);
        j["untold_delay_ms"] = ns_to_ms(p.stamp_delay_ns);
    } else {
        j["size"] = {o.v4l2.width, o.v4l2.height};
        j["format"] = fourcc_to_string(o.v4l2.fourcc);
        j["exposure_ms"] = o.exposure_ns > 0 ? nlohmann::json(ns_to_ms(o.exposure_ns)) : nullptr;
    }
    return j;
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
    base.display_type = a.display;
    base.real_display.device = a.display_device;
    base.real_display.connector = a.display_connector;
    base.real_display.mode = a.display_mode;
    if (n.display_persistence_ms >= 0)
        base.real_display.persistence_ns = ms_to_ns(n.display_persistence_ms);
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

// The modes' runs, and what the last one used; with the observer, what the camera saw of each.
struct LatencyRuns {
    std::vector<LatencyModeResult> results;
    std::vector<ObservedReplay> observed;  // per mode, with the observer (its replay left empty)
    std::string renderer;
    int used_mesh = 0;
    DisplayInfo display;  // what the panel said of itself (the last mode's)
};

// One mode's replay: plain, filmed by the simulated camera, or watched by `device`.
Result<ReplayResult> run_mode(const ReplayOptions& o, const ObserverSetup& obs, Camera* device,
                              LatencyRuns* runs) {
    if (!obs.on) return run_replay(o);
    Result<ObservedReplay> r = device ? run_replay_observed(o, *device, obs.exposure_ns)
                                      : run_replay_filmed(o, obs.sim_camera);
    if (!r.ok()) return r.error();
    ReplayResult replay = std::move(r->replay);
    r->replay = ReplayResult{};
    runs->observed.push_back(std::move(r).value());
    return replay;
}

// One replay per mode, from `base` (a copy: the first mode's calibrated cost model goes to the
// others); the first that fails ends it with an error naming the mode.
Result<LatencyRuns> run_modes(const LatencyArgs& a, const std::vector<LatencyMode>& modes,
                              ReplayOptions base, const ObserverSetup& obs, Camera* device) {
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
        Result<ReplayResult> r = run_mode(o, obs, device, &runs);
        if (!r.ok()) return make_error("mode " + mode.name + ": " + r.error().message);
        runs.renderer = r->device_name;
        runs.display = r->display;
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
            {"display", a.display},
            {"eye_width", int(n.eye_w)},
            {"eye_height", int(n.eye_h)},
            {"refresh_hz", n.refresh},
            {"persistence_ms",
             ns_to_ms(base.display_type == "mock" ? base.display.persistence_ns
                                                  : base.real_display.persistence_ns)},
            {"tracker_hz", n.tracker_hz},
            {"tracker_latency_ms", ns_to_ms(base.tracker.latency_ns)},
            {"frame_cost_ms", n.frame_cost >= 0 ? nlohmann::json(n.frame_cost) : nlohmann::json()},
            {"warp_cost_ms", n.frame_cost >= 0 ? nlohmann::json(n.warp_cost) : nlohmann::json()},
            {"distortion",
             base.node.distortion ? nlohmann::json(base.node.headset.name) : nlohmann::json()},
            {"modes", mode_names}};
}

// The report, then the plot; if the plot cannot be written the report goes again. Reports a
// failure (exit 1) and returns false. With the observer each mode carries what the camera saw.
bool write_outputs(const LatencyArgs& a, const nlohmann::json& options, const LatencyRuns& runs,
                   const std::string& title, const std::string& subtitle) {
    if (!a.report.empty()) {
        nlohmann::json report = latency_report_json(options, runs.renderer, runs.results);
        for (size_t i = 0; i < runs.observed.size() && i < report["modes"].size(); ++i)
            report["modes"][i]["observer"] = observer_json(runs.observed[i]);
        const std::string text = report.dump(1) + "\n";
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

// The flash calibration (--calibrate-flash): the simulated camera over a mock display of the
// options' panel (on the options' clock), or the device over the mock display the node presents
// to; the table, and the calibration as the report.
void run_flash_calibration(const LatencyArgs& a, const ReplayOptions& base,
                           const ObserverSetup& obs, Camera* device) {
    std::unique_ptr<Clock> clock = make_clock(a.clock == "sim" ? ClockKind::sim : ClockKind::real);
    MockDisplayConfig dc = base.display;
    dc.vsync_epoch_ns = clock->now_ns();
    std::unique_ptr<PanelCamera> sim_camera;
    if (!device) {
        PanelCameraConfig c = obs.sim_camera;
        c.display = dc;
        c.phase_ns += dc.vsync_epoch_ns;
        Result<std::unique_ptr<PanelCamera>> made = create_panel_camera(*clock, c);
        if (!made.ok()) return errors.usage(made.error().message);
        sim_camera = std::move(*made);
        dc.watcher = sim_camera.get();
    }
    DisplaySpec spec;
    spec.type = base.display_type;
    spec.mock = dc;
    spec.kms = base.real_display;
    Result<std::unique_ptr<Display>> display =
        make_display(spec, *clock, WiringKeys::command_line());
    if (!display.ok()) {
        if (spec.type == "mock") return errors.usage(display.error().message);
        return errors.fail("--display " + spec.type + ": " + display.error().message +
                           "; nothing written");
    }
    const DisplayInfo panel = (*display)->info();
    FlashCalibrationOptions fo;
    fo.flashes = obs.flashes;
    Camera& camera = device ? *device : static_cast<Camera&>(*sim_camera);
    if (!a.quiet)
        std::fprintf(stderr, "hmdnode latency: flash calibration of camera %s, %d flashes...\n",
                     camera.name().c_str(), fo.flashes);
    Result<FlashCalibration> c =
        calibrate_camera_flash(*clock, **display, camera, fo, device ? obs.exposure_ns : 0);
    if (!c.ok()) return errors.fail(c.error().message + "; nothing written");
    std::printf(
        "hmdnode latency: flash calibration, camera %s, %dx%d per eye at %g Hz, %s clock\n%s",
        camera.name().c_str(), panel.eye_width, panel.eye_height, panel.refresh_hz, a.clock.c_str(),
        flash_calibration_table(*c).c_str());
    if (!a.report.empty()) {
        nlohmann::json j = flash_calibration_json(*c);
        j["camera"] = observer_options_json(obs);
        if (Status s = write_file_atomically(a.report, j.dump(1) + "\n"); !s.ok())
            return errors.fail(s.error().message + "; nothing written");
        std::printf("report: %s\n", a.report.c_str());
    }
}

// Per mode, what the camera saw: its frames, then the summary.
void print_observed(const LatencyRuns& runs) {
    for (size_t i = 0; i < runs.observed.size() && i < runs.results.size(); ++i) {
        const ObservedReplay& o = runs.observed[i];
        std::printf("\nobserver, mode %s, camera %s (%zu frames outside the run left out):\n%s%s",
                    runs.results[i].mode.name.c_str(), o.camera.c_str(), o.frames_outside,
                    observer_frames_table(o.observer).c_str(),
                    observer_summary_table(o.observer).c_str());
    }
}

void run_latency(const LatencyArgs& a, const std::vector<std::string>& extras) {
    if (std::string e = check_option_words(a, extras); !e.empty()) return errors.usage(e);
    if (std::string e = check_camera_words(a); !e.empty()) return errors.usage(e);
    if (std::string e = check_display_words(a); !e.empty()) return errors.usage(e);
    if (!errors.check_outputs({{"--report", a.report}, {"--plot", a.plot}})) return;
    LatencyNumbers n;
    if (std::string e = parse_numbers(a, &n); !e.empty()) return errors.usage(e);
    ObserverSetup obs;
    if (std::string e = parse_camera_numbers(a, n, &obs); !e.empty()) return errors.usage(e);
    Result<std::vector<LatencyMode>> modes = parse_latency_modes(a.modes);
    if (!modes.ok()) return errors.usage(modes.error().message);
    if (!a.report.empty() && !a.plot.empty() && fs::absolute(a.report) == fs::absolute(a.plot))
        return errors.usage("--report and --plot name the same file");
    if (a.cam.calibrate_flash && !a.plot.empty())
        return errors.usage("--plot goes with the modes' runs, not --calibrate-flash");
    // A device is opened before any work, so that a missing or busy one fails at once.
    std::unique_ptr<Camera> device;
    if (obs.on && !obs.sim) {
        Result<std::unique_ptr<Camera>> cam = open_v4l2_camera(obs.v4l2);
        if (!cam.ok()) return errors.fail("--camera: " + cam.error().message + "; nothing written");
        device = std::move(*cam);
    }

    Result<HeadMotion> motion = HeadMotion{};
    if (!a.cam.calibrate_flash) motion = load_head_motion(a, &n);
    if (!motion.ok()) return errors.fail(motion.error().message + "; nothing written");
    ReplayOptions base = base_replay_options(a, n, *motion);
    if (obs.on) base.node.latency_marker_cell_px = obs.cell_px;
    if (a.cam.calibrate_flash) return run_flash_calibration(a, base, obs, device.get());
    Result<LatencyRuns> runs = run_modes(a, *modes, base, obs, device.get());
    if (!runs.ok()) return errors.fail(runs.error().message + "; nothing written");

    if (a.display != "mock") {  // the panel's mode, not the options' defaults
        n.eye_w = runs->display.eye_width;
        n.eye_h = runs->display.eye_height;
        n.refresh = runs->display.refresh_hz;
    }
    const std::string title = latency_title(a, n, *motion, runs->used_mesh);
    const std::string subtitle = "renderer " + runs->renderer;
    std::printf("%s, %s\n%s", title.c_str(), subtitle.c_str(),
                latency_table(runs->results).c_str());
    print_observed(*runs);
    nlohmann::json options = report_options(a, n, base, *motion, *modes);
    options["observer"] = observer_options_json(obs);
    if (!write_outputs(a, options, *runs, title, subtitle)) return;
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
    c->add_option("--eye-width", args->eye_width,
                  "The mock display's pixels per eye (default 540)");
    c->add_option("--eye-height", args->eye_height,
                  "The mock display's pixels per eye (default 600)");
    c->add_option("--refresh", args->refresh, "The mock display's refresh rate (Hz, default 90)");
    c->add_option("--display", args->display,
                  "mock (the default: the simulated headset panel), or a real panel: kms (a DRM "
                  "connector, as hmdnoded drives it) or vk-display (VK_KHR_display); --clock real, "
                  "its mode sets the size and rate, and with --observer camera a camera device "
                  "films it")
        ->capture_default_str();
    c->add_option("--display-device", args->display_device,
                  "--display kms: the DRM device (/dev/dri/cardN; default: every card in turn)");
    c->add_option("--display-connector", args->display_connector,
                  "--display kms or vk-display: the connector (e.g. DP-1, edid:VLV:91A8, "
                  "non-desktop; default: the non-desktop one, else the only connected one)");
    c->add_option("--display-mode", args->display_mode,
                  "--display kms or vk-display: WxH@HZ (default: the connector's preferred mode; "
                  "the eye size is half its width)");
    c->add_option("--display-persistence-ms", args->display_persistence_ms,
                  "--display kms or vk-display: how long a row glows (the panel's; default 2)");
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
    CameraArgs& cam = args->cam;
    c->add_option("--observer", cam.observer,
                  "camera: watch the panel through a camera and decode the latency marker in each "
                  "frame: observed motion-to-photon beside the node's own figure");
    c->add_option("--camera", cam.camera,
                  "With --observer camera: sim (a simulated camera filming the mock display, the "
                  "default) or a V4L2 capture device (/dev/videoN, --clock real)");
    c->add_option("--camera-fps", cam.fps, "sim: frames per second (default 240)");
    c->add_option("--camera-exposure-ms", cam.exposure_ms,
                  "sim: the exposure (default 1); a device: the exposure it is set to, which V4L2 "
                  "does not report (default: unknown, taken as 0)");
    c->add_option("--camera-shutter", cam.shutter, "sim: global (default) or rolling");
    c->add_option("--camera-line-us", cam.line_us,
                  "sim, rolling: row-to-row delay (default: the panel's scan-out, a period over "
                  "its rows)");
    c->add_option("--camera-stamp", cam.stamp,
                  "sim: what a frame's stamp marks: start, middle or end (default) of exposure");
    c->add_option("--camera-phase-ms", cam.phase_ms,
                  "sim: the first frame's exposure start after the first vsync (default 0)");
    c->add_option("--camera-jitter-ms", cam.jitter_ms,
                  "sim: uniform jitter of each frame's start, +- this (default 0)");
    c->add_option("--camera-delay-ms", cam.delay_ms,
                  "sim: the camera's own stamp delay, which the observer is not told of (what "
                  "--calibrate-flash measures; default 0)");
    c->add_option("--camera-size", cam.size, "A device: WIDTHxHEIGHT to ask for (default 640x480)");
    c->add_option("--camera-format", cam.format, "A device: yuyv (default) or grey");
    c->add_option("--marker-cell-px", cam.cell_px,
                  "The latency marker's panel pixels per cell (default 4; a camera needs 6 of "
                  "its pixels per cell)");
    c->add_flag("--calibrate-flash", cam.calibrate_flash,
                "With --observer camera: no modes; flash the panel full-field at known vsyncs "
                "and measure the camera's own delay (--report: the calibration)");
    c->add_option("--flashes", cam.flashes, "--calibrate-flash: how many flashes (default 12)");
    c->allow_extras();
    for (CLI::Option* o : c->get_options())
        if (o->get_expected_max() == 1) o->multi_option_policy(CLI::MultiOptionPolicy::TakeLast);
    c->callback([args, c] { run_latency(*args, c->remaining()); });
}

const CommandRegistration reg{15, add_latency_command};

}  // namespace
}  // namespace hmdnode::tool
