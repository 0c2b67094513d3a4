// hmdnoded's status: each frame counted into the status window, the window logged and written to
// the status file (on a thread of its own) and sent to systemd (STATUS=), readiness after the first
// presented frame, and the watchdog from the loop's progress.
#include <chrono>
#include <filesystem>
#include <string>

#include <spdlog/spdlog.h>

#include "daemon/daemon.hpp"
#include "hmdnode/firmware_host/replay.hpp"
#include "hmdnode/hal/tracking/base_station_placement.hpp"
#include "hmdnode/hal/tracking/device_tracker.hpp"

namespace hmdnode {

// A frame with no pose yet (an absent device): said every 5 s; before readiness systemd's start
// timeout is extended, the loop keeping its pace without a pose being no hung start.
void Daemon::note_no_pose() {
    ++no_pose_frames_;
    ++metrics_.no_pose_frames;
    Clock& clock = node_->clock();
    if (clock.now_ns() < next_wait_log_) return;
    std::string last_error;
    if (DeviceTracker* dt = node_->device_tracker()) last_error = dt->status().last_error;
    const std::string& label = node_->tracker_label();
    spdlog::info("waiting for tracker {}{}{}", label, last_error.empty() ? "" : ": ", last_error);
    next_wait_log_ = clock.now_ns() + 5 * kNsPerSecond;
    if (!ready_)
        notifier_.notify("EXTEND_TIMEOUT_USEC=15000000\nSTATUS=waiting for tracker " +
                         std::string(tracker_backend_name(cfg_.tracker_backend)) + " (" + label +
                         ")" + (last_error.empty() ? "" : ": " + last_error));
}

void Daemon::note_frame(const FrameRecord& rec) {
    ++frames_;
    metrics_.add_frame(rec, frames_ == 1);
    if (!ready_) {
        ready_ = true;
        notifier_.notify("READY=1\nSTATUS=running: first frame presented");
        spdlog::info("ready: first frame presented");
    }
    ++window_frames_;
    window_on_time_ += rec.on_time;
    window_vsyncs_ += 1 + size_t(window_frames_ > 1 ? rec.missed_vsyncs_before : 0);
    window_late_ += rec.late;
    window_rewarps_ += rec.kind == FrameKind::rewarp;
    if (rec.kind == FrameKind::new_frame) {
        ++window_new_frames_;
        window_gaze_frames_ += rec.gaze_source == GazeSource::eye_tracker;
    }
    lat_.push_back(rec.latency_ms);
    if (rec.kind == FrameKind::new_frame) render_ms_.push_back(rec.render_ms);
    warp_ms_.push_back(rec.warp_ms);
}

// The window as the status file has it. A window without frames (no pose yet) has no rate or
// latencies: null.
nlohmann::json Daemon::status_json(const Percentiles& p) {
    const NodeRuntime& node = node_->runtime();
    nlohmann::json s = {
        {"time_unix_s",
         std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch())
             .count()},
        {"frames", frames_},
        {"errors", errors_},
        {"has_pose", node.has_pose()},
        {"no_pose_frames", no_pose_frames_},
        {"window_frames", window_frames_},
        {"window_vsyncs", window_vsyncs_},
        {"missed_vsyncs", window_vsyncs_ - window_on_time_},
        {"late_frames", window_late_},
        {"rewarps", window_rewarps_},
        {"eye_tracker", eye_tracker_backend_name(cfg_.eye_tracker)},
        // LOD eccentricity measured from: "eye_tracker" (every new frame of the window),
        // "lens_centre" (none), "mixed"; the count of new frames that used the gaze.
        {"gaze_source", window_gaze_frames_ == 0                    ? "lens_centre"
                        : window_gaze_frames_ == window_new_frames_ ? "eye_tracker"
                                                                    : "mixed"},
        {"gaze_frames", window_gaze_frames_},
        {"on_time_rate", window_vsyncs_
                             ? nlohmann::json(double(window_on_time_) / double(window_vsyncs_))
                             : nlohmann::json()},
        {"latency_ms", percentiles_json(p)},
        {"render_ms", percentiles_json(percentiles(render_ms_))},
        {"warp_ms", percentiles_json(percentiles(warp_ms_))},
        {"triangles", metrics_.triangles},
        {"lod_switches", metrics_.lod_switches},
        {"renderer_backend", renderer_backend_},
        {"lod_pops", metrics_.lod_pops},
        {"lod_pops_per_min", metrics_.lod_pops_per_min()},
        // The lens pass, and the pixel-cost ladder and render rate of the last present
        // (docs/latency.md); presents per step and per rate since the start.
        {"lens_pass", node.lens_pass()},
        {"ladder_step", node.ladder().steps()[size_t(metrics_.ladder_step)].name},
        {"render_scale", metrics_.render_scale},
        {"render_rate_divisor", metrics_.render_divisor}};
    if (DeviceTracker* dt = node_->device_tracker()) {
        // Recovery figures: a replug shows as a disconnect and the gap it left.
        const DeviceTrackerStatus ts = dt->status();
        s["tracker"] = {{"connected", ts.connected},
                        {"opens", ts.opens},
                        {"disconnects", ts.disconnects},
                        {"last_gap_ms", ns_to_ms(ts.last_gap_ns)},
                        {"total_gap_ms", ns_to_ms(ts.total_gap_ns)},
                        {"samples", ts.samples},
                        {"clock_offset_ms", ns_to_ms(ts.clock_offset_ns)},
                        {"clock_jitter_ms", ts.clock_jitter_ns * 1e-6},
                        {"sequence_gaps", ts.codec.sequence_gaps},
                        {"malformed_reports", ts.codec.malformed},
                        {"last_error", ts.last_error}};
        if (!ts.connected && node.has_pose())  // before: the waiting line says it
            spdlog::warn("tracker disconnected ({}); holding the last pose", ts.last_error);
    }
    return s;
}

