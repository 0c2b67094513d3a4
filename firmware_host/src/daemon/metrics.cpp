#include "daemon/metrics.hpp"

#include <spdlog/fmt/fmt.h>

namespace hmdnode {

void Histogram::observe(double seconds) {
    for (size_t i = 0; i < kBounds.size(); ++i)
        if (seconds <= kBounds[i]) {
            ++counts[i];
            break;
        }
    ++count;
    sum += seconds;
}

void DaemonMetrics::add_frame(const FrameRecord& rec, bool first) {
    ++frames;
    if (first) first_photon_ns = rec.photon_time_ns;
    last_photon_ns = rec.photon_time_ns;
    vsyncs += 1 + uint64_t(first ? 0 : rec.missed_vsyncs_before);
    missed_vsyncs += uint64_t(first ? 0 : rec.missed_vsyncs_before) + (rec.on_time ? 0 : 1);
    late_frames += rec.late;
    rewarps += rec.kind == FrameKind::rewarp;
    mtp.observe(rec.latency_ms * 1e-3);
    ladder_step = rec.ladder_step;
    render_scale = rec.render_scale;
    render_divisor = rec.render_divisor;
    if (size_t(rec.ladder_step) < presents_by_step.size())
        ++presents_by_step[size_t(rec.ladder_step)];
    if (rec.render_divisor >= 1 && size_t(rec.render_divisor) <= presents_by_divisor.size())
        ++presents_by_divisor[size_t(rec.render_divisor) - 1];
    if (rec.kind == FrameKind::new_frame) {
        render.observe(rec.render_ms * 1e-3);
        triangles = rec.triangles;
        lod_pops += rec.lod_pops;
        lod_transitions += rec.lod_transitions;
        if (last_levels.size() == rec.levels.size())
            for (size_t i = 0; i < rec.levels.size(); ++i)
                lod_switches += rec.levels[i] != last_levels[i];
        last_levels = rec.levels;  // note: same size after the first frame: no allocation
    }
}

double DaemonMetrics::lod_pops_per_min() const {
    const double minutes = double(last_photon_ns - first_photon_ns) * 1e-9 / 60.0;
    return minutes > 0.0 ? double(lod_pops) / minutes : 0.0;
}

namespace {

void counter(std::string& out, const char* name, const char* help, uint64_t v) {
    out += fmt::format("# HELP {0} {1}\n# TYPE {0} counter\n{0} {2}\n", name, help, v);
}
void gauge(std::string& out, const char* name, const char* help, double v) {
    out += fmt::format("# HELP {0} {1}\n# TYPE {0} gauge\n{0} {2}\n", name, help, v);
}
void histogram(std::string& out, const char* name, const char* help, const Histogram& h) {
    out += fmt::format("# HELP {0} {1}\n# TYPE {0} histogram\n", name, help);
    uint64_t cumulative = 0;
    for (size_t i = 0; i < Histogram::kBounds.size(); ++i) {
        cumulative += h.counts[i];
        out += fmt::format("{}_bucket{{le=\"{}\"}} {}\n", name, Histogram::kBounds[i], cumulative);
    }
    out += fmt::format("{0}_bucket{{le=\"+Inf\"}} {1}\n{0}_sum {2}\n{0}_count {1}\n", name, h.count,
                       h.sum);
}

}  // namespace

std::string DaemonMetrics::prometheus(const DeviceTrackerStatus* t) const {
    std::string out;
    counter(out, "hmdnode_frames_total", "Frames presented (new and re-warped).", frames);
    counter(out, "hmdnode_frame_errors_total", "Frames that failed to render or present.", errors);
    counter(out, "hmdnode_no_pose_frames_total", "Frames skipped for want of a pose.",
            no_pose_frames);
    counter(out, "hmdnode_vsyncs_total", "Vsyncs since the first present.", vsyncs);
    counter(out, "hmdnode_missed_vsyncs_total", "Vsyncs without a new or re-warped frame on time.",
            missed_vsyncs);
    counter(out, "hmdnode_late_frames_total", "New frames shown after their vsync.", late_frames);
    counter(out, "hmdnode_rewarps_total", "Re-warps of the previous frame.", rewarps);
    counter(out, "hmdnode_lod_switches_total", "Changes of an object's LOD level between frames.",
            lod_switches);
    counter(out, "hmdnode_lod_pops_total",
            "Visible LOD level changes shown without a cross-fade (pops).", lod_pops);
    counter(out, "hmdnode_lod_transitions_total", "LOD cross-fades begun.", lod_transitions);
    gauge(out, "hmdnode_lod_pops_per_minute", "LOD pops per minute since the first present.",
          lod_pops_per_min());
    gauge(out, "hmdnode_triangles", "Triangles of the last new frame.", double(triangles));
    gauge(out, "hmdnode_ladder_step",
          "Pixel-cost ladder step of the last present (0: full resolution).", double(ladder_step));
    gauge(out, "hmdnode_render_scale", "Eye-buffer resolution per axis of the last present.",
          render_scale);
    gauge(out, "hmdnode_render_rate_divisor",
          "New frames every this many vsyncs (re-warps between), last present.",
          double(render_divisor));
    out +=
        "# HELP hmdnode_ladder_presents_total Presents per pixel-cost ladder step.\n"
        "# TYPE hmdnode_ladder_presents_total counter\n";
    for (size_t i = 0; i < presents_by_step.size(); ++i)
        if (presents_by_step[i] > 0)
            out += fmt::format("hmdnode_ladder_presents_total{{step=\"{}\"}} {}\n", i,
                               presents_by_step[i]);
    out +=
        "# HELP hmdnode_render_rate_presents_total Presents per render-rate divisor.\n"
        "# TYPE hmdnode_render_rate_presents_total counter\n";
    for (size_t i = 0; i < presents_by_divisor.size(); ++i)
        if (presents_by_divisor[i] > 0)
            out += fmt::format("hmdnode_render_rate_presents_total{{divisor=\"{}\"}} {}\n", i + 1,
                               presents_by_divisor[i]);
    histogram(out, "hmdnode_motion_to_photon_seconds",
              "Motion-to-photon latency of each present (panel centre, mid-persistence).", mtp);
    histogram(out, "hmdnode_render_seconds", "Render time of each new frame.", render);
    if (t) {
        gauge(out, "hmdnode_tracker_connected", "1 while the tracker is open.",
              t->connected ? 1.0 : 0.0);
        counter(out, "hmdnode_tracker_samples_total", "Tracker samples delivered.", t->samples);
        counter(out, "hmdnode_tracker_disconnects_total", "Tracker disconnects.", t->disconnects);
        counter(out, "hmdnode_tracker_sequence_gaps_total", "Reports missing by sequence number.",
                t->codec.sequence_gaps);
        gauge(out, "hmdnode_tracker_gap_seconds_total", "Time without the tracker, in all.",
              double(t->total_gap_ns) * 1e-9);
        gauge(out, "hmdnode_tracker_clock_offset_seconds", "Device-to-host clock offset.",
              double(t->clock_offset_ns) * 1e-9);
    }
    return out;
}

}  // namespace hmdnode
