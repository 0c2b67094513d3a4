// Replay: a recorded trace through the simulated tracker, the node runtime, the Vulkan renderer and
// the mock headset display, on the simulated or the system clock; and its report
// (docs/formats.md, "Replay report").
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "hmdnode/core/result.hpp"
#include "hmdnode/core/trace.hpp"
#include "hmdnode/firmware_host/node.hpp"
#include "hmdnode/firmware_host/wiring.hpp"
#include "hmdnode/hal/display/mock_display.hpp"
#include "hmdnode/hal/sim/sim_tracker.hpp"
#include "hmdnode/render/renderer.hpp"

namespace hmdnode {

struct ReplayOptions {
    std::filesystem::path scene;
    // Where the poses come from, in the one backend vocabulary (hmdnode/firmware_host/wiring.hpp):
    // trace (the default: `trace` replayed, and the truth for registration error), sim, capture,
    // rec, hidapi, libusb (no truth: registration error is n/a).
    TrackerBackend tracker_backend = TrackerBackend::trace;
    std::filesystem::path trace;              // trace: the CSV; sim: its motion (optional)
    std::shared_ptr<const Trace> trace_data;  // instead of trace: a trace in memory
    std::filesystem::path from;               // capture: the pcap[.gz]; rec: the recording
    std::filesystem::path base_stations;      // rec: a stored setup: 6DoF (wiring.hpp)
    std::string device;  // capture/sim/hidapi/libusb: "VID:PID[:SERIAL]"; rec: its device name
    // The gaze that steers LOD: none (the lens centre) or trace (the trace's gaze columns).
    EyeTrackerBackend eye_tracker = EyeTrackerBackend::none;
    std::filesystem::path report;  // empty: no JSON report
    bool simulated_clock = true;
    double start_s = 0.0;      // offset into the trace (a capture: from its first report)
    double duration_s = 0.0;   // 0: to the end
    int64_t max_frames = 0;    // 0: no limit
    SimTrackerConfig tracker;  // host_start/start_offset/duration are filled in by replay
    MockDisplayConfig display;
    // The display presented to: "mock" (the default: `display` above), or a real panel, "kms" or
    // "vk-display", as `real_display` names it (wiring.hpp's DisplaySpec): the real clock only,
    // the panel's size and rate its mode's (`display`'s persistence and frame dumps unused), and
    // no display_watcher (a simulated camera films the mock display alone).
    std::string display_type = "mock";
    KmsDisplayConfig real_display;
    NodeConfig node;
    RendererConfig renderer;  // eye size is taken from the display
    // The simulated clock's frame cost: empty = calibrated on the renderer at start-up.
    std::optional<FrameCostModel> frame_cost;
    // Move a 6DoF trace so that its first position is the node's default head position.
    bool recentre = false;
    std::function<void(const FrameRecord&)> on_frame;  // progress (optional)
    // The mock display's watcher, made when the node's clock and panel are (DisplaySpec::
    // mock_watcher: a simulated camera filming the panel); the panel image is then read back at
    // every present.
    std::function<Result<PanelWatcher*>(Clock&, const MockDisplayConfig&)> display_watcher;
};

// NaN where there were no values (a capture's registration error: no truth).
struct Percentiles {
    double p50 = 0, p95 = 0, p99 = 0, max = 0;
};

// Counted per vsync (docs/formats.md): every vsync from the first present's to the last one's
// either showed a new or re-warped frame on time, or it is missed (nothing new, or a late frame).
// Latency and registration error are per displayed vsync: a vsync that repeats a frame shows it
// older, against the head where it is now.
struct ReplaySummary {
    size_t frames = 0;      // presents (new frames + re-warps)
    size_t new_frames = 0;  // rendered frames presented
    size_t rewarps = 0;     // re-warps of a previous frame
    size_t vsyncs = 0;
    size_t missed_vsyncs = 0;
    size_t late_frames = 0;       // new frames shown after the vsync they were rendered for
    size_t longest_late_run = 0;  // consecutive vsyncs missed, at most
    double new_frames_per_vsync = 0.0;
    Percentiles latency_ms;
    Percentiles registration_error_deg;
    Percentiles render_ms;
    Percentiles warp_ms;
    double on_time_rate = 0.0;    // vsyncs that showed a new or re-warped frame on time / vsyncs
    double triangles_mean = 0.0;  // per new frame
    // LOD level changes (docs/lod-selection.md, "No pops"): pops (a visible change without a
    // cross-fade), cross-fades begun, new frames that drew some object at two levels, and pops
    // per minute of the presents' span (NaN for a run shorter than a frame).
    size_t lod_pops = 0;
    size_t lod_transitions = 0;
    size_t lod_fading_frames = 0;
    double lod_pops_per_min = std::numeric_limits<double>::quiet_NaN();
    // New frames whose LOD eccentricity came from the eye tracker's gaze (the rest: the lens
    // centre); gaze_source_summary names the mix.
    size_t gaze_frames = 0;
    std::optional<FrameCostModel> frame_cost_model;  // simulated clock: the model used
    bool frame_cost_calibrated = false;
    // The render cost the node learned for LOD over the run (FrameCostFit), when it rendered.
    struct LearnedCost {
        double base_ms = 0.0, per_triangle_ms = 0.0;
    };
    std::optional<LearnedCost> lod_cost_fit;
    double replayed_s = 0.0;  // trace time covered
    double wall_s = 0.0;      // wall time the replay took
    // The lens pass and the pixel-cost ladder (docs/latency.md): the pass in use ("fused",
    // "mesh"; "" without one), what the start-up calibration measured of the passes (NaN where
    // none ran), per ladder step the new frames rendered at it and the presents that showed them,
    // the presents per render rate (index d - 1: new frames every d vsyncs), and the
    // motion-to-photon floor: photon offset + latch + the pass's p99 + the tracker's latency.
    std::string lens_pass;
    NodeRuntime::PassTimes pass_times;
    std::string cpu_wake = "off";  // what kept the cores awake (cpu_wake.hpp)
    struct LadderShare {
        std::string name;
        double scale = 1.0;
        bool chromatic = true;
        size_t new_frames = 0, presents = 0;
    };
    std::vector<LadderShare> ladder;
    std::vector<size_t> presents_by_divisor;
    double mtp_floor_ms = std::numeric_limits<double>::quiet_NaN();
};

enum class VsyncShown {
    new_frame,  // a new frame presented for this vsync
    rewarp,     // the previous frame re-warped for it
    repeat,     // nothing presented for it: the panel shows the last frame again (a missed vsync)
};

// What one vsync showed: every vsync from the first present's to the last one's, the frame on
// screen being the last one shown at or before it.
struct VsyncSample {
    int64_t vsync_ns = 0;
    VsyncShown shown = VsyncShown::repeat;
    bool on_time = false;     // a new or re-warped frame shown at the vsync it aimed at
    bool late = false;        // a new frame shown after the vsync it was rendered for
    double latency_ms = 0.0;  // mid-persistence photons of the panel centre - pose sample
    double registration_error_deg = 0.0;  // NaN: no truth at that time
};

// The per-vsync series of a run's presents (period and truth as in the run; a null truth gives
// NaN registration error at repeated vsyncs). The presents are the frame loop's: one per vsync,
// in vsync order.
std::vector<VsyncSample> vsync_series(const std::vector<FrameRecord>& frames, int64_t period_ns,
                                      const TruthFn& truth, double registration_distance_m);

struct ReplayResult {
    std::vector<FrameRecord> frames;
    std::vector<VsyncSample> vsyncs;  // vsync_series of the frames against the trace
    int64_t period_ns = 0;            // of the display
    DisplayInfo display;              // what the display said of itself
    std::vector<std::string> object_names;
    ReplaySummary summary;
    std::string device_name;
    std::string renderer_backend;  // "vulkan" or "gles"
    size_t trace_samples = 0;
    int mesh_cols = 0, mesh_rows = 0;  // the distortion mesh in use
    LodAllocator lod_allocator = LodAllocator::threshold;
    int msaa_samples = 1;  // of the renderer's eye buffers
};

// Nearest rank (core/percentile.hpp); NaN values are left out.
Percentiles percentiles(std::vector<double> values);
// {"p50", "p95", "p99", "max"}, as the report and the daemon's status file write them (null for
// NaN).
nlohmann::json percentiles_json(const Percentiles& p);

// The highest rate the simulated tracker resamples a trace at (Hz): the resampled trace is made
// up front, so an absurd rate would exhaust memory; 4 kHz is twice the fastest IMU report rate
// of the devices in docs/hardware.md.
inline constexpr double kMaxResampleHz = 4000.0;
// The largest simulated transport latency or jitter (us): a second. Larger values mean nothing for
// a head tracker, and converting absurd ones to nanoseconds would overflow.
inline constexpr double kMaxTrackerDelayUs = 1e6;

// The options' values checked before any work (run_replay's first step): the report path can be
// written (core's check_output_file), the persistence fits the period, the tracker's rate, noise,
// latency and jitter and the LOD tolerance are finite and in range. The error names the field.
Status check_replay_options(const ReplayOptions& options);

// Runs the whole replay and, if options.report is set, writes the JSON report atomically. Fails
// (and writes no report) on a bad scene or trace, or a renderer/display error.
Result<ReplayResult> run_replay(const ReplayOptions& options);

// The per-vsync summary of a run's presents (period and truth as in the run; truth may be null).
ReplaySummary summarize_presents(const std::vector<FrameRecord>& frames, int64_t period_ns,
                                 const TruthFn& truth, double registration_distance_m);
// The same from a series vsync_series made of the frames.
ReplaySummary summarize_vsyncs(const std::vector<FrameRecord>& frames,
                               const std::vector<VsyncSample>& vsyncs);

// The report's `summary` object (docs/formats.md).
// "eye_tracker" (every new frame's LOD eccentricity from the gaze), "lens_centre" (none), "mixed".
const char* gaze_source_summary(const ReplaySummary& s);
nlohmann::json replay_summary_json(const ReplaySummary& summary);
// Two lines for people: the lens pass with its start-up times and the motion-to-photon floor, the
// ladder's steps and the render rates with their shares of the presents ("" without a pass).
std::string lens_pass_summary(const ReplaySummary& summary);
// The JSON report (docs/formats.md).
nlohmann::json replay_report_json(const ReplayOptions& options, const ReplayResult& result);
// A short table for people ("n/a" where a percentile is NaN).
std::string replay_summary_table(const ReplayResult& result);

}  // namespace hmdnode
