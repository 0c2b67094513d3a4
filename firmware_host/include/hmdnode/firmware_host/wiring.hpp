// The one wiring place (docs/daemon.md, "Backends"): one vocabulary of backend names, the same in
// the daemon's config keys and in the command-line flags of `hmdnode replay` and `hmdnode record`,
// turned into the clock, the tracker, the display and the renderer the node runs on. Every
// backend works wherever it makes sense: the daemon can replay a capture, a replay can drive a
// live device, a recording can come from any tracker backend. Errors name the key or flag that
// was wrong (WiringKeys: config keys for the daemon, flags for the tool). Cost: what the backends
// cost to open; nothing here runs per frame.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <string_view>

#include "hmdnode/core/result.hpp"
#include "hmdnode/core/time.hpp"
#include "hmdnode/core/trace.hpp"
#include "hmdnode/hal/display.hpp"
#include "hmdnode/hal/display/kms_display.hpp"
#include "hmdnode/hal/display/mock_display.hpp"
#include "hmdnode/hal/eye_tracker.hpp"
#include "hmdnode/hal/sim/sim_eye_tracker.hpp"
#include "hmdnode/hal/sim/sim_tracker.hpp"
#include "hmdnode/hal/tracker.hpp"
#include "hmdnode/hal/transport.hpp"
#include "hmdnode/render/renderer.hpp"

