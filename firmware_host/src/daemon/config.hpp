// hmdnoded's config file (JSON, docs/daemon.md). Unknown keys are errors, so a typo is never
// silently ignored.
#pragma once

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "hmdnode/core/result.hpp"
#include "hmdnode/firmware_host/node.hpp"
#include "hmdnode/firmware_host/node_assembly.hpp"
#include "hmdnode/firmware_host/wiring.hpp"
#include "hmdnode/hal/display/kms_display.hpp"
#include "hmdnode/hal/display/mock_display.hpp"
#include "hmdnode/hal/sim/sim_tracker.hpp"
#include "hmdnode/hal/transport.hpp"

namespace hmdnode {

struct DaemonConfig {
    std::filesystem::path scene;
    std::filesystem::path trace;  // tracker "trace": the trace it replays ("sim": its motion)
    std::filesystem::path from;   // tracker "capture" / "rec": the file it reads
    double start_s = 0.0;         // tracker "trace" / "capture": start this far into it
    bool loop = true;             // restart a file backend (trace, capture, rec) when it ends
    bool simulated_clock = false;
    int64_t max_frames = 0;
    SimTrackerConfig tracker;
    // The backends of the one vocabulary (hmdnode/firmware_host/wiring.hpp): trace, sim,
    // capture, rec, hidapi, libusb ("sim-trace", "sim-device" and "type": "sim" are the older
    // spellings, accepted with a warning).
    TrackerBackend tracker_backend = TrackerBackend::trace;
    std::string device;           // "device" (+ ":" "serial"): VID:PID[:SERIAL], rec: its name
    DeviceFilter tracker_device;  // `device` parsed (not for rec)
    // "base_stations": a stored base-station setup (`hmdnode tracking place` writes one; relative
    // to the config file): 6DoF from a lighthouse device's light (hidapi, libusb, rec, capture).
    std::filesystem::path base_stations;
    // "place_base_stations": true: the base stations the setup lacks (all while the file does
    // not exist) are placed in the tracker from the device's first still stretch and written to
    // base_stations (wiring.hpp's TrackerSpec::place_base_stations): the first start places.
    bool place_base_stations = false;
    // "eye_tracker": {"backend": "none" | "trace", "latency_us": N}: the gaze that steers LOD
    // (trace: the gaze columns of tracker.trace, on the head tracker's timeline).
    EyeTrackerBackend eye_tracker = EyeTrackerBackend::none;
    int64_t eye_tracker_latency_ns = SimEyeTrackerConfig{}.latency_ns;
    // "display": {"type": "mock" | "kms" | "vk-display", ...} (docs/daemon.md). The mock's
    // figures are in `display`; kms and vk-display take theirs from the connector's mode.
    std::string display_type = "mock";
    MockDisplayConfig display;
    // "renderer": {"backend": "vulkan" | "gles"}; empty: HMDNODE_RENDERER, else "vulkan".
    std::string renderer_backend;
    KmsDisplayConfig kms;  // device, connector, mode (connector also names a vk-display display)
    int msaa_samples = 1;  // "display": {"msaa": 1 | 4}: samples per eye-buffer pixel
    NodeConfig node;
    std::filesystem::path status_path;  // empty: none
    double status_every_s = 5.0;
    // SCHED_FIFO priority of the frame loop's thread (1-99; 0: the default policy). Threads it
    // creates later start with the default policy (SCHED_RESET_ON_FORK); the renderer's worker
    // threads are created before it is raised.
    int realtime_priority = 0;
    // The control socket (docs/daemon.md): "control": {"path": ...}; absent: $RUNTIME_DIRECTORY/
    // control when systemd gives a runtime directory, else none; "" : none.
    std::filesystem::path control_path;
    // Deprecated spellings met while reading (the daemon logs them): each names the new key.
    std::vector<std::string> warnings;
};

// The wiring specs of a config (hmdnode/firmware_host/wiring.hpp); `trace` is the loaded trace.
TrackerSpec tracker_spec(const DaemonConfig& config, std::shared_ptr<const Trace> trace);
DisplaySpec display_spec(const DaemonConfig& config);
// The whole node's spec (hmdnode/firmware_host/node_assembly.hpp), named by the config's keys.
NodeSpec node_spec(const DaemonConfig& config, std::shared_ptr<const Trace> trace);

// Relative paths in the file are relative to the file's directory.
Result<DaemonConfig> load_daemon_config(const std::filesystem::path& path);

}  // namespace hmdnode
