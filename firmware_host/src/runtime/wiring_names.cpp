// The one wiring place (wiring.hpp), its first half: the backend names, the node's choice names
// (LOD allocator, lens pass) and the usage checks of the specs. Apart from the construction
// (wiring.cpp) so that the daemon's config reader links without the renderer
// (tests/fuzz/daemon_config_fuzz.cpp). Cost: string compares.
#include <string>

#include "hmdnode/firmware_host/wiring.hpp"

#include "hmdnode/firmware_host/node.hpp"

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

const char* eye_tracker_backend_name(EyeTrackerBackend b) {
    return b == EyeTrackerBackend::trace ? "trace" : "none";
}

Result<EyeTrackerBackend> parse_eye_tracker_backend(std::string_view name, const WiringKeys& keys) {
    for (EyeTrackerBackend b : {EyeTrackerBackend::none, EyeTrackerBackend::trace})
        if (name == eye_tracker_backend_name(b)) return b;
    return make_error(keys.eye_tracker + " \"" + std::string(name) + "\" is not one of " +
                      kEyeTrackerBackendNames);
}

Result<ClockKind> parse_clock(std::string_view name, const WiringKeys& keys) {
    if (name == "real") return ClockKind::real;
    if (name == "sim") return ClockKind::sim;
    return make_error(keys.clock + " \"" + std::string(name) + "\" is not real or sim");
}

Status check_tracker_spec(const TrackerSpec& spec, ClockKind clock, const WiringKeys& keys) {
    const char* name = tracker_backend_name(spec.backend);
    if (!spec.base_stations.empty() && spec.backend != TrackerBackend::rec &&
        spec.backend != TrackerBackend::capture && spec.backend != TrackerBackend::hidapi &&
        spec.backend != TrackerBackend::libusb)
        return make_error(keys.base_stations + " (a stored base-station setup) needs " +
                          keys.backend +
                          " hidapi, libusb, rec or capture (a device's, a recording's or a "
                          "capture's light), not " +
                          name);
    if (spec.place_base_stations && spec.base_stations.empty())
        return make_error(keys.place_base_stations + " needs " + keys.base_stations +
                          " FILE: the setup file the placed base stations are written to");
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
                return make_error(keys.start + " with " + keys.backend + " " + name + " needs " +
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

bool is_display_type(std::string_view type) {
    return type == "mock" || type == "kms" || type == "vk-display";
}

Status check_display_spec(const DisplaySpec& spec, const WiringKeys& keys) {
    if (!is_display_type(spec.type))
        return make_error(keys.display + " \"" + spec.type + "\" is not one of " +
                          kDisplayTypeNames);
    if (Status st = check_persistence(spec.mock); !st.ok())
        return make_error("display persistence " + st.error().message);
    return {};
}

// The LOD allocators' names (node.hpp): here, with the other names, so that the config's fuzz
// harness links without the frame loop.
const char* lens_pass_choice_name(LensPassChoice c) {
    switch (c) {
        case LensPassChoice::fused:
            return "fused";
        case LensPassChoice::mesh:
            return "mesh";
        case LensPassChoice::automatic:
            break;
    }
    return "auto";
}

std::optional<LensPassChoice> parse_lens_pass_choice(std::string_view name) {
    if (name == "auto") return LensPassChoice::automatic;
    if (name == "fused") return LensPassChoice::fused;
    if (name == "mesh") return LensPassChoice::mesh;
    return std::nullopt;
}

const char* lod_allocator_name(LodAllocator a) {
    switch (a) {
        case LodAllocator::greedy:
            return "greedy";
        case LodAllocator::iga:
            return "iga";
        case LodAllocator::threshold:
            break;
    }
    return "threshold";
}

std::optional<LodAllocator> parse_lod_allocator(std::string_view name) {
    if (name == "threshold") return LodAllocator::threshold;
    if (name == "greedy") return LodAllocator::greedy;
    if (name == "iga") return LodAllocator::iga;
    return std::nullopt;
}

// The cores-awake choice (cpu_wake.hpp): here beside the other names, so that the config reader
// links without the runtime.
const char* cpu_wake_name(CpuWake w) {
    switch (w) {
        case CpuWake::off:
            return "off";
        case CpuWake::automatic:
            return "auto";
        case CpuWake::qos:
            return "qos";
        case CpuWake::spin:
            return "spin";
    }
    return "off";
}

std::optional<CpuWake> parse_cpu_wake(std::string_view name) {
    for (CpuWake w : {CpuWake::off, CpuWake::automatic, CpuWake::qos, CpuWake::spin})
        if (name == cpu_wake_name(w)) return w;
    return std::nullopt;
}

}  // namespace hmdnode
