// Replay: a recorded trace through the simulated tracker, the node runtime, the Vulkan renderer and
// the mock headset display, on the simulated or the system clock; and its report.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "hmdnode/core/result.hpp"
#include "hmdnode/firmware_host/node.hpp"
#include "hmdnode/hal/mock_display.hpp"
#include "hmdnode/hal/sim_tracker.hpp"
#include "hmdnode/render/renderer.hpp"

namespace hmdnode {

struct ReplayOptions {
    std::filesystem::path scene;
    std::filesystem::path trace;
    std::filesystem::path capture;  // instead of trace: a usbmon capture (pcap[.gz]) ...
    std::string capture_device;     // ... and the "VID:PID" of its device to replay
    std::filesystem::path report;   // empty: no JSON report
    bool simulated_clock = true;
    double start_s = 0.0;      // offset into the trace (a capture: from its first report)
    double duration_s = 0.0;   // 0: to the end
    int64_t max_frames = 0;    // 0: no limit
    SimTrackerConfig tracker;  // host_start/start_offset/duration are filled in by replay
    MockDisplayConfig display;
    NodeConfig node;
    RendererConfig renderer;                           // eye size is taken from the display
    std::function<void(const FrameRecord&)> on_frame;  // progress (optional)
};

// NaN where there were no values (a capture's registration error: no truth).
struct Percentiles {
    double p50 = 0, p95 = 0, p99 = 0, max = 0;
};

struct ReplaySummary {
    size_t frames = 0;
    Percentiles latency_ms;
    Percentiles registration_error_deg;
    Percentiles render_ms;
    double on_time_rate = 0.0;
    double triangles_mean = 0.0;
    double replayed_s = 0.0;  // trace time covered
    double wall_s = 0.0;      // wall time the replay took
};

struct ReplayResult {
    std::vector<FrameRecord> frames;
    std::vector<std::string> object_names;
    ReplaySummary summary;
    std::string device_name;
    size_t trace_samples = 0;
};

Percentiles percentiles(std::vector<double> values);
// {"p50", "p95", "p99", "max"}, as the report and the daemon's status file write them (null for
// NaN).
nlohmann::json percentiles_json(const Percentiles& p);

// Runs the whole replay and, if options.report is set, writes the JSON report atomically. Fails
// (and writes no report) on a bad scene or trace, or a renderer/display error.
Result<ReplayResult> run_replay(const ReplayOptions& options);

// The JSON report (docs/report-format.md).
nlohmann::json replay_report_json(const ReplayOptions& options, const ReplayResult& result);
// A short table for people ("n/a" where a percentile is NaN).
std::string replay_summary_table(const ReplayResult& result);

}  // namespace hmdnode
