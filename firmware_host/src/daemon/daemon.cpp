// hmdnoded's start-up and frame loop (daemon.hpp).
#include "daemon/daemon.hpp"

#include <sched.h>

#include <cerrno>
#include <cstring>
#include <utility>

#include <spdlog/spdlog.h>

#include "hmdnode/core/gltf.hpp"
#include "hmdnode/hal/tracking/device_tracker.hpp"

namespace hmdnode {

Daemon::Daemon(std::filesystem::path config_path, DaemonConfig config, SystemdNotifier& notifier,
               DaemonSignals signals)
    : config_path_(std::move(config_path)),
      cfg_(std::move(config)),
      notifier_(notifier),
      signals_(signals) {}

std::optional<int> Daemon::start() {
    if (std::optional<int> code = load_inputs()) return code;
    if (std::optional<int> code = assemble()) return code;
    if (std::optional<int> code = calibrate()) return code;
    NodeRuntime& node = node_->runtime();
    const DisplayInfo panel = node_->display().info();  // the mock's, or the connector mode's
    Renderer& renderer = node_->renderer();
    spdlog::info(
        "hmdnoded: scene {} ({} objects), tracker {}: {} ({} trace samples), display {} {}x{} per "
        "eye at {} Hz, renderer {} ({}, {}x MSAA)",
        cfg_.scene.string(), node.objects().size(), tracker_backend_name(cfg_.tracker_backend),
        node_->tracker_label(), trace_ ? trace_->samples.size() : 0, cfg_.display_type,
        panel.eye_width, panel.eye_height, panel.refresh_hz, renderer.device_name(),
        renderer.backend_name(), renderer.msaa_samples());
    renderer_backend_ = renderer.backend_name();
    raise_priority();
    pet_every_ = std::chrono::microseconds(notifier_.watchdog_usec() / 2);
    next_pet_ = WallClock::now() + pet_every_;
    // Until the tracker's first sample each frame renders nothing (run_frame returns at once, so
    // SIGTERM is seen between frames); say so every 5 s.
    Clock& clock = node_->clock();
    next_wait_log_ = clock.now_ns();
    next_status_ = clock.now_ns() + s_to_ns(cfg_.status_every_s);
    // The status window's latencies: reserved once, so the frame loop does not allocate.
    for (std::vector<double>* v : {&lat_, &render_ms_, &warp_ms_})
        v->reserve(size_t(cfg_.status_every_s * panel.refresh_hz * 2.0) + 16);
    metrics_.last_levels.reserve(node.objects().size());
    return open_control();
}

std::optional<int> Daemon::load_inputs() {
    Result<Scene> scene = load_gltf(cfg_.scene);
    if (!scene.ok()) {
        spdlog::error("{}", scene.error().message);
        return 2;
    }
    scene_ = std::make_unique<Scene>(std::move(scene).value());
    scene_path_ = cfg_.scene;
    for (const std::string& w : cfg_.warnings) spdlog::warn("{}: {}", config_path_.string(), w);
    if (!cfg_.trace.empty()) {
        Result<Trace> trace = read_trace_csv(cfg_.trace);
        if (!trace.ok()) {
            spdlog::error("{}", trace.error().message);
            return 2;
        }
        trace_ = std::make_shared<const Trace>(std::move(trace).value());
    }
    return std::nullopt;
}

// The one assembly place (hmdnode/firmware_host/node_assembly.hpp), named by the config's keys: a
// device tracker (every backend but trace) reconnects by itself; a file backend (trace, capture,
// rec) finishes and is made anew when `loop` is set, with the eye tracker (none: LOD eccentricity
// from the lens centre) so that the two replay the trace on one timeline. Pixels come back to the
// CPU by the one read-back rule.
std::optional<int> Daemon::assemble() {
    NodePart failed = NodePart::start;
    Result<std::unique_ptr<AssembledNode>> node =
        make_node(node_spec(cfg_, trace_), *scene_, &failed);
    if (node.ok()) {
        node_ = std::move(*node);
        return std::nullopt;
    }
    // From the runtime's start on a failure is the world's (the renderer or the device), not the
    // config's: exit 1, which the unit restarts (2, a bad config, it does not).
    switch (failed) {
        case NodePart::tracker:
            spdlog::error("tracker.backend {}: {}", tracker_backend_name(cfg_.tracker_backend),
                          node.error().message);
            return 2;
        case NodePart::start:
            spdlog::error("{}", node.error().message);
            return 1;
        case NodePart::eye_tracker_start:
            spdlog::error("eye tracker: {}", node.error().message);
            return 2;
        default:
            spdlog::error("{}", node.error().message);
            return 2;
    }
}

// This renderer's costs seed the pacing estimates (and are the simulated clock's model). About 50
// renders and warps: seconds on a slow renderer, so SIGTERM is seen between two, and while they
// progress systemd's start timeout is extended (a start that hangs still times out).
std::optional<int> Daemon::calibrate() {
    NodeRuntime& node = node_->runtime();
    spdlog::info("cores kept awake: {}", node_->cpu_wake());
    int steps = 0;
    auto calibrating = [&, next_extend = WallClock::now()]() mutable {
        if (*signals_.stop) return false;
        ++steps;
        if (const auto now = WallClock::now(); now >= next_extend) {
            notifier_.notify(fmt::format(
                "EXTEND_TIMEOUT_USEC=60000000\nSTATUS=calibrating the frame cost ({} renders)",
                steps));
            next_extend = now + std::chrono::seconds(5);
        }
        return true;
    };
    Result<FrameCostModel> m = node.calibrate_frame_cost(calibrating);
    if (!m.ok()) {
        if (*signals_.stop) {
            spdlog::info("hmdnoded: stopped during the start-up calibration");
            return 0;
        }
        spdlog::error("{}", m.error().message);
        return 1;
    }
    if (node_->clock().is_simulated()) node.set_sim_cost(*m);
    spdlog::info("frame cost: render {:.2f} ms + {:.3f} ms per 1k triangles, warp {:.2f} ms",
                 ns_to_ms(m->base_ns), m->per_triangle_ns * 1e-3, ns_to_ms(m->warp_ns));
    const NodeRuntime::PassTimes& pt = node.pass_times();
    spdlog::info("lens pass {} (fused {:.2f} ms, mesh {:.2f} ms, floor {:.2f} ms)",
                 node.lens_pass(), pt.fused_ms, pt.mesh_ms, pt.floor_ms);
    return std::nullopt;
}

// The frame loop's thread only (this one): the renderer's worker threads exist already and keep
// the default policy; threads created from here on start with it (reset on fork).
void Daemon::raise_priority() {
    if (cfg_.realtime_priority <= 0) return;
    sched_param sp{};
    sp.sched_priority = cfg_.realtime_priority;
    if (sched_setscheduler(0, SCHED_FIFO | SCHED_RESET_ON_FORK, &sp) == 0)
        spdlog::info("frame loop thread: SCHED_FIFO priority {}", cfg_.realtime_priority);
    else
        spdlog::warn(
            "frame loop thread: SCHED_FIFO priority {} refused ({}); running at the default policy "
            "(the unit's LimitRTPRIO= allows it)",
            cfg_.realtime_priority, std::strerror(errno));
}

std::optional<int> Daemon::open_control() {
    if (cfg_.control_path.empty()) return std::nullopt;
    Result<std::unique_ptr<ControlServer>> cs = ControlServer::open(
        cfg_.control_path, [this](const nlohmann::json& c) { return control(c); });
    if (!cs.ok()) {
        spdlog::error("{}", cs.error().message);
        return 2;
    }
    control_ = std::move(*cs);
    spdlog::info("control socket: {}", cfg_.control_path.string());
    return std::nullopt;
}

int Daemon::run() {
    NodeRuntime& node = node_->runtime();
    Clock& clock = node_->clock();
    while (!*signals_.stop && (cfg_.max_frames <= 0 || int64_t(frames_) < cfg_.max_frames)) {
        if (control_) control_->serve();
        // A frame boundary (no frame half rendered): what changes the eye buffers applies here.
        if (node.between_frames()) at_frame_boundary();
        if (*signals_.reload) reload();
        if (paused_) {
            // Paused on purpose: the loop is alive, so the watchdog is petted; no frame is made.
            clock.sleep_until_ns(clock.now_ns() + node_->display().info().period_ns);
            pet_watchdog(/*needs_frames=*/false);
            continue;
        }
        if (node.tracker_finished() && !restart_finished_tracker()) break;
        Result<FrameOutcome> fr = node_->run_frame(&rec_);
        if (!fr.ok()) {
            // A failure of the world: log it, count it, keep running.
            ++errors_;
            ++metrics_.errors;
            spdlog::warn("frame {} failed: {}", frames_, fr.error().message);
            clock.sleep_until_ns(clock.now_ns() + node_->display().info().period_ns);
            continue;
        }
        if (*fr == FrameOutcome::no_pose_yet)
            note_no_pose();
        else
            note_frame(rec_);
        // Every status window: log it, write the status file when one is configured, start anew
        // (so the window never grows, with or without a status file).
        if (clock.now_ns() >= next_status_) status_window();
        pet_watchdog(/*needs_frames=*/true);
    }
    notifier_.notify("STOPPING=1");
    store_placed_setup();  // a placement since the last window (written as the writer closes)
    node.stop();
    spdlog::info("hmdnoded: stopped after {} frames ({} failed)", frames_, errors_);
    return 0;
}

void Daemon::at_frame_boundary() {
    if (pending_warp_) {
        if (Status st = node_->runtime().set_warp(*pending_warp_); !st.ok())
            spdlog::error("set warp {}: {}", *pending_warp_, st.error().message);
        pending_warp_.reset();
    }
    if (std::optional<SceneLoader::Done> done = loader_.take()) swap_scene(std::move(*done));
}

void Daemon::swap_scene(SceneLoader::Done done) {
    NodeRuntime& node = node_->runtime();
    if (!done.scene.ok()) {
        scene_error_ = done.scene.error().message;
        spdlog::error("{}; keeping the running scene {}", scene_error_, scene_path_.string());
        return;
    }
    auto next = std::make_unique<Scene>(std::move(done.scene).value());
    if (Status st = node.replace_scene(*next); !st.ok()) {
        scene_error_ = st.error().message;
        spdlog::error("scene {}: {}; keeping the running scene {}", done.path.string(),
                      scene_error_, scene_path_.string());
        return;
    }
    scene_ = std::move(next);  // the old one is freed: nothing refers to it
    scene_path_ = done.path;
    scene_error_.clear();
    metrics_.last_levels.clear();
    metrics_.last_levels.reserve(node.objects().size());
    spdlog::info("scene swapped: {} ({} objects)", scene_path_.string(), node.objects().size());
}

// A file backend at its end: false to stop (no `loop`, or it cannot be made anew).
bool Daemon::restart_finished_tracker() {
    if (!cfg_.loop) {
        spdlog::info("{} finished", node_->tracker_label());
        return false;
    }
    NodePart failed = NodePart::tracker;
    if (Status st = node_->restart_trackers(&failed); !st.ok()) {
        if (failed == NodePart::tracker || failed == NodePart::start)
            spdlog::error("cannot restart {}; stopping", node_->tracker_label());
        else
            spdlog::error("cannot restart the eye tracker; stopping");
        return false;
    }
    spdlog::info("{} restarted", node_->tracker_label());
    return true;
}

}  // namespace hmdnode
