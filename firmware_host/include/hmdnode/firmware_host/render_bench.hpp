// Render bench (the method of Li and Kim 2020, docs/references.md: LOD methods compared by render
// time and image quality): the frames of a trace replay rendered off-screen at the levels the node
// chose and, on request, at full detail from the same pose, timed per frame, with PSNR and SSIM of
// each LOD frame against its full-detail twin; a JSON report (docs/formats.md, "Render bench
// report") and an SVG plot.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "hmdnode/core/result.hpp"
#include "hmdnode/firmware_host/node.hpp"
#include "hmdnode/firmware_host/replay.hpp"

namespace hmdnode {

// Which levels the bench draws: the node's choice (its selector and allocator), every object's
// finest, or level N of every chain (its coarsest where the chain is shorter).
struct LodMode {
    enum Kind { automatic, full, fixed } kind = automatic;
    int level = 0;  // fixed
};
// "auto", "full" or "level=N" (N >= 0); the error names the text.
Result<LodMode> parse_lod_mode(const std::string& text);
std::string lod_mode_name(const LodMode& mode);

struct RenderBenchOptions {
    std::filesystem::path scene;
    std::filesystem::path trace;
    int64_t first_frame = 100;  // rendered frames [first_frame, end_frame) of the replay
    int64_t end_frame = 1100;
    int eye_width = 360, eye_height = 400;
    double refresh_hz = 90.0;
    LodMode lod;
    LodAllocator allocator = LodAllocator::threshold;
    double tolerance_px = 1.0;
    int msaa_samples = 1;              // 1 or 4: MSAA of both the LOD and the full-detail frames
    // The gaze that steers the replay's LOD: none (lens centre) or trace (the trace's gaze).
    EyeTrackerBackend eye_tracker = EyeTrackerBackend::none;
    bool compare_full = false;         // also render full detail from each pose, and compare
    std::filesystem::path images_dir;  // empty: no PNGs; else lod_NNNNN.png (+ full_NNNNN.png)
    int images_every = 1;
    std::filesystem::path report;  // JSON (required by the tool; optional here)
    std::filesystem::path plot;    // SVG
};

struct RenderBenchFrame {
    int64_t frame = 0;  // the replay's rendered-frame index
    int64_t vsync_ns = 0;
    uint64_t triangles = 0, full_triangles = 0;  // drawn, both eyes' frusta
    size_t culled = 0;
    double render_ms = 0.0;       // record + GPU of the LOD frame (no read-back)
    double full_render_ms = 0.0;  // of the full-detail frame (compare_full)
    double psnr_db = 0.0;         // LOD against full detail, both eyes (capped: kPsnrCapDb)
    double ssim = 0.0;            // mean of the two eyes' SSIM
};

struct RenderBenchSummary {
    size_t frames = 0;
    Percentiles render_ms, full_render_ms;
    double triangles_mean = 0.0, full_triangles_mean = 0.0;
    double time_ratio = 0.0;  // full p50 / LOD p50 (compare_full)
    double psnr_median = 0.0, psnr_min = 0.0, ssim_median = 0.0, ssim_min = 0.0;
    double load_start = 0.0, load_end = 0.0;  // 1-minute load average (/proc/loadavg)
};

struct RenderBenchResult {
    std::vector<RenderBenchFrame> frames;
    RenderBenchSummary summary;
    std::string gaze_source;  // of the replay's new frames (gaze_source_summary)
    size_t gaze_frames = 0;
    std::string device_name;
    int cpus = 0;
};

// Replays the trace on the simulated clock (no late warp, no lens distortion: the eye buffers are
// what is compared), then renders frames [first, end) again on a fresh renderer. Fails when the
// scene, trace or renderer fails, when the trace yields fewer frames than `first_frame + 1`, or an
// output cannot be written; writes the report and plot atomically.
Result<RenderBenchResult> run_render_bench(const RenderBenchOptions& options);

nlohmann::json render_bench_report_json(const RenderBenchOptions& options,
                                        const RenderBenchResult& result);
std::string render_bench_svg(const RenderBenchOptions& options, const RenderBenchResult& result);
std::string render_bench_table(const RenderBenchOptions& options, const RenderBenchResult& result);

}  // namespace hmdnode
