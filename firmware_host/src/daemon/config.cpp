#include "daemon/config.hpp"

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <set>
#include <type_traits>

#include <nlohmann/json.hpp>

#include "hmdnode/core/atomic_file.hpp"
#include "hmdnode/firmware_host/replay.hpp"

namespace hmdnode {
namespace {

using nlohmann::json;

// Reads an optional member of the expected JSON type; records an error naming the key otherwise.
struct Reader {
    std::string file;
    std::string error;
    std::filesystem::path base;  // the file's directory: relative paths are relative to it

    std::filesystem::path resolve(const std::string& p) const {
        return p.empty() || p[0] == '/' ? std::filesystem::path(p) : base / p;
    }

    bool check_keys(const json& obj, const std::string& where,
                    const std::set<std::string>& allowed) {
        if (!obj.is_object()) {
            fail(where + " must be an object");
            return false;
        }
        for (const auto& [k, v] : obj.items())
            if (!allowed.count(k)) {
                fail("unknown key \"" + where + (where.empty() ? "" : ".") + k + "\"");
                return false;
            }
        return true;
    }
    void fail(const std::string& msg) {
        if (error.empty()) error = file + ": " + msg;
    }
    template <class T>
    void get(const json& obj, const char* key, T* out) {
        if (!obj.contains(key)) return;
        const json& v = obj.at(key);
        if constexpr (std::is_integral_v<T> && !std::is_same_v<T, bool>) {
            // note: nlohmann converts a float or an out-of-range integer with a bare cast
            // (undefined for 1e30); an integer field takes an integer that fits.
            const bool fits =
                v.is_number_unsigned()
                    ? v.get<uint64_t>() <= uint64_t(std::numeric_limits<T>::max())
                    : v.is_number_integer() &&
                          v.get<int64_t>() >= int64_t(std::numeric_limits<T>::min()) &&
                          (std::is_unsigned_v<T> ||
                           v.get<int64_t>() <= int64_t(std::numeric_limits<T>::max()));
            if (!fits) {
                fail(std::string("\"") + key + "\" must be an integer from " +
                     std::to_string(std::numeric_limits<T>::min()) + " to " +
                     std::to_string(std::numeric_limits<T>::max()));
                return;
            }
        }
        try {
            *out = v.get<T>();
        } catch (const json::exception&) {
            fail(std::string("\"") + key + "\" has the wrong type");
        }
    }
};

// The top level's own keys: the scene, the clock, max_frames, realtime_priority.
void read_top_level(Reader& r, const json& j, DaemonConfig& c) {
    std::string scene, clock = "real";
    r.get(j, "scene", &scene);
    r.get(j, "clock", &clock);
    r.get(j, "max_frames", &c.max_frames);
    r.get(j, "realtime_priority", &c.realtime_priority);
    if (c.realtime_priority < 0 || c.realtime_priority > 99)
        r.fail("\"realtime_priority\" must be between 0 (none) and 99");
    if (scene.empty()) r.fail("\"scene\" is required");
    c.scene = r.resolve(scene);
    if (Result<ClockKind> k = parse_clock(clock, WiringKeys::config()); !k.ok())
        r.fail(k.error().message);
    else
        c.simulated_clock = *k == ClockKind::sim;
}

// "tracker": the backend of the one vocabulary and what it reads.
void read_tracker(Reader& r, const json& j, DaemonConfig& c) {
    json t = j.value("tracker", json::object());
    if (r.check_keys(t, "tracker",
                     {"type", "backend", "from", "device", "serial", "trace", "loop", "start_s",
                      "resample_hz", "noise_deg", "latency_us", "jitter_us", "seed",
                      "base_stations", "place_base_stations"})) {
        std::string type, trace, backend, from, device, serial, base_stations;
        r.get(t, "backend", &backend);
        r.get(t, "from", &from);
        r.get(t, "base_stations", &base_stations);
        if (!base_stations.empty()) c.base_stations = r.resolve(base_stations);
        r.get(t, "place_base_stations", &c.place_base_stations);
        r.get(t, "device", &device);
        r.get(t, "serial", &serial);
        double latency_us = 1000.0, jitter_us = 0.0;
        r.get(t, "type", &type);
        r.get(t, "trace", &trace);
        r.get(t, "loop", &c.loop);
        r.get(t, "start_s", &c.start_s);
        r.get(t, "resample_hz", &c.tracker.resample_hz);
        r.get(t, "noise_deg", &c.tracker.noise_deg);
        r.get(t, "latency_us", &latency_us);
        r.get(t, "jitter_us", &jitter_us);
        r.get(t, "seed", &c.tracker.seed);
        // note: the older key "type": "sim" is the backend "trace" (the one vocabulary,
        // firmware_host/include/hmdnode/firmware_host/wiring.hpp).
        if (!type.empty()) {
            if (type != "sim")
                r.fail("tracker.type \"" + type +
                       "\" is not available (the key is deprecated: write tracker.backend, one "
                       "of " +
                       kTrackerBackendNames + ")");
            else if (backend.empty())
                c.warnings.push_back(
                    "tracker.type \"sim\" is deprecated: write tracker.backend \"trace\"");
        }
        std::string deprecation;
        Result<TrackerBackend> b = parse_tracker_backend(backend.empty() ? "trace" : backend,
                                                         WiringKeys::config(), &deprecation);
        if (!b.ok())
            r.fail(b.error().message);
        else
            c.tracker_backend = *b;
        if (!deprecation.empty()) c.warnings.push_back(deprecation);
        if (!from.empty()) c.from = r.resolve(from);
        // sim: the reference tracker's default ids; serial: the older key for the selector's
        c.device =
            device.empty() && c.tracker_backend == TrackerBackend::sim ? "1209:0001" : device;
        if (!serial.empty() && c.tracker_backend != TrackerBackend::rec) c.device += ":" + serial;
        if (c.tracker_backend != TrackerBackend::rec && !c.device.empty()) {
            if (Result<DeviceFilter> f = parse_vid_pid(std::string_view(c.device)); f.ok())
                c.tracker_device = *f;
        }
        if (!(c.start_s >= 0.0 && c.start_s <= 1e6))
            r.fail("tracker.start_s must be between 0 and 1e6 s");
        if (!trace.empty()) c.trace = r.resolve(trace);
        // note: checked before the conversion, which overflows (undefined) for absurd values.
        if (!(latency_us >= 0.0 && latency_us <= kMaxTrackerDelayUs && jitter_us >= 0.0 &&
              jitter_us <= kMaxTrackerDelayUs))
            r.fail("tracker.latency_us and tracker.jitter_us must be between 0 and " +
                   std::to_string(int(kMaxTrackerDelayUs)) + " (a second)");
        else {
            c.tracker.latency_ns = int64_t(latency_us * 1000.0);
            c.tracker.jitter_ns = int64_t(jitter_us * 1000.0);
        }
        if (!(c.tracker.resample_hz >= 0.0 && c.tracker.resample_hz <= kMaxResampleHz))
            r.fail("tracker.resample_hz must be between 0 (as recorded) and " +
                   std::to_string(int(kMaxResampleHz)) + " Hz");
        if (!(c.tracker.noise_deg >= 0.0 && c.tracker.noise_deg <= 180.0))
            r.fail("tracker.noise_deg must be between 0 and 180");
    }
}

// "display": the type; the mock's figures or the connector's mode; persistence, MSAA.
void read_display(Reader& r, const json& j, DaemonConfig& c) {
    json d = j.value("display", json::object());
    if (r.check_keys(d, "display",
                     {"type", "eye_width", "eye_height", "refresh_hz", "persistence_ms",
                      "frames_dir", "frames_every", "device", "connector", "mode", "msaa"})) {
        std::string& type = c.display_type;
        std::string frames_dir;
        double persistence_ms = 2.0;
        r.get(d, "type", &type);
        r.get(d, "eye_width", &c.display.eye_width);
        r.get(d, "eye_height", &c.display.eye_height);
        r.get(d, "refresh_hz", &c.display.refresh_hz);
        r.get(d, "persistence_ms", &persistence_ms);
        r.get(d, "frames_dir", &frames_dir);
        r.get(d, "frames_every", &c.display.frames_every);
        r.get(d, "device", &c.kms.device);
        r.get(d, "connector", &c.kms.connector);
        r.get(d, "mode", &c.kms.mode);
        r.get(d, "msaa", &c.msaa_samples);
        if (c.msaa_samples != 1 && c.msaa_samples != 4) r.fail("display.msaa must be 1 or 4");
        if (!is_display_type(type))
            r.fail("display.type \"" + type + "\" is not one of " + kDisplayTypeNames);
        if (type == "mock" &&
            (d.contains("device") || d.contains("connector") || d.contains("mode")))
            r.fail(
                "display.device, display.connector and display.mode are for display.type kms "
                "or vk-display, not mock");
        if (type != "mock" && (d.contains("eye_width") || d.contains("eye_height") ||
                               d.contains("refresh_hz") || d.contains("frames_dir")))
            r.fail(
                "display.eye_width, eye_height, refresh_hz and frames_dir are the mock's; "
                "display.type " +
                type + " takes them from display.mode");
        if (!c.kms.mode.empty())
            if (Result<KmsModeRequest> m = parse_kms_mode(c.kms.mode); !m.ok())
                r.fail("display.mode: " + m.error().message);
        if (!(persistence_ms >= 0.0 && persistence_ms <= 1000.0))
            r.fail("display.persistence_ms must be between 0 and 1000");
        else
            c.display.persistence_ns = c.kms.persistence_ns = ms_to_ns(persistence_ms);
        if (c.display.refresh_hz > 0.0)
            if (Status st = check_persistence(c.display); !st.ok())
                r.fail("display.persistence_ms " + st.error().message);
        if (!frames_dir.empty()) c.display.frames_dir = r.resolve(frames_dir);
    }
}

// "node": prediction, LOD, the warp and the lens, the pixel-cost ladder.
void read_node(Reader& r, const json& j, DaemonConfig& c) {
    json n = j.value("node", json::object());
    if (r.check_keys(
            n, "node",
            {"ipd_m", "predict", "prediction_ms", "lod_tolerance_px", "lod_bias", "head_height_m",
             "warp", "distortion", "headset", "mesh", "lod_allocator", "lod_fade_frames",
             "lens_pass", "pixel_ladder", "min_render_scale", "max_render_divisor", "cpu_wake"})) {
        std::string headset;
        std::string allocator = lod_allocator_name(c.node.lod_allocator);
        std::string lens_pass = lens_pass_choice_name(c.node.lens_pass);
        std::string cpu_wake = cpu_wake_name(c.node.cpu_wake);
        int mesh = c.node.mesh_cols;
        r.get(n, "ipd_m", &c.node.rig.ipd_m);
        r.get(n, "predict", &c.node.predict);
        r.get(n, "prediction_ms", &c.node.prediction_offset_ms);
        r.get(n, "lod_tolerance_px", &c.node.lod.tolerance_px);
        r.get(n, "lod_bias", &c.node.lod_bias);
        r.get(n, "head_height_m", &c.node.default_head_position.y);
        r.get(n, "warp", &c.node.warp);
        r.get(n, "distortion", &c.node.distortion);
        r.get(n, "headset", &headset);
        r.get(n, "mesh", &mesh);
        r.get(n, "lod_allocator", &allocator);
        r.get(n, "lod_fade_frames", &c.node.lod_fade_frames);
        r.get(n, "lens_pass", &lens_pass);
        r.get(n, "pixel_ladder", &c.node.pixel_ladder);
        r.get(n, "min_render_scale", &c.node.min_render_scale);
        r.get(n, "max_render_divisor", &c.node.pacing.max_divisor);
        r.get(n, "cpu_wake", &cpu_wake);
        if (std::optional<CpuWake> w = parse_cpu_wake(cpu_wake))
            c.node.cpu_wake = *w;
        else
            r.fail("node.cpu_wake \"" + cpu_wake + "\" is not auto, qos, spin or off");
        if (std::optional<LensPassChoice> p = parse_lens_pass_choice(lens_pass))
            c.node.lens_pass = *p;
        else
            r.fail("node.lens_pass \"" + lens_pass + "\" is not auto, fused or mesh");
        if (!(c.node.min_render_scale >= 0.1 && c.node.min_render_scale <= 1.0))
            r.fail("node.min_render_scale must be between 0.1 and 1");
        if (c.node.pacing.max_divisor < 1 || c.node.pacing.max_divisor > 4)
            r.fail("node.max_render_divisor must be between 1 (a new frame for every vsync) and 4");
        if (c.node.lod_fade_frames < 0 || c.node.lod_fade_frames > kMaxLodFadeFrames)
            r.fail("node.lod_fade_frames must be between 0 (off) and " +
                   std::to_string(kMaxLodFadeFrames));
        if (std::optional<LodAllocator> a = parse_lod_allocator(allocator))
            c.node.lod_allocator = *a;
        else
            r.fail("node.lod_allocator \"" + allocator + "\" is not threshold, greedy or iga");
        if (c.node.lod.tolerance_px < 0.0) r.fail("node.lod_tolerance_px must be >= 0");
        if (!(std::fabs(c.node.prediction_offset_ms) <= NodeRuntime::kMaxPredictionOffsetMs))
            r.fail("node.prediction_ms must be between -" +
                   std::to_string(int(NodeRuntime::kMaxPredictionOffsetMs)) + " and " +
                   std::to_string(int(NodeRuntime::kMaxPredictionOffsetMs)));
        if (!(std::fabs(c.node.lod_bias) <= NodeRuntime::kMaxLodBias))
            r.fail("node.lod_bias must be between -" +
                   std::to_string(int(NodeRuntime::kMaxLodBias)) + " and " +
                   std::to_string(int(NodeRuntime::kMaxLodBias)) +
                   " (the tolerance is scaled by 2^lod_bias)");
        if (mesh < 0 || mesh > 512) r.fail("node.mesh must be between 0 (automatic) and 512");
        c.node.mesh_cols = c.node.mesh_rows = mesh;
        if (!headset.empty()) {
            Result<HeadsetProfile> p = load_headset_profile(r.resolve(headset));
            if (!p.ok())
                r.fail("node.headset: " + p.error().message);
            else
                c.node.headset = *p;
        }
    }
}

// "renderer": the backend.
void read_renderer(Reader& r, const json& j, DaemonConfig& c) {
    json rend = j.value("renderer", json::object());
    if (r.check_keys(rend, "renderer", {"backend"})) {
        r.get(rend, "backend", &c.renderer_backend);
        if (c.renderer_backend != "vulkan" && c.renderer_backend != "gles" &&
            !c.renderer_backend.empty())
            r.fail("renderer.backend \"" + c.renderer_backend + "\" is not one of vulkan, gles");
    }
}

// "eye_tracker" (after "tracker": its trace backend needs tracker.trace).
void read_eye_tracker(Reader& r, const json& j, DaemonConfig& c) {
    json et = j.value("eye_tracker", json::object());
    if (r.check_keys(et, "eye_tracker", {"backend", "latency_us"})) {
        std::string backend = "none";
        double latency_us = double(c.eye_tracker_latency_ns) / 1e3;
        r.get(et, "backend", &backend);
        r.get(et, "latency_us", &latency_us);
        if (Result<EyeTrackerBackend> b = parse_eye_tracker_backend(backend, WiringKeys::config());
            !b.ok())
            r.fail(b.error().message);
        else
            c.eye_tracker = *b;
        if (!(latency_us >= 0.0 && latency_us <= 1e6))
            r.fail("eye_tracker.latency_us must be between 0 and 1e6");
        else
            c.eye_tracker_latency_ns = int64_t(latency_us * 1e3);
        if (c.eye_tracker == EyeTrackerBackend::trace && c.trace.empty())
            r.fail("eye_tracker.backend \"trace\" needs tracker.trace (a trace with gaze columns)");
    }
}

// "status": the status file and its window.
void read_status(Reader& r, const json& j, DaemonConfig& c) {
    json s = j.value("status", json::object());
    if (r.check_keys(s, "status", {"path", "every_s"})) {
        std::string sp;
        r.get(s, "path", &sp);
        r.get(s, "every_s", &c.status_every_s);
        if (!sp.empty()) c.status_path = r.resolve(sp);
        if (!(c.status_every_s > 0.0 && c.status_every_s <= 86400.0))
            r.fail("status.every_s must be > 0 and at most 86400 (a day)");
    }
}

// "control": the control socket (default: systemd's runtime directory).
void read_control(Reader& r, const json& j, DaemonConfig& c) {
    if (const char* rd = std::getenv("RUNTIME_DIRECTORY"); rd && *rd && !std::strchr(rd, ':'))
        c.control_path = std::filesystem::path(rd) / "control";
    json ctl = j.value("control", json::object());
    if (r.check_keys(ctl, "control", {"path"}) && ctl.contains("path")) {
        std::string cp;
        r.get(ctl, "path", &cp);
        c.control_path = cp.empty() ? std::filesystem::path() : r.resolve(cp);
    }
}

// What the backends need (the trace or file, the device, the clock), named by key; once the
// sections read cleanly.
void check_backends(Reader& r, const DaemonConfig& c) {
    TrackerSpec ts = tracker_spec(c, nullptr);
    if (Status st = check_tracker_spec(ts, c.simulated_clock ? ClockKind::sim : ClockKind::real,
                                       WiringKeys::config());
        !st.ok())
        r.fail(st.error().message);
    else if (Status ds = check_display_spec(display_spec(c), WiringKeys::config()); !ds.ok())
        r.fail(ds.error().message);
}

}  // namespace

Result<DaemonConfig> load_daemon_config(const std::filesystem::path& path) {
    Result<std::string> text = read_file(path);
    if (!text.ok()) return text.error();
    json j;
    try {
        j = json::parse(*text);
    } catch (const json::parse_error& e) {
        return make_error(path.string() + ": not valid JSON at byte " + std::to_string(e.byte) +
                          ": " + e.what());
    } catch (const json::exception& e) {  // note: a number too large for a double (1e999)
        return make_error(path.string() + ": not valid JSON: " + e.what());
    }
    Reader r{path.string(), "", path.parent_path()};
    DaemonConfig c;
    if (!r.check_keys(j, "",
                      {"scene", "clock", "max_frames", "tracker", "display", "node", "status",
                       "realtime_priority", "control", "renderer", "eye_tracker"}))
        return make_error(r.error);
    // One section after the other; the first error is kept (Reader::fail).
    read_top_level(r, j, c);
    read_tracker(r, j, c);
    read_display(r, j, c);
    read_node(r, j, c);
    read_renderer(r, j, c);
    read_eye_tracker(r, j, c);
    read_status(r, j, c);
    read_control(r, j, c);
    if (r.error.empty()) check_backends(r, c);
    if (!r.error.empty()) return make_error(r.error);
    return c;
}

TrackerSpec tracker_spec(const DaemonConfig& c, std::shared_ptr<const Trace> trace) {
    TrackerSpec s;
    s.backend = c.tracker_backend;
    s.from = c.from;
    s.trace = std::move(trace);
    s.trace_path = c.trace;
    s.device = c.device;
    s.base_stations = c.base_stations;
    s.place_base_stations = c.place_base_stations;
    s.sim = c.tracker;
    s.start_s = c.start_s;
    return s;
}

DisplaySpec display_spec(const DaemonConfig& c) {
    DisplaySpec s;
    s.type = c.display_type;
    s.mock = c.display;
    s.kms = c.kms;
    return s;
}

NodeSpec node_spec(const DaemonConfig& c, std::shared_ptr<const Trace> trace) {
    NodeSpec s;
    s.keys = WiringKeys::config();
    s.clock = c.simulated_clock ? ClockKind::sim : ClockKind::real;
    s.tracker = tracker_spec(c, trace);
    s.eye_tracker.backend = c.eye_tracker;
    s.eye_tracker.trace = std::move(trace);
    s.eye_tracker.trace_path = c.trace;
    s.eye_tracker.start_s = c.start_s;
    s.eye_tracker.latency_ns = c.eye_tracker_latency_ns;
    s.display = display_spec(c);
    s.renderer.type = c.renderer_backend;
    s.renderer.config.msaa_samples = c.msaa_samples;
    s.node = c.node;
    return s;
}

}  // namespace hmdnode
