// The one wiring place (wiring.hpp): backend names -> clock, tracker, display, renderer.
#include "hmdnode/firmware_host/wiring.hpp"

#include <filesystem>
#include <system_error>

#include "hmdnode/hal/sim/sim_reference_device.hpp"
#include "hmdnode/hal/tracking/device_tracker.hpp"
#include "hmdnode/hal/tracking/survive_recording.hpp"

namespace hmdnode {

const char* tracker_backend_name(TrackerBackend b) {
    switch (b) {
        case TrackerBackend::trace:
            return "trace";
        case TrackerBackend::sim:
            return "sim";
        case TrackerBackend::capture:
            return "capture";
        case TrackerBackend::rec:
            return "rec";
        case TrackerBackend::hidapi:
            return "hidapi";
        case TrackerBackend::libusb:
            return "libusb";
    }
    return "?";
}

bool is_live_backend(TrackerBackend b) {
    return b == TrackerBackend::hidapi || b == TrackerBackend::libusb;
}

bool is_file_backend(TrackerBackend b) {
    return b == TrackerBackend::trace || b == TrackerBackend::capture || b == TrackerBackend::rec;
}

Result<TrackerBackend> parse_tracker_backend(std::string_view name, const WiringKeys& keys,
                                             std::string* deprecation) {
    for (TrackerBackend b : {TrackerBackend::trace, TrackerBackend::sim, TrackerBackend::capture,
                             TrackerBackend::rec, TrackerBackend::hidapi, TrackerBackend::libusb})
        if (name == tracker_backend_name(b)) return b;
    // The older spellings (the daemon's config before the one vocabulary).
    const std::pair<std::string_view, TrackerBackend> old[] = {{"sim-trace", TrackerBackend::trace},
                                                               {"sim-device", TrackerBackend::sim}};
    for (const auto& [o, b] : old)
        if (name == o) {
            if (deprecation)
                *deprecation = keys.backend + " \"" + std::string(o) + "\" is deprecated: write " +
                               keys.backend + " \"" + tracker_backend_name(b) + "\"";
            return b;
        }
    return make_error(keys.backend + " \"" + std::string(name) + "\" is not one of " +
                      kTrackerBackendNames);
}

Result<ClockKind> parse_clock(std::string_view name, const WiringKeys& keys) {
    if (name == "real") return ClockKind::real;
    if (name == "sim") return ClockKind::sim;
    return make_error(keys.clock + " \"" + std::string(name) + "\" is not real or sim");
}

std::unique_ptr<Clock> make_clock(ClockKind kind, int64_t sim_start_ns) {
    if (kind == ClockKind::sim) return std::make_unique<SimulatedClock>(sim_start_ns);
    return std::make_unique<SystemClock>();
}

Status check_tracker_spec(const TrackerSpec& spec, ClockKind clock, const WiringKeys& keys) {
    const char* name = tracker_backend_name(spec.backend);
    switch (spec.backend) {
        case TrackerBackend::trace:
            if (!spec.trace && spec.trace_path.empty())
                return make_error(keys.trace + " is required for " + keys.backend + " trace");
            return {};
        case TrackerBackend::capture:
        case TrackerBackend::rec:
            if (spec.from.empty())
                return make_error(keys.from + " is required for " + keys.backend + " " + name +
                                  (spec.backend == TrackerBackend::capture
                                       ? " (a usbmon capture, .pcap or .pcap.gz)"
                                       : " (a libsurvive recording, .rec or .rec.gz)"));
            if (spec.device.empty())
                return make_error(keys.device + " is required for " + keys.backend + " " + name +
                                  (spec.backend == TrackerBackend::capture
                                       ? " (the VID:PID of the captured device)"
                                       : " (the recording's device name, e.g. T20)"));
            if (spec.start_s > 0.0 && clock != ClockKind::sim)
                return make_error("a start offset into a " + std::string(name) + " needs " +
                                  keys.clock + " sim");
            return {};
        case TrackerBackend::hidapi:
        case TrackerBackend::libusb:
            if (clock != ClockKind::real)
                return make_error(keys.backend + " " + name + " reads a live device: it needs " +
                                  keys.clock + " real");
            [[fallthrough]];
        case TrackerBackend::sim:
            if (spec.backend != TrackerBackend::sim || !spec.device.empty())
                if (Result<DeviceFilter> f = parse_vid_pid(std::string_view(spec.device)); !f.ok())
                    return make_error(keys.device + ": " + f.error().message + " (required for " +
                                      keys.backend + " " + name + ")");
            return {};
    }
    return {};
}

Result<WiredTracker> make_tracker(const TrackerSpec& spec, Clock& clock, const WiringKeys& keys) {
    if (Status st =
            check_tracker_spec(spec, clock.is_simulated() ? ClockKind::sim : ClockKind::real, keys);
        !st.ok())
        return st.error();
    if (spec.backend == TrackerBackend::capture || spec.backend == TrackerBackend::rec)
        if (std::error_code ec; !std::filesystem::is_regular_file(spec.from, ec))
            return make_error(keys.from + " " + spec.from.string() + ": no such file");
    const int64_t now = clock.now_ns();
    WiredTracker out;
    auto adopt = [&](Result<std::unique_ptr<DeviceTracker>> t) -> Result<WiredTracker> {
        if (!t.ok()) return t.error();
        out.device = t->get();
        out.tracker = std::move(*t);
        return std::move(out);
    };
    switch (spec.backend) {
        case TrackerBackend::trace: {
            SimTrackerConfig tc = spec.sim;
            tc.host_start_ns = now;
            tc.start_offset_ns = s_to_ns(spec.start_s);
            tc.duration_ns = s_to_ns(spec.duration_s);
            if (!spec.trace) return make_error(keys.trace + ": not loaded");
            Result<std::unique_ptr<Tracker>> t = create_sim_tracker(spec.trace, clock, tc);
            if (!t.ok()) return make_error(spec.trace_path.string() + ": " + t.error().message);
            out.tracker = std::move(*t);
            out.label = "trace " + spec.trace_path.string();
            return out;
        }
        case TrackerBackend::capture:
            // The report start_s after the capture's first one arrives now; the earlier ones at
            // once (decoded and fused, not shown), so the pose at the start is the live one.
            out.label = spec.device + " from capture " + spec.from.string();
            return adopt(
                create_capture_tracker(spec.from, spec.device, clock, now - s_to_ns(spec.start_s)));
        case TrackerBackend::rec: {
            Result<SurviveRecording> r = read_survive_recording(spec.from, spec.device);
            if (!r.ok()) return r.error();
            out.label = spec.device + " from libsurvive recording " + spec.from.string();
            return adopt(create_survive_tracker(
                std::make_shared<const SurviveRecording>(std::move(*r)), clock, now));
        }
        case TrackerBackend::sim:
        case TrackerBackend::hidapi:
        case TrackerBackend::libusb: {
            DeviceFilter filter;
            filter.vendor_id = refproto::kDevVendorId;
            filter.product_id = refproto::kDevProductId;
            if (!spec.device.empty()) filter = *parse_vid_pid(std::string_view(spec.device));
            std::unique_ptr<TransportBackend> backend;
            if (spec.backend == TrackerBackend::sim) {
                SimReferenceDeviceConfig sc;
                sc.vendor_id = filter.vendor_id;
                sc.product_id = filter.product_id;
                if (!filter.serial.empty()) sc.serial = filter.serial;
                backend = create_sim_reference_backend(
                    clock, sc,
                    spec.trace ? motion_from_trace(spec.trace, now) : sinusoidal_motion());
            } else {
                auto b = create_transport_backend(tracker_backend_name(spec.backend));
                if (!b.ok())
                    return make_error(keys.backend + " " + tracker_backend_name(spec.backend) +
                                      ": " + b.error().message);
                backend = std::move(*b);
            }
            if (spec.wrap_backend) backend = spec.wrap_backend(std::move(backend));
            out.label = format_vid_pid(filter.vendor_id, filter.product_id) + " via " +
                        tracker_backend_name(spec.backend);
            DeviceTrackerConfig tc;
            tc.filter = filter;
            return adopt(create_device_tracker(std::move(backend),
                                               make_codec_for(filter.vendor_id, filter.product_id),
                                               clock, tc));
        }
    }
    return make_error("unhandled tracker backend");
}

Status check_display_spec(const DisplaySpec& spec, const WiringKeys& keys) {
    if (spec.type != "mock")
        return make_error(keys.display + " \"" + spec.type +
                          "\" is not available (available: " + kDisplayTypeNames + ")");
    if (Status st = check_persistence(spec.mock); !st.ok())
        return make_error("display persistence " + st.error().message);
    return {};
}

Result<std::unique_ptr<Display>> make_display(const DisplaySpec& spec, Clock& clock,
                                              const WiringKeys& keys) {
    if (Status st = check_display_spec(spec, keys); !st.ok()) return st.error();
    // One branch per display type.
    if (spec.type == "mock") {
        MockDisplayConfig dc = spec.mock;
        dc.vsync_epoch_ns = clock.now_ns();
        return create_mock_display(clock, dc);
    }
    return make_error(keys.display + " \"" + spec.type + "\" is not available");
}

Result<std::unique_ptr<Renderer>> make_renderer(const RendererSpec& spec, const DisplayInfo& panel,
                                                const WiringKeys& keys) {
    if (spec.type != "vulkan")
        return make_error(keys.renderer + " \"" + spec.type +
                          "\" is not available (available: " + kRendererNames + ")");
    RendererConfig rc = spec.config;
    rc.eye_width = panel.eye_width;
    rc.eye_height = panel.eye_height;
    return create_vulkan_renderer(rc);
}

}  // namespace hmdnode