// With tracker.place_base_stations: the device tracker's setup, when it holds base stations the
// file did not, posted to its writer (write_file_atomically on the writer's thread: a stalled disk
// never costs a vsync); a failed write is posted again at the next window.
void Daemon::store_placed_setup() {
    if (!cfg_.place_base_stations || cfg_.base_stations.empty()) return;
    DeviceTracker* dt = node_->device_tracker();
    if (!dt) return;
    if (!setup_writer_) {
        setup_writer_.emplace(cfg_.status_every_s);
        std::error_code ec;  // a stored file's base stations are not written again
        if (std::filesystem::exists(cfg_.base_stations, ec))
            if (auto s = lighthouse::load_base_station_setup(cfg_.base_stations))
                setup_stored_ = s->size();
    }
    if (const uint64_t f = setup_writer_->counts().failed; f != setup_failed_) {
        setup_failed_ = f;
        setup_stored_ = 0;
    }
    const DeviceTrackerStatus ts = dt->status();
    if (ts.light.setup.size() <= setup_stored_) return;
    std::vector<lighthouse::BaseStationPlacement> setup = ts.light.setup;
    const int64_t now = std::chrono::duration_cast<std::chrono::seconds>(
                            std::chrono::system_clock::now().time_since_epoch())
                            .count();
    for (lighthouse::BaseStationPlacement& b : setup)
        if (b.solved_unix_s == 0 && b.residual_rms_rad > 0) b.solved_unix_s = now;
    spdlog::info("{} base station(s) placed in the tracker; setup written to {}", setup.size(),
                 cfg_.base_stations.string());
    setup_writer_->post(cfg_.base_stations, lighthouse::base_station_setup_json(setup));
    setup_stored_ = setup.size();
}

// Every status window: log it, write the status file when one is configured, start anew (so the
// window never grows, with or without a status file).
void Daemon::status_window() {
    store_placed_setup();
    const Percentiles p = percentiles(lat_);
    last_window_ = status_json(p);
    // The status file is written on a thread of its own (a stalled disk never costs a vsync); one
    // that cannot be written does not stop the loop (said once when it starts failing, once when
    // it works again).
    if (!cfg_.status_path.empty()) {
        if (!status_writer_) status_writer_.emplace(cfg_.status_every_s);
        status_writer_->post(
            cfg_.status_path,
            last_window_.dump(1, ' ', false, nlohmann::json::error_handler_t::replace));
    }
    notifier_.notify(fmt::format(
        "STATUS=frames {}, on time {}, MTP p50 {:.1f} ms p99 {:.1f} ms, render p50 {:.1f} ms, "
        "errors {}{}",
        frames_,
        window_vsyncs_
            ? fmt::format("{:.1f}%", 100.0 * double(window_on_time_) / double(window_vsyncs_))
            : std::string("n/a"),
        p.p50, p.p99, percentiles(render_ms_).p50, errors_,
        node_->runtime().has_pose() ? "" : ", no pose yet"));
    if (window_vsyncs_)
        spdlog::info(
            "frames {} vsyncs on time {:.1f}% ({} missed, {} re-warped) latency p50 {:.1f} ms p99 "
            "{:.1f} ms",
            frames_, 100.0 * double(window_on_time_) / double(window_vsyncs_),
            window_vsyncs_ - window_on_time_, window_rewarps_, p.p50, p.p99);
    lat_.clear();
    render_ms_.clear();
    warp_ms_.clear();
    window_frames_ = window_on_time_ = window_vsyncs_ = window_late_ = window_rewarps_ = 0;
    window_new_frames_ = window_gaze_frames_ = 0;
    next_status_ = node_->clock().now_ns() + s_to_ns(cfg_.status_every_s);
}

// The watchdog, once ready, at most every half WatchdogSec: from the frame loop only when frames
// were presented since the last pet (needs_frames); while paused on purpose, always.
void Daemon::pet_watchdog(bool needs_frames) {
    if (!ready_ || pet_every_.count() <= 0 || WallClock::now() < next_pet_) return;
    if (!needs_frames) {
        notifier_.notify("WATCHDOG=1");
    } else if (frames_ > frames_at_pet_) {
        notifier_.notify("WATCHDOG=1");
        frames_at_pet_ = frames_;
    }
    next_pet_ = WallClock::now() + pet_every_;
}

}  // namespace hmdnode
