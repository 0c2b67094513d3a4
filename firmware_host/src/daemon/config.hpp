// hmdnoded's config file (JSON, docs/daemon.md). Unknown keys are errors, so a typo is never
// silently ignored.
#pragma once

#include <filesystem>

#include "hmdnode/core/result.hpp"
#include "hmdnode/firmware_host/node.hpp"
#include "hmdnode/hal/mock_display.hpp"
#include "hmdnode/hal/sim_tracker.hpp"

namespace hmdnode {

struct DaemonConfig {
    std::filesystem::path scene;
    std::filesystem::path trace;  // tracker "sim": the trace it replays
    bool loop = true;             // restart the trace when it ends
    bool simulated_clock = false;
    int64_t max_frames = 0;
    SimTrackerConfig tracker;
    MockDisplayConfig display;
    NodeConfig node;
    std::filesystem::path status_path;  // empty: none
    double status_every_s = 5.0;
};

// Relative paths in the file are relative to the file's directory.
Result<DaemonConfig> load_daemon_config(const std::filesystem::path& path);

}  // namespace hmdnode
