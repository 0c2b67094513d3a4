// Replay: scene + trace (or capture) -> the node assembled in the one assembly place
// (node_assembly.hpp: tracker -> node runtime -> renderer -> mock display), then the per-vsync
// summary and the report. run_replay's steps, one function each: the trace (replay_trace), the
// node's spec (replay_node_spec), the simulated clock's frame cost (replay_frame_cost), the truth
// for registration error (replay_truth), the frames (replay_frames), the summary
// (summarize_replay).
#include "hmdnode/firmware_host/replay.hpp"

#include <algorithm>
#include <cassert>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <sstream>

#include <nlohmann/json.hpp>

#include "hmdnode/core/atomic_file.hpp"
#include "hmdnode/core/gltf.hpp"
#include "hmdnode/core/percentile.hpp"
#include "hmdnode/core/trace.hpp"
#include "hmdnode/firmware_host/node_assembly.hpp"

namespace hmdnode {

Percentiles percentiles(std::vector<double> v) {
    v.erase(std::remove_if(v.begin(), v.end(), [](double x) { return std::isnan(x); }), v.end());
    Percentiles p;
    if (v.empty()) {  // no values (a capture has no truth): NaN, written as null / "n/a"
        p.p50 = p.p95 = p.p99 = p.max = std::numeric_limits<double>::quiet_NaN();
        return p;
    }
    std::sort(v.begin(), v.end());
    p.p50 = percentile_sorted(v, 0.50);
    p.p95 = percentile_sorted(v, 0.95);
    p.p99 = percentile_sorted(v, 0.99);
    p.max = v.back();
    return p;
}

namespace {
nlohmann::json finite_or_null(double v) {
    return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json();
}
}  // namespace

nlohmann::json percentiles_json(const Percentiles& p) {
    return {{"p50", finite_or_null(p.p50)},
            {"p95", finite_or_null(p.p95)},
            {"p99", finite_or_null(p.p99)},
            {"max", finite_or_null(p.max)}};
}

std::vector<VsyncSample> vsync_series(const std::vector<FrameRecord>& frames, int64_t period_ns,
                                      const TruthFn& truth, double registration_distance_m) {
    std::vector<VsyncSample> out;
    if (frames.empty() || period_ns <= 0) return out;
    // A display shows one frame per vsync, in order (Display::present).
    assert(std::adjacent_find(frames.begin(), frames.end(),
                              [](const FrameRecord& a, const FrameRecord& b) {
                                  return b.vsync_ns <= a.vsync_ns;
                              }) == frames.end());
    const int64_t first = frames.front().vsync_ns, last = frames.back().vsync_ns;
    out.reserve(size_t((last - first) / period_ns + 2));
    size_t k = 0;
    for (int64_t v = first; v <= last + period_ns / 2; v += period_ns) {
        while (k + 1 < frames.size() && frames[k + 1].vsync_ns <= v + period_ns / 2) ++k;
        // The newest present shown by this vsync: the walk never leaves one behind.
        assert(k < frames.size() && frames[k].vsync_ns <= v + period_ns / 2);
        const FrameRecord& f = frames[k];
        const bool shown_now = std::llabs(f.vsync_ns - v) < period_ns / 2;
        VsyncSample s;
        s.vsync_ns = v;
        s.shown = !shown_now                       ? VsyncShown::repeat
                  : f.kind == FrameKind::new_frame ? VsyncShown::new_frame
                                                   : VsyncShown::rewarp;
        s.on_time = shown_now && f.on_time;
        s.late = shown_now && f.late;
        // A repeated frame ages, and is compared with the head where it is at this vsync.
        const int64_t photon = v + (f.photon_time_ns - f.vsync_ns);
        s.latency_ms = ns_to_ms(photon - f.pose_sample_time_ns);
        s.registration_error_deg = std::numeric_limits<double>::quiet_NaN();
        if (shown_now)
            s.registration_error_deg = f.registration_error_deg;
        else if (truth)
            if (std::optional<TruthPose> t = truth(photon))
                s.registration_error_deg =
                    registration_error(f.shown_pose, *t, registration_distance_m);
        out.push_back(s);
    }
    return out;
}

ReplaySummary summarize_presents(const std::vector<FrameRecord>& frames, int64_t period_ns,
                                 const TruthFn& truth, double registration_distance_m) {
    return summarize_vsyncs(frames,
                            vsync_series(frames, period_ns, truth, registration_distance_m));
}

ReplaySummary summarize_vsyncs(const std::vector<FrameRecord>& frames,
                               const std::vector<VsyncSample>& vsyncs) {
    ReplaySummary s;
    s.frames = frames.size();
    std::vector<double> ren, warp;
    double tri = 0.0;
    for (const FrameRecord& f : frames) {
        if (f.kind == FrameKind::new_frame) {
            ++s.new_frames;
            ren.push_back(f.render_ms);
            tri += double(f.triangles);
            s.late_frames += f.late ? 1 : 0;
            s.lod_pops += f.lod_pops;
            s.lod_transitions += f.lod_transitions;
            s.lod_fading_frames += f.lod_fading > 0;
            s.gaze_frames += f.gaze_source == GazeSource::eye_tracker;
        } else {
            ++s.rewarps;
        }
        if (f.warp_ms > 0.0) warp.push_back(f.warp_ms);
    }
    s.render_ms = percentiles(ren);
    s.warp_ms = percentiles(warp);
    s.triangles_mean = s.new_frames ? tri / double(s.new_frames) : 0.0;
    if (frames.size() > 1 && frames.back().photon_time_ns > frames.front().photon_time_ns)
        s.lod_pops_per_min =
            double(s.lod_pops) /
            (ns_to_s(frames.back().photon_time_ns - frames.front().photon_time_ns) / 60.0);
    if (vsyncs.empty()) return s;
    std::vector<double> lat, reg;
    size_t good = 0, run = 0;
    for (const VsyncSample& v : vsyncs) {
        ++s.vsyncs;
        if (v.on_time) {
            ++good;
            run = 0;
        } else {
            s.longest_late_run = std::max(s.longest_late_run, ++run);
        }
        lat.push_back(v.latency_ms);
        reg.push_back(v.registration_error_deg);
    }
    assert(good <= s.vsyncs && s.vsyncs == vsyncs.size());
    s.missed_vsyncs = s.vsyncs - good;
    s.on_time_rate = double(good) / double(s.vsyncs);
    s.new_frames_per_vsync = double(s.new_frames) / double(s.vsyncs);
    s.latency_ms = percentiles(lat);
    s.registration_error_deg = percentiles(reg);
    return s;
}

Status check_replay_options(const ReplayOptions& opt) {
    if (!opt.report.empty())
        if (Status st = check_output_file(opt.report); !st.ok())
            return make_error("report " + st.error().message);
    if (Status st = check_persistence(opt.display); !st.ok())
        return make_error("display persistence " + st.error().message);
    if (!is_display_type(opt.display_type))
        return make_error("display type \"" + opt.display_type + "\" is not one of " +
                          kDisplayTypeNames);
    if (opt.display_type != "mock" && opt.simulated_clock)
        return make_error("display " + opt.display_type +
                          " is a real panel: it runs on the real clock, not the simulated one");
    if (opt.display_type != "mock" && opt.display_watcher)
        return make_error("display " + opt.display_type +
                          ": a simulated camera films the mock display only");
    const SimTrackerConfig& t = opt.tracker;
    if (!(t.resample_hz >= 0.0 && t.resample_hz <= kMaxResampleHz))
        return make_error("tracker resample rate " + std::to_string(t.resample_hz) +
                          " Hz is not between 0 and " + std::to_string(int(kMaxResampleHz)));
    if (!(t.noise_deg >= 0.0 && t.noise_deg <= 180.0))
        return make_error("tracker noise " + std::to_string(t.noise_deg) +
                          " deg is not between 0 and 180");
    if (!(opt.node.lod.tolerance_px >= 0.0) || !std::isfinite(opt.node.lod.tolerance_px))
        return make_error("LOD tolerance " + std::to_string(opt.node.lod.tolerance_px) +
                          " px must be a finite number >= 0");
    if (opt.node.lod_fade_frames < 0 || opt.node.lod_fade_frames > kMaxLodFadeFrames)
        return make_error("LOD fade frames " + std::to_string(opt.node.lod_fade_frames) +
                          " is not between 0 and " + std::to_string(kMaxLodFadeFrames));
    if (opt.renderer.msaa_samples != 1 && opt.renderer.msaa_samples != 4)
        return make_error("MSAA samples " + std::to_string(opt.renderer.msaa_samples) +
                          " is not 1 or 4");
    if (!(opt.start_s >= 0.0 && opt.duration_s >= 0.0) || !std::isfinite(opt.start_s) ||
        !std::isfinite(opt.duration_s))
        return make_error("start and duration must be finite and >= 0");
    return {};
}

namespace {

bool trace_has_position(const std::shared_ptr<const Trace>& trace) {
    return trace && !trace->samples.empty() && trace->samples[0].position;
}

// The trace the replay reads (opt.trace_data, or opt.trace for the trace and sim backends),
// moved for --recentre; null without one.
Result<std::shared_ptr<const Trace>> replay_trace(const ReplayOptions& opt) {
    std::shared_ptr<const Trace> trace;
    const bool wants_trace =
        opt.tracker_backend == TrackerBackend::trace || opt.tracker_backend == TrackerBackend::sim;
    if (opt.trace_data) {
        trace = opt.trace_data;
    } else if (wants_trace && !opt.trace.empty()) {
        Result<Trace> trace_r = read_trace_csv(opt.trace);
        if (!trace_r.ok())
            return make_error(trace_r.error().message +
                              " (replay reads hmdnode trace CSV; convert other tables with "
                              "`hmdnode trace import`)");
        trace = std::make_shared<const Trace>(std::move(trace_r).value());
    }
    if (trace && opt.recentre) {
        if (!trace_has_position(trace))
            return make_error(opt.trace.string() + ": --recentre needs a trace with positions");
        Trace moved = *trace;
        const glm::dvec3 shift = opt.node.default_head_position - *moved.samples[0].position;
        for (TraceSample& ts : moved.samples)
            if (ts.position) *ts.position += shift;
        trace = std::make_shared<const Trace>(std::move(moved));
    }
    return trace;
}

// What the one assembly place (node_assembly.hpp) builds for the replay: the clock, the trackers
// (the trace's: replayed by the trace backend, the sim device's motion, the eye tracker's gaze
// columns), the mock display, the renderer and the runtime.
Result<NodeSpec> replay_node_spec(const ReplayOptions& opt, std::shared_ptr<const Trace> trace,
                                  const WiringKeys& keys, ClockKind clock_kind) {
    TrackerSpec spec;
    spec.backend = opt.tracker_backend;
    spec.from = opt.from;
    spec.base_stations = opt.base_stations;
    spec.trace = trace;
    spec.trace_path = opt.trace;
    spec.device = opt.device;
    spec.sim = opt.tracker;
    spec.start_s = opt.start_s;
    spec.duration_s = opt.duration_s;
    if (Status st = check_tracker_spec(spec, clock_kind, keys); !st.ok()) return st.error();
    // The eye tracker: the trace's gaze columns, replayed with the head (none: the lens centre).
    EyeTrackerSpec eye_spec;
    eye_spec.backend = opt.eye_tracker;
    eye_spec.trace = trace;
    eye_spec.trace_path = opt.trace;
    eye_spec.start_s = opt.start_s;
    eye_spec.duration_s = opt.duration_s;
    if (opt.eye_tracker == EyeTrackerBackend::trace && !trace)
        return make_error(keys.eye_tracker + " trace needs " + keys.trace);
    // The runtime's read-back follows the one read-back rule of make_node (only the frames the
    // mock display writes come back to the CPU).
    NodeSpec ns;
    ns.keys = keys;
    ns.clock = clock_kind;
    ns.tracker = spec;
    ns.eye_tracker = eye_spec;
    ns.display.type = opt.display_type;
    ns.display.mock = opt.display;
    ns.display.kms = opt.real_display;
    ns.display.mock_watcher = opt.display_watcher;
    ns.renderer.config = opt.renderer;
    ns.node = opt.node;
    return ns;
}

// The simulated clock's frame cost (given, or measured on this renderer now: the simulated clock
// does not move while it is measured), and whether it was measured.
struct ReplayFrameCost {
    std::optional<FrameCostModel> model;
    bool calibrated = false;
};

Result<ReplayFrameCost> replay_frame_cost(const ReplayOptions& opt, NodeRuntime& node) {
    ReplayFrameCost cost;
    if (!opt.simulated_clock) {
        // Seeds the pacing estimates with this renderer's measured costs.
        if (Result<FrameCostModel> m = node.calibrate_frame_cost(); !m.ok()) return m.error();
        return cost;
    }
    if (opt.frame_cost) {
        cost.model = *opt.frame_cost;
    } else {
        Result<FrameCostModel> m = node.calibrate_frame_cost();
        if (!m.ok()) return m.error();
        cost.model = *m;
        cost.calibrated = true;
    }
    node.set_sim_cost(*cost.model);
    return cost;
}

// Truth for registration error: `truth_trace` itself (null: no truth), slerped, at the photon
// time, the replay's part of it (--start, --duration) played from trace_host_start.
TruthFn replay_truth(const ReplayOptions& opt, std::shared_ptr<const Trace> truth_trace,
                     int64_t trace_host_start) {
    const int64_t start_offset_ns = s_to_ns(opt.start_s), duration_ns = s_to_ns(opt.duration_s);
    const int64_t trace_t0 = truth_trace ? truth_trace->start_ns() + start_offset_ns : 0;
    const int64_t trace_end = !truth_trace ? 0
                              : duration_ns > 0
                                  ? std::min(truth_trace->end_ns(), trace_t0 + duration_ns)
                                  : truth_trace->end_ns();
    const bool has_position = trace_has_position(truth_trace);
    return [=](int64_t host_ns) -> std::optional<TruthPose> {
        if (!truth_trace) return std::nullopt;
        const int64_t t = host_ns - trace_host_start + trace_t0;
        if (t > trace_end) return std::nullopt;  // past the recording: no truth
        const Pose p = truth_trace->pose_at(t);
        TruthPose tp;
        tp.orientation = p.orientation;
        if (has_position) tp.position = p.position;
        return tp;
    };
}

// Runs the node's frames into result->frames until the tracker finishes, --duration ends (any
// backend but trace: the frames whose wake-up falls within it; a trace's ends the trace) or
// --max-frames, then stops it.
Status replay_frames(const ReplayOptions& opt, AssembledNode& parts, const TruthFn& truth,
                     ReplayResult* result) {
    NodeRuntime& node = parts.runtime();
    const int64_t host_start = parts.host_start_ns();
    const int64_t start_offset_ns = s_to_ns(opt.start_s), duration_ns = s_to_ns(opt.duration_s);
    FrameRecord rec;
    const int64_t capture_end = opt.tracker_backend != TrackerBackend::trace && duration_ns > 0
                                    ? host_start + duration_ns
                                    : std::numeric_limits<int64_t>::max();
    while (!node.tracker_finished() && parts.clock().now_ns() < capture_end &&
           (opt.max_frames <= 0 || int64_t(result->frames.size()) < opt.max_frames)) {
        Result<FrameOutcome> fr = parts.run_frame(&rec, truth);
        if (!fr.ok()) {
            node.stop();
            return make_error("frame " + std::to_string(result->frames.size()) + ": " +
                              fr.error().message);
        }
        if (*fr == FrameOutcome::no_pose_yet) continue;  // nothing presented, nothing to record
        result->frames.push_back(rec);
        if (opt.on_frame) opt.on_frame(rec);
    }
    node.stop();
    // A capture's --start past its last sample: every frame would show the last pose.
    if (opt.tracker_backend == TrackerBackend::capture && start_offset_ns > 0 &&
        (node.history().empty() ||
         node.history().newest_time_ns() < host_start - kNsPerSecond / 2)) {
        char start[32];
        std::snprintf(start, sizeof start, "%g", opt.start_s);
        return make_error(opt.from.string() + ": --start " + start +
                          " s is past the capture's last sample");
    }
    result->trace_samples = parts.tracker().counters().samples_delivered;
    return {};
}

// The per-vsync series and the summary of the frames run, with what the node learned and used.
void summarize_replay(const ReplayOptions& opt, AssembledNode& parts, const ReplayFrameCost& cost,
                      const TruthFn& truth, std::chrono::steady_clock::time_point wall0,
                      ReplayResult* result) {
    const NodeRuntime& node = parts.runtime();
    result->display = parts.display().info();
    result->period_ns = result->display.period_ns;
    result->vsyncs =
        vsync_series(result->frames, result->period_ns, truth, opt.node.registration_distance_m);
    result->summary = summarize_vsyncs(result->frames, result->vsyncs);
    ReplaySummary& s = result->summary;
    s.frame_cost_model = cost.model;
    s.frame_cost_calibrated = cost.calibrated;
    if (!node.lod_cost_fit().empty())
        s.lod_cost_fit = ReplaySummary::LearnedCost{node.lod_cost_fit().base_ms(),
                                                    node.lod_cost_fit().per_triangle_ms()};
    s.replayed_s =
        s.frames
            ? ns_to_s(result->frames.back().photon_time_ns - result->frames.front().photon_time_ns)
            : 0.0;
    s.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
    s.lens_pass = node.lens_pass();
    s.cpu_wake = parts.cpu_wake();
    s.pass_times = node.pass_times();
    for (const LadderStep& st : node.ladder().steps())
        s.ladder.push_back({st.name, st.scale, st.chromatic, 0, 0});
    s.presents_by_divisor.assign(size_t(std::max(1, opt.node.pacing.max_divisor)), 0);
    for (const FrameRecord& f : result->frames) {
        ReplaySummary::LadderShare& l = s.ladder[size_t(f.ladder_step)];
        ++l.presents;
        if (f.kind == FrameKind::new_frame) ++l.new_frames;
        const size_t d = size_t(std::max(1, f.render_divisor)) - 1;
        if (d < s.presents_by_divisor.size()) ++s.presents_by_divisor[d];
    }
    // (On the simulated clock the pass costs what the model charges, not what it measured.)
    const double pass_p99_ms = cost.model ? ns_to_ms(cost.model->warp_ns) : s.warp_ms.p99;
    if (std::isfinite(pass_p99_ms))
        s.mtp_floor_ms = ns_to_ms(parts.display().photon_offset_ns() +
                                  parts.display().info().latch_margin_ns + opt.tracker.latency_ns) +
                         pass_p99_ms;
}

}  // namespace

// Scene and trace, the node assembled (node_assembly.hpp) and calibrated, its frames, the
// summary, the report.
Result<ReplayResult> run_replay(const ReplayOptions& opt) {
    const auto wall0 = std::chrono::steady_clock::now();
    if (Status st = check_replay_options(opt); !st.ok()) return st.error();
    Result<Scene> scene = load_gltf(opt.scene);
    if (!scene.ok()) return scene.error();
    // The one wiring place (wiring.hpp), named by the command's flags.
    const WiringKeys keys = WiringKeys::command_line();
    const ClockKind clock_kind = opt.simulated_clock ? ClockKind::sim : ClockKind::real;
    Result<std::shared_ptr<const Trace>> trace = replay_trace(opt);
    if (!trace.ok()) return trace.error();
    Result<NodeSpec> ns = replay_node_spec(opt, *trace, keys, clock_kind);
    if (!ns.ok()) return ns.error();
    Result<std::unique_ptr<AssembledNode>> assembled = make_node(*ns, *scene);
    if (!assembled.ok()) return assembled.error();
    AssembledNode& parts = **assembled;
    NodeRuntime& node = parts.runtime();
    Result<ReplayFrameCost> cost = replay_frame_cost(opt, node);
    if (!cost.ok()) return cost.error();
    // On the system clock the calibration above takes real time (seconds on a heavy scene) that
    // would come out of the trace: the trace starts again now, on a fresh tracker.
    int64_t trace_host_start = parts.host_start_ns();
    if (!opt.simulated_clock && opt.tracker_backend == TrackerBackend::trace) {
        trace_host_start = parts.clock().now_ns();
        if (Status st = parts.restart_trackers(); !st.ok()) return st.error();
    }
    // Only the trace backend has a truth to compare with (the sim device's motion is the trace,
    // but its fused pose lags it by the device's latency: no truth there either).
    const TruthFn truth = replay_truth(
        opt, opt.tracker_backend == TrackerBackend::trace ? *trace : nullptr, trace_host_start);

    ReplayResult result;
    result.device_name = parts.renderer().device_name();
    result.renderer_backend = parts.renderer().backend_name();
    result.mesh_cols = node.mesh_cols();
    result.mesh_rows = node.mesh_rows();
    result.lod_allocator = opt.node.lod_allocator;
    result.msaa_samples = parts.renderer().msaa_samples();
    for (const SceneObject& o : node.objects()) result.object_names.push_back(o.name);
    if (Status st = replay_frames(opt, parts, truth, &result); !st.ok()) return st.error();
    summarize_replay(opt, parts, *cost, truth, wall0, &result);
    if (!opt.report.empty()) {
        const std::string text = replay_report_json(opt, result).dump(1);
        if (Status st = write_file_atomically(opt.report, text); !st.ok()) return st.error();
    }
    return result;
}

const char* gaze_source_summary(const ReplaySummary& s) {
    if (s.gaze_frames == 0) return "lens_centre";
    return s.gaze_frames == s.new_frames ? "eye_tracker" : "mixed";
}

nlohmann::json replay_summary_json(const ReplaySummary& s) {
    using nlohmann::json;
    json cost = nullptr;
    if (s.frame_cost_model)
        cost = {{"render_base", ns_to_ms(s.frame_cost_model->base_ns)},
                {"render_per_1k_triangles", s.frame_cost_model->per_triangle_ns * 1e-3},
                {"warp", ns_to_ms(s.frame_cost_model->warp_ns)},
                {"warp_no_ca", ns_to_ms(s.frame_cost_model->warp_cost_ns(false))},
                {"calibrated", s.frame_cost_calibrated}};
    json ladder = json::array();
    for (const ReplaySummary::LadderShare& l : s.ladder)
        ladder.push_back({{"step", l.name},
                          {"scale", l.scale},
                          {"chromatic_aberration_corrected", l.chromatic},
                          {"new_frames", l.new_frames},
                          {"presents", l.presents}});
    json fit = nullptr;
    if (s.lod_cost_fit)
        fit = {{"render_base", s.lod_cost_fit->base_ms},
               {"render_per_1k_triangles", s.lod_cost_fit->per_triangle_ms * 1e3}};
    return {{"frames", s.frames},
            {"new_frames", s.new_frames},
            {"rewarps", s.rewarps},
            {"vsyncs", s.vsyncs},
            {"missed_vsyncs", s.missed_vsyncs},
            {"late_frames", s.late_frames},
            {"longest_late_run", s.longest_late_run},
            {"new_frames_per_vsync", s.new_frames_per_vsync},
            {"latency_ms", percentiles_json(s.latency_ms)},
            {"registration_error_deg", percentiles_json(s.registration_error_deg)},
            {"render_ms", percentiles_json(s.render_ms)},
            {"warp_ms",
             {{"p50", finite_or_null(s.warp_ms.p50)}, {"p99", finite_or_null(s.warp_ms.p99)}}},
            {"frame_cost_model_ms", cost},
            {"lod_cost_fit_ms", fit},
            {"on_time_rate", s.on_time_rate},
            {"triangles_mean", s.triangles_mean},
            {"lod_pops", s.lod_pops},
            {"lod_pops_per_min", finite_or_null(s.lod_pops_per_min)},
            {"lod_transitions", s.lod_transitions},
            {"lod_fading_frames", s.lod_fading_frames},
            {"gaze_source", gaze_source_summary(s)},
            {"gaze_frames", s.gaze_frames},
            {"lens_pass", s.lens_pass},
            {"cpu_wake", s.cpu_wake},
            {"pass_ms",
             {{"fused", finite_or_null(s.pass_times.fused_ms)},
              {"mesh", finite_or_null(s.pass_times.mesh_ms)},
              {"floor", finite_or_null(s.pass_times.floor_ms)}}},
            {"ladder", ladder},
            {"presents_by_render_rate", s.presents_by_divisor},
            {"mtp_floor_ms", finite_or_null(s.mtp_floor_ms)},
            {"replayed_s", s.replayed_s},
            {"wall_s", s.wall_s}};
}

// The report's "display": the mock panel as configured, or what a real one said of itself.
nlohmann::json replay_display_json(const ReplayOptions& opt, const DisplayInfo& info) {
    if (opt.display_type == "mock")
        return {{"type", "mock"},
                {"eye_width", opt.display.eye_width},
                {"eye_height", opt.display.eye_height},
                {"refresh_hz", opt.display.refresh_hz},
                {"persistence_ms", ns_to_ms(opt.display.persistence_ns)},
                {"scanout_fraction", opt.display.scanout_fraction}};
    return {{"type", opt.display_type},      {"name", info.name},
            {"eye_width", info.eye_width},   {"eye_height", info.eye_height},
            {"refresh_hz", info.refresh_hz}, {"persistence_ms", ns_to_ms(info.persistence_ns)}};
}

nlohmann::json replay_report_json(const ReplayOptions& opt, const ReplayResult& r) {
    using nlohmann::json;
    json frames = json::array();
    for (const FrameRecord& f : r.frames) {
        json levels = json::object();
        for (size_t i = 0; i < f.levels.size(); ++i) levels[r.object_names[i]] = f.levels[i];
        frames.push_back({{"index", f.index},
                          {"kind", f.kind == FrameKind::rewarp ? "rewarp" : "new"},
                          {"frame", f.frame},
                          {"render_target_vsync_ns", f.render_target_vsync_ns},
                          {"target_vsync_ns", f.target_vsync_ns},
                          {"vsync_ns", f.vsync_ns},
                          {"pose_sample_time_ns", f.pose_sample_time_ns},
                          {"predicted_photon_time_ns", f.predicted_photon_time_ns},
                          {"photon_time_ns", f.photon_time_ns},
                          {"latency_ms", f.latency_ms},
                          {"prediction_horizon_ms", f.prediction_horizon_ms},
                          {"registration_error_deg", finite_or_null(f.registration_error_deg)},
                          {"angular_speed_dps", f.angular_speed_dps},
                          {"on_time", f.on_time},
                          {"late", f.late},
                          {"missed_vsyncs_before", f.missed_vsyncs_before},
                          {"render_pose_sample_time_ns", f.render_pose_sample_time_ns},
                          {"lod", levels},
                          {"triangles", f.triangles},
                          {"culled", f.culled},
                          {"lod_budget_ms", finite_or_null(f.lod_budget_ms)},
                          {"predicted_render_ms", finite_or_null(f.predicted_render_ms)},
                          {"lod_coarsened", f.lod_coarsened},
                          {"lod_fading", f.lod_fading},
                          {"lod_transitions", f.lod_transitions},
                          {"lod_pops", f.lod_pops},
                          {"gaze_source", gaze_source_name(f.gaze_source)},
                          {"render_ms", f.render_ms},
                          {"warp_ms", f.warp_ms},
                          {"frame_cost_ms", f.frame_cost_ms},
                          {"ladder_step", f.ladder_step},
                          {"render_scale", f.render_scale},
                          {"chromatic_aberration_corrected", f.chromatic},
                          {"render_rate_divisor", f.render_divisor}});
    }
    const ReplaySummary& s = r.summary;
    return {{"format", "hmdnode-replay-report/2"},
            {"scene", opt.scene.string()},
            {"tracker", tracker_backend_name(opt.tracker_backend)},
            {"eye_tracker", eye_tracker_backend_name(opt.eye_tracker)},
            {"trace", opt.trace.string()},
            {"from", opt.from.string()},
            {"clock", opt.simulated_clock ? "sim" : "real"},
            {"renderer", r.device_name},
            {"renderer_backend", r.renderer_backend},
            {"display", replay_display_json(opt, r.display)},
            {"ipd_m", opt.node.rig.ipd_m},
            {"prediction", opt.node.predict},
            {"warp", opt.node.warp},
            {"lod_allocator", lod_allocator_name(r.lod_allocator)},
            {"lod_fade_frames", opt.node.lod_fade_frames},
            {"msaa_samples", r.msaa_samples},
            {"distortion", opt.node.distortion ? json(opt.node.headset.name) : json(nullptr)},
            {"distortion_mesh", {r.mesh_cols, r.mesh_rows}},
            {"objects", r.object_names},
            {"trace_samples", r.trace_samples},
            {"summary", replay_summary_json(s)},
            {"frames", frames}};
}

std::string lens_pass_summary(const ReplaySummary& s) {
    if (s.lens_pass.empty()) return "";
    char buf[512];
    std::ostringstream out;
    auto ms = [](double v) {
        char b[32];
        if (std::isfinite(v))
            std::snprintf(b, sizeof b, "%.2f ms", v);
        else
            std::snprintf(b, sizeof b, "n/a");
        return std::string(b);
    };
    std::snprintf(buf, sizeof buf,
                  "lens pass %s (start-up: fused %s, mesh %s, floor %s = three bilinear samples "
                  "per pixel)",
                  s.lens_pass.c_str(), ms(s.pass_times.fused_ms).c_str(),
                  ms(s.pass_times.mesh_ms).c_str(), ms(s.pass_times.floor_ms).c_str());
    out << buf;
    if (s.cpu_wake != "off") out << "; cores kept awake: " << s.cpu_wake;
    if (std::isfinite(s.mtp_floor_ms)) {
        std::snprintf(buf, sizeof buf,
                      "; motion-to-photon floor %.2f ms (photon offset + latch + pass p99 + "
                      "tracker latency)",
                      s.mtp_floor_ms);
        out << buf;
    }
    out << "\npixel-cost ladder (share of presents):";
    const double n = double(std::max<size_t>(1, s.frames));
    bool any = false;
    for (const ReplaySummary::LadderShare& l : s.ladder) {
        if (l.presents == 0) continue;
        std::snprintf(buf, sizeof buf, "%s %s %.1f %%", any ? "," : "", l.name.c_str(),
                      100.0 * double(l.presents) / n);
        out << buf;
        any = true;
    }
    if (!any) out << " none";
    out << "; render rate:";
    any = false;
    for (size_t d = 0; d < s.presents_by_divisor.size(); ++d) {
        if (s.presents_by_divisor[d] == 0) continue;
        std::snprintf(buf, sizeof buf, "%s 1/%zu %.1f %%", any ? "," : "", d + 1,
                      100.0 * double(s.presents_by_divisor[d]) / n);
        out << buf;
        any = true;
    }
    if (!any) out << " none";
    out << '\n';
    return out.str();
}

std::string replay_summary_table(const ReplayResult& r) {
    const ReplaySummary& s = r.summary;
    char buf[1024];
    std::ostringstream out;
    // One row; a value that does not exist (no truth, no frames) prints as "n/a".
    auto row = [&](const char* label, const Percentiles& p, int decimals) {
        std::snprintf(buf, sizeof buf, "%-26s", label);
        out << buf;
        for (double v : {p.p50, p.p95, p.p99, p.max}) {
            if (std::isfinite(v))
                std::snprintf(buf, sizeof buf, " %8.*f", decimals, v);
            else
                std::snprintf(buf, sizeof buf, " %8s", "n/a");
            out << buf;
        }
        out << '\n';
    };
    std::snprintf(buf, sizeof buf,
                  "%zu new frames + %zu re-warps over %.1f s of trace (%zu samples), wall %.1f s, "
                  "renderer %s\n"
                  "vsyncs %zu: %.1f %% on time (new or re-warped), %zu missed, %.2f new frames "
                  "per vsync, %zu late frames, longest missed run %zu\n"
                  "%-26s %8s %8s %8s %8s\n",
                  s.new_frames, s.rewarps, s.replayed_s, r.trace_samples, s.wall_s,
                  r.device_name.c_str(), s.vsyncs, 100.0 * s.on_time_rate, s.missed_vsyncs,
                  s.new_frames_per_vsync, s.late_frames, s.longest_late_run, "", "p50", "p95",
                  "p99", "max");
    out << buf;
    row("motion-to-photon (ms)", s.latency_ms, 2);
    row("registration error (deg)", s.registration_error_deg, 3);
    row("render, measured (ms)", s.render_ms, 2);
    row("warp, measured (ms)", s.warp_ms, 2);
    if (s.frame_cost_model) {
        std::snprintf(
            buf, sizeof buf,
            "simulated clock: frame cost model %.2f ms + %.3f ms per 1k triangles, warp "
            "%.2f ms (%s); latency above follows the model\n",
            ns_to_ms(s.frame_cost_model->base_ns), s.frame_cost_model->per_triangle_ns * 1e-3,
            ns_to_ms(s.frame_cost_model->warp_ns),
            s.frame_cost_calibrated ? "calibrated on this renderer at start-up" : "given");
        out << buf;
    }
    std::snprintf(buf, sizeof buf,
                  "triangles per new frame %.0f (mean), LOD allocator %s, %zu LOD cross-fades, "
                  "%zu pops (%.1f per minute), MSAA %dx, gaze %s (%zu of %zu new frames)",
                  s.triangles_mean, lod_allocator_name(r.lod_allocator), s.lod_transitions,
                  s.lod_pops, std::isfinite(s.lod_pops_per_min) ? s.lod_pops_per_min : 0.0,
                  r.msaa_samples, gaze_source_summary(s), s.gaze_frames, s.new_frames);
    out << buf;
    if (s.lod_cost_fit) {
        std::snprintf(buf, sizeof buf, ", learned render cost %.2f ms + %.3f ms per 1k triangles",
                      s.lod_cost_fit->base_ms, s.lod_cost_fit->per_triangle_ms * 1e3);
        out << buf;
    }
    out << '\n' << lens_pass_summary(s);
    return out.str();
}

}  // namespace hmdnode
