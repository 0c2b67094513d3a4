// hmdnoded's config file (JSON, docs/daemon.md). Unknown keys are errors, so a typo is never
// silently ignored.
#pragma once

#include <filesystem>

#include "hmdnode/core/result.hpp"
#include "hmdnode/firmware_host/node.hpp"
#include "hmdnode/hal/display/mock_display.hpp"
#include "hmdnode/hal/sim/sim_tracker.hpp"
#include "hmdnode/hal/transport.hpp"

namespace hmdnode {

struct DaemonConfig {
    std::filesystem::path scene;
    std::filesystem::path trace;  // tracker "sim": the trace it replays
    bool loop = true;             // restart the trace when it ends
    bool simulated_clock = false;
    int64_t max_frames = 0;
    SimTrackerConfig tracker;
    // "sim-trace" (SimTracker replaying `trace`), "hidapi", "libusb" (a real device through the
    // DeviceTracker) or "sim-device" (the simulated reference tracker through the DeviceTracker;
    // its motion is `trace` when given, else synthetic).
    std::string tracker_backend = "sim-trace";
    DeviceFilter tracker_device;  // "device": "VID:PID", "serial"
    MockDisplayConfig display;
    // "renderer": {"backend": "vulkan" | "gles"}; empty: HMDNODE_RENDERER, else "vulkan".
    std::string renderer_backend;
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
};

// Relative paths in the file are relative to the file's directory.
Result<DaemonConfig> load_daemon_config(const std::filesystem::path& path);

}  // namespace hmdnode