namespace hmdnode {

class DeviceTracker;

// Where the tracker's poses come from.
//   trace   : a recorded head trace (hmdnode CSV) replayed by the simulated tracker; the truth for
//             registration error
//   sim     : the simulated reference-protocol tracker through the device tracker (its motion is
//             the trace when one is given, else synthetic)
//   capture : a usbmon capture (pcap[.gz]) of a device through the device tracker
//   rec     : a libsurvive recording's IMU through the device tracker (Index codec)
//   hidapi, libusb : a live device through the device tracker
// Older spellings still accepted, with a deprecation warning: "sim-trace" (trace), "sim-device"
// (sim).
enum class TrackerBackend { trace, sim, capture, rec, hidapi, libusb };
inline constexpr const char* kTrackerBackendNames = "trace, sim, capture, rec, hidapi, libusb";
const char* tracker_backend_name(TrackerBackend backend);
// True for the backends that read a live device (the real clock only).
bool is_live_backend(TrackerBackend backend);
// True for the backends that read a file (`from`, or the trace): they can finish.
bool is_file_backend(TrackerBackend backend);

// The keys or flags errors name: the daemon's config keys, or a command's flags.
struct WiringKeys {
    std::string clock = "clock";
    std::string backend = "tracker.backend";
    std::string from = "tracker.from";
    std::string trace = "tracker.trace";
    std::string device = "tracker.device";
    std::string display = "display.type";
    std::string renderer = "renderer.backend";
    std::string start = "tracker.start_s";
    std::string eye_tracker = "eye_tracker.backend";
    std::string base_stations = "tracker.base_stations";
    std::string place_base_stations = "tracker.place_base_stations";
    static WiringKeys config() { return {}; }
    static WiringKeys command_line() {
        return {"--clock",
                "--tracker",
                "--from",
                "--trace",
                "--device",
                "--display",
                "--renderer",
                "--start",
                "--eye-tracker",
                "--base-stations",
                "--place-base-stations"};
    }
};

// A backend name (or an older spelling) to its backend. An older spelling sets *deprecation to a
// warning that names the new value and the key; an unknown name is an error naming the key and
// listing the names.
Result<TrackerBackend> parse_tracker_backend(std::string_view name, const WiringKeys& keys,
                                             std::string* deprecation = nullptr);

// "real" (the system's monotonic clock) or "sim" (a simulated clock that moves only when the node
// says so: deterministic, as fast as the machine renders).
enum class ClockKind { real, sim };
Result<ClockKind> parse_clock(std::string_view name, const WiringKeys& keys);
std::unique_ptr<Clock> make_clock(ClockKind kind, int64_t sim_start_ns = 0);

struct TrackerSpec {
    TrackerBackend backend = TrackerBackend::trace;
    std::filesystem::path from;          // capture: the pcap[.gz]; rec: the libsurvive recording
    std::shared_ptr<const Trace> trace;  // trace: the trace replayed; sim: its motion (optional)
    std::filesystem::path trace_path;    // for messages
    // capture, sim, hidapi, libusb: "VID:PID[:SERIAL]" (hex; sim: default 1209:0001);
    // rec: the recording's device name (T20, WM0, ...)
    std::string device;
    // rec, capture, hidapi, libusb: a stored base-station setup (JSON, docs/formats.md; its world
    // +z up, as libsurvive's): the recording's, the capture's or the live device's light through
    // the device tracker's light path, 6DoF (docs/tracking.md §12). A live device's light comes
    // from its other HID interface, merged with the IMU's (hal/transport/interface_group.hpp), and
    // its sensor model from the configuration read at the open.
    std::filesystem::path base_stations;
    // With base_stations: the base stations the setup lacks (all of them while the file does not
    // exist yet) are placed in the tracker from the device's first still stretch
    // (LightTrackingConfig::place), and save_placed_setup writes them back to the file: the first
    // start of a box places, the next ones reuse.
    bool place_base_stations = false;
    SimTrackerConfig sim;     // trace: rate, noise, latency, jitter (host_start/offset: filled in)
    double start_s = 0.0;     // trace, capture: start this far into the input
    double duration_s = 0.0;  // trace: replay this long (0: to the end)
    // Live and simulated devices: wraps the transport backend before the device tracker opens it
    // (`hmdnode record` tees the raw reports into its pcap). Null: none.
    std::function<std::unique_ptr<TransportBackend>(std::unique_ptr<TransportBackend>)>
        wrap_backend;
};

// Checks a spec against the clock before anything is opened (a usage check: files are opened by
// make_tracker): the inputs each backend needs are given, a live device is on the real clock, the
// device text parses. Errors name the key.
Status check_tracker_spec(const TrackerSpec& spec, ClockKind clock, const WiringKeys& keys);

struct WiredTracker {
    std::unique_ptr<Tracker> tracker;
    DeviceTracker* device = nullptr;  // the device tracker behind it (every backend but trace)
    std::string label;                // what it reads, for logs ("trace FILE", "28de:2000 via ...")
};

// Makes the tracker (not started) with its first sample due at the clock's now (a file backend:
// its first record arrives then).
Result<WiredTracker> make_tracker(const TrackerSpec& spec, Clock& clock, const WiringKeys& keys);

// With spec.place_base_stations: the device tracker's setup (DeviceLightStatus::setup) written to
// spec.base_stations (atomically) when it holds more base stations than *stored, the count the
// file held (0 for a file not there yet); *stored then its count. Nothing to write: OK. Errors
// name the file.
Status save_placed_setup(const TrackerSpec& spec, const DeviceTracker& tracker, size_t* stored);
// The number of base stations spec.base_stations holds (0 when it is missing and
// spec.place_base_stations: to be placed). An error for a bad file.
Result<size_t> stored_base_stations(const TrackerSpec& spec);

// Where the gaze comes from (docs/lod-selection.md, "Gaze"):
//   none  : no eye tracker; LOD eccentricity is measured from the lens centre
//   trace : the gaze columns of the head trace (tracker.trace / --trace), replayed by the
//           simulated eye tracker on the head tracker's timeline
enum class EyeTrackerBackend { none, trace };
inline constexpr const char* kEyeTrackerBackendNames = "none, trace";
const char* eye_tracker_backend_name(EyeTrackerBackend backend);
Result<EyeTrackerBackend> parse_eye_tracker_backend(std::string_view name, const WiringKeys& keys);

struct EyeTrackerSpec {
    EyeTrackerBackend backend = EyeTrackerBackend::none;
    std::shared_ptr<const Trace> trace;  // trace: the trace whose gaze columns are replayed
    std::filesystem::path trace_path;    // for messages
    double start_s = 0.0;                // as the head tracker's
    double duration_s = 0.0;
    int64_t latency_ns = SimEyeTrackerConfig{}.latency_ns;
};

// Makes the eye tracker (not started), its first sample at the clock's now, like make_tracker's
// trace: made at the same clock time, the two replay one timeline. Null for none. Errors name the
// key (a trace without gaze columns: the file).
Result<std::unique_ptr<EyeTracker>> make_eye_tracker(const EyeTrackerSpec& spec, Clock& clock,
                                                     const WiringKeys& keys);

// The display: "mock" (the mock headset display, hal/display/mock_display.hpp), "kms" (the
// headset's connector through KMS, hal/display/kms_display.hpp: its mode gives the eye size and
// refresh) or "vk-display" (a VK_KHR_display display, render/vk_display.hpp: chosen by
// display.connector, its mode by display.mode, presented through a FIFO swapchain with
// VK_KHR_present_wait where offered). One branch per type in make_display.
struct DisplaySpec {
    std::string type = "mock";
    MockDisplayConfig mock;  // the mock panel's size, rate and frames; persistence (all types)
    KmsDisplayConfig kms;    // kms: device, connector, mode; vk-display: connector names it
    // mock: made by make_display once the clock and the panel (its vsync epoch set) are known, the
    // watcher the display tells of every present (a simulated camera filming it: `hmdnode latency
    // --observer camera --camera sim`); it must outlive the display. Empty: mock.watcher as given.
    std::function<Result<PanelWatcher*>(Clock&, const MockDisplayConfig&)> mock_watcher;
};
inline constexpr const char* kDisplayTypeNames = "mock, kms, vk-display";
// One of kDisplayTypeNames.
bool is_display_type(std::string_view type);
Status check_display_spec(const DisplaySpec& spec, const WiringKeys& keys);
// Vsync epoch: the clock's now; a mock display's watcher from spec.mock_watcher where set.
Result<std::unique_ptr<Display>> make_display(const DisplaySpec& spec, Clock& clock,
                                              const WiringKeys& keys);

// The renderer: "vulkan" (lavapipe where no GPU is) or "gles" (OpenGL ES 3 on surfaceless EGL);
// empty: config.backend, else HMDNODE_RENDERER, else vulkan (render/renderer.hpp). The eye size is
// the display's.
struct RendererSpec {
    std::string type;
    RendererConfig config;
};
Result<std::unique_ptr<Renderer>> make_renderer(const RendererSpec& spec, const DisplayInfo& panel,
                                                const WiringKeys& keys);

// The renderer for a display made by make_display. On a KMS display (display.type "kms") with the
// gles backend: zero-copy scan-out ("GBM zero-copy"): the renderer runs on EGL's GBM platform on
// the display's DRM device (RendererConfig::scanout), its ring of buffer objects is attached to the
// display as framebuffers, and each present flips the buffer the warp just drew; *zero_copy is set
// then (the node need not read frames back). Otherwise as above (KMS with Vulkan: the
// "dumb-buffer copy"; dma-buf import of the Vulkan image is planned). Logs which path. The display
// must outlive the renderer's presents; the renderer keeps its own duplicate of the DRM file.
Result<std::unique_ptr<Renderer>> make_renderer(const RendererSpec& spec, Display& display,
                                                const WiringKeys& keys, bool* zero_copy = nullptr);

}  // namespace hmdnode
