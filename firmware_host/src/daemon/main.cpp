// hmdnoded: the node daemon. Runs the frame loop from a JSON config file (docs/daemon.md) until
// SIGINT/SIGTERM, survives failures of the world (a frame that fails to render or present is
// logged and skipped; a tracker with no sample yet -- an absent device -- renders nothing and is
// waited for between frames, so a signal still stops the daemon; the end of a replayed trace
// restarts it when `loop` is set), and writes a status JSON file periodically.
//
// Under systemd (Type=notify, docs/daemon.md "Running as a service"): READY=1 once the first frame
// is presented; WATCHDOG=1 from the frame loop itself, at most every half WatchdogSec and only when
// frames were presented since the last one (a loop stuck in the renderer, or every frame failing,
// stops it and systemd restarts the service); STATUS= with the window's figures; while waiting for
// a tracker before the first frame, EXTEND_TIMEOUT_USEC= keeps the start from timing out as long
// as the loop keeps its pace. SIGHUP reloads the config at a frame boundary (RELOADING=1); the
// control socket, when configured, is served between frames.
#include <sched.h>

#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <spdlog/spdlog.h>
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "cli/cli_checks.hpp"
#include "daemon/config.hpp"
#include "daemon/metrics.hpp"
#include "daemon/scene_loader.hpp"
#include "daemon/sd_notify.hpp"
#include "hmdnode/core/gltf.hpp"
#include "hmdnode/core/trace.hpp"
#include "hmdnode/firmware_host/control_protocol.hpp"
#include "hmdnode/firmware_host/control_socket.hpp"
#include "hmdnode/firmware_host/node.hpp"
#include "hmdnode/firmware_host/node_assembly.hpp"
#include "hmdnode/firmware_host/replay.hpp"
#include "hmdnode/firmware_host/status_writer.hpp"
#include "hmdnode/firmware_host/wiring.hpp"
#include "hmdnode/hal/sim/sim_reference_device.hpp"
#include "hmdnode/hal/tracking/device_tracker.hpp"

namespace {
volatile std::sig_atomic_t g_stop = 0;
volatile std::sig_atomic_t g_reload = 0;
void on_signal(int) {
    g_stop = 1;
}
void on_hangup(int) {
    g_reload = 1;
}
}  // namespace

int main(int argc, char** argv) {
    using namespace hmdnode;
    CLI::App app{"hmdnoded: the hmdnode rendering-node daemon"};
    std::string config_path = "/etc/hmdnode/hmdnoded.json";
    int64_t max_frames = 0;
    app.add_option("-c,--config", config_path, "Config file (JSON)");
    app.add_option("--max-frames", max_frames,
                   "Exit after this many frames (0: run until signalled)");
    cli::refuse_non_finite_numbers(app);
    // --help exits 0; a usage error exits 2 like a bad config, so the unit does not restart.
    if (std::optional<int> code = cli::parse_command_line(app, argc, argv)) return *code;
    // note: first, before any thread exists: it unsets NOTIFY_SOCKET and WATCHDOG_*.
    SystemdNotifier notifier;

    Result<DaemonConfig> cfg = load_daemon_config(config_path);
    if (!cfg.ok()) {
        spdlog::error("{}", cfg.error().message);
        return 2;
    }
    if (max_frames > 0) cfg->max_frames = max_frames;
    std::signal(SIGINT, on_signal);
    std::signal(SIGTERM, on_signal);
    std::signal(SIGHUP, on_hangup);

    Result<Scene> scene_r = load_gltf(cfg->scene);
    if (!scene_r.ok()) {
        spdlog::error("{}", scene_r.error().message);
        return 2;
    }
    // The running scene; a new one (SIGHUP, load-scene) is read off the frame loop's thread and
    // swapped in at a frame boundary, the old one freed after the swap.
    auto scene = std::make_unique<Scene>(std::move(scene_r).value());
    std::filesystem::path scene_path = cfg->scene;
    SceneLoader loader;
    for (const std::string& w : cfg->warnings) spdlog::warn("{}: {}", config_path, w);
    std::shared_ptr<const Trace> trace;  // the trace backend replays it; sim moves along it
    if (!cfg->trace.empty()) {
        Result<Trace> trace_r = read_trace_csv(cfg->trace);
        if (!trace_r.ok()) {
            spdlog::error("{}", trace_r.error().message);
            return 2;
        }
        trace = std::make_shared<const Trace>(std::move(trace_r).value());
    }

    // The one assembly place (hmdnode/firmware_host/node_assembly.hpp), named by the config's
    // keys: a device tracker (every backend but trace) reconnects by itself; a file backend
    // (trace, capture, rec) finishes and is made anew when `loop` is set, with the eye tracker
    // (none: LOD eccentricity from the lens centre) so that the two replay the trace on one
    // timeline. Pixels come back to the CPU by the one read-back rule.
    NodePart failed_part = NodePart::start;
    Result<std::unique_ptr<AssembledNode>> assembled =
        make_node(node_spec(*cfg, trace), *scene, &failed_part);
    if (!assembled.ok()) {
        // From the runtime's start on a failure is the world's (the renderer or the device), not
        // the config's: exit 1, which the unit restarts (2, a bad config, it does not).
        switch (failed_part) {
            case NodePart::tracker:
                spdlog::error("tracker.backend {}: {}", tracker_backend_name(cfg->tracker_backend),
                              assembled.error().message);
                return 2;
            case NodePart::start:
                spdlog::error("{}", assembled.error().message);
                return 1;
            case NodePart::eye_tracker_start:
                spdlog::error("eye tracker: {}", assembled.error().message);
                return 2;
            default:
                spdlog::error("{}", assembled.error().message);
                return 2;
        }
    }
    AssembledNode& parts = **assembled;
    Clock* clock = &parts.clock();
    NodeRuntime& node = parts.runtime();
    // The panel: the mock's figures, or the connector mode's (kms).
    const DisplayInfo panel = parts.display().info();
    std::string scene_error;  // why the last scene that was asked for is not running
    // This renderer's costs seed the pacing estimates (and are the simulated clock's model). About
    // 50 renders and warps: seconds on a slow renderer, so SIGTERM is seen between two, and while
    // they progress systemd's start timeout is extended (a start that hangs still times out).
    int calibration_steps = 0;
    auto calibrating = [&, next_extend = std::chrono::steady_clock::now()]() mutable {
        if (g_stop) return false;
        ++calibration_steps;
        if (const auto now = std::chrono::steady_clock::now(); now >= next_extend) {
            notifier.notify(fmt::format(
                "EXTEND_TIMEOUT_USEC=60000000\nSTATUS=calibrating the frame cost ({} renders)",
                calibration_steps));
            next_extend = now + std::chrono::seconds(5);
        }
        return true;
    };
    if (Result<FrameCostModel> m = node.calibrate_frame_cost(calibrating); m.ok()) {
        if (clock->is_simulated()) node.set_sim_cost(*m);
        spdlog::info("frame cost: render {:.2f} ms + {:.3f} ms per 1k triangles, warp {:.2f} ms",
                     ns_to_ms(m->base_ns), m->per_triangle_ns * 1e-3, ns_to_ms(m->warp_ns));
        const NodeRuntime::PassTimes& pt = node.pass_times();
        spdlog::info("lens pass {} (fused {:.2f} ms, mesh {:.2f} ms, floor {:.2f} ms)",
                     node.lens_pass(), pt.fused_ms, pt.mesh_ms, pt.floor_ms);
    } else if (g_stop) {
        spdlog::info("hmdnoded: stopped during the start-up calibration");
        return 0;
    } else {
        spdlog::error("{}", m.error().message);
        return 1;
    }
    spdlog::info(
        "hmdnoded: scene {} ({} objects), tracker {}: {} ({} trace samples), display {} {}x{} per "
        "eye at {} Hz, renderer {} ({}, {}x MSAA)",
        cfg->scene.string(), node.objects().size(), tracker_backend_name(cfg->tracker_backend),
        parts.tracker_label(), trace ? trace->samples.size() : 0, cfg->display_type,
        panel.eye_width, panel.eye_height, panel.refresh_hz, parts.renderer().device_name(),
        parts.renderer().backend_name(), parts.renderer().msaa_samples());
    const std::string renderer_backend = parts.renderer().backend_name();

    // The frame loop's thread only (this one): the renderer's worker threads exist already and
    // keep the default policy; threads created from here on start with it (reset on fork).
    if (cfg->realtime_priority > 0) {
        sched_param sp{};
        sp.sched_priority = cfg->realtime_priority;
        if (sched_setscheduler(0, SCHED_FIFO | SCHED_RESET_ON_FORK, &sp) == 0)
            spdlog::info("frame loop thread: SCHED_FIFO priority {}", cfg->realtime_priority);
        else
            spdlog::warn(
                "frame loop thread: SCHED_FIFO priority {} refused ({}); running at the "
                "default policy (the unit's LimitRTPRIO= allows it)",
                cfg->realtime_priority, std::strerror(errno));
    }
    // systemd: readiness after the first presented frame, the watchdog from the loop's progress.
    using WallClock = std::chrono::steady_clock;
    const auto pet_every = std::chrono::microseconds(notifier.watchdog_usec() / 2);
    auto next_pet = WallClock::now() + pet_every;
    uint64_t frames_at_pet = 0;
    bool ready = false;

    // Status window: the frames since the last status write.
    std::vector<double> lat, reg, render_ms, warp_ms;
    // Honest accounting (docs/latency.md): every vsync without a new or re-warped frame on time is
    // missed; a present after a gap adds the vsyncs it skipped.
    size_t window_frames = 0, window_on_time = 0, window_vsyncs = 0, window_late = 0,
           window_rewarps = 0, errors = 0, window_new_frames = 0, window_gaze_frames = 0;
    uint64_t frames = 0, no_pose_frames = 0;
    // Until the tracker's first sample each frame renders nothing (run_frame returns at once, so
    // SIGTERM is seen between frames); say so every 5 s.
    int64_t next_wait_log = clock->now_ns();
    int64_t next_status = clock->now_ns() + s_to_ns(cfg->status_every_s);
    // The status window's latencies: reserved once, so the frame loop does not allocate.
    for (std::vector<double>* v : {&lat, &render_ms, &warp_ms})
        v->reserve(size_t(cfg->status_every_s * panel.refresh_hz * 2.0) + 16);
    FrameRecord rec;
    std::optional<StatusWriter> status_writer;  // started with the first status window

    // The control socket, served between frames (docs/daemon.md, "Control socket").
    DaemonMetrics metrics;
    metrics.last_levels.reserve(node.objects().size());
    nlohmann::json last_window;  // the last status window, as the status file has it
    bool paused = false;
    std::optional<bool> pending_warp;  // set warp: applied at the next frame boundary
    std::unique_ptr<ControlServer> control;
    if (!cfg->control_path.empty()) {
        auto handler = [&](const nlohmann::json& c) -> nlohmann::json {
            using Kind = ControlCommand::Kind;
            Result<ControlCommand> cmd = parse_control_command(c);
            if (!cmd.ok()) return {{"ok", false}, {"error", cmd.error().message}};
            // A numeric setting's reply, once the node has taken (or refused) it.
            auto setting = [](const char* key, double value, const Status& st) -> nlohmann::json {
                if (!st.ok()) return {{"ok", false}, {"error", st.error().message}};
                spdlog::info("control: set {} {}", key, value);
                return {{"ok", true}, {"key", key}, {"value", value}};
            };
            switch (cmd->kind) {
                case Kind::status:
                    return {{"ok", true},
                            {"frames", frames},
                            {"errors", errors},
                            {"ready", ready},
                            {"paused", paused},
                            {"has_pose", node.has_pose()},
                            {"predict", node.config().predict},
                            {"prediction_ms", node.prediction_offset_ms()},
                            {"warp", pending_warp.value_or(node.config().warp)},
                            {"lod_tolerance_px", node.config().lod.tolerance_px},
                            {"lod_bias", node.lod_bias()},
                            {"scene", scene_path.string()},
                            {"objects", node.objects().size()},
                            {"scene_loading", loader.busy()},
                            {"scene_error", scene_error},
                            {"renderer_backend", renderer_backend},
                            {"window", last_window}};
                case Kind::metrics: {
                    std::optional<DeviceTrackerStatus> ts;
                    if (DeviceTracker* dt = parts.device_tracker()) ts = dt->status();
                    return {{"ok", true}, {"metrics", metrics.prometheus(ts ? &*ts : nullptr)}};
                }
                case Kind::pause:
                case Kind::resume:
                    paused = cmd->kind == Kind::pause;
                    spdlog::info("control: {}", paused ? "pause" : "resume");
                    return {{"ok", true}, {"paused", paused}};
                case Kind::set_predict:
                    node.set_predict(cmd->predict);
                    spdlog::info("control: set predict {}", cmd->predict);
                    return {{"ok", true}, {"key", "predict"}, {"value", cmd->predict}};
                case Kind::recentre:
                    if (Status st = node.recentre(); !st.ok())
                        return {{"ok", false}, {"error", st.error().message}};
                    spdlog::info("control: recentre");
                    return {{"ok", true}};
                case Kind::load_scene: {
                    std::filesystem::path p = cmd->path;
                    if (p.is_relative()) p = std::filesystem::path(config_path).parent_path() / p;
                    if (std::error_code ec; !std::filesystem::is_regular_file(p, ec))
                        return {{"ok", false},
                                {"error", "load-scene: " + p.string() + ": no such file"}};
                    if (loader.busy())
                        return {{"ok", false}, {"error", "load-scene: a scene is loading already"}};
                    loader.start(p);
                    spdlog::info("control: load-scene {}", p.string());
                    return {{"ok", true}, {"loading", p.string()}};
                }
                case Kind::set_warp:
                    pending_warp = cmd->warp;  // at the next frame boundary
                    spdlog::info("control: set warp {}", cmd->warp);
                    return {{"ok", true}, {"key", "warp"}, {"value", cmd->warp}};
                case Kind::set_prediction_ms:
                    return setting("prediction_ms", cmd->prediction_ms,
                                   node.set_prediction_offset_ms(cmd->prediction_ms));
                case Kind::set_lod_bias:
                    return setting("lod_bias", cmd->lod_bias, node.set_lod_bias(cmd->lod_bias));
                case Kind::set_lod_tolerance_px:
                    return setting("lod_tolerance_px", cmd->lod_tolerance_px,
                                   node.set_lod_tolerance_px(cmd->lod_tolerance_px));
            }
            return {{"ok", false}, {"error", "unhandled command"}};
        };
        Result<std::unique_ptr<ControlServer>> cs = ControlServer::open(cfg->control_path, handler);
        if (!cs.ok()) {
            spdlog::error("{}", cs.error().message);
            return 2;
        }
        control = std::move(*cs);
        spdlog::info("control socket: {}", cfg->control_path.string());
    }

    while (!g_stop && (cfg->max_frames <= 0 || int64_t(frames) < cfg->max_frames)) {
        if (control) control->serve();
        // A frame boundary (no frame half rendered): what changes the eye buffers applies here.
        if (node.between_frames()) {
            if (pending_warp) {
                if (Status st = node.set_warp(*pending_warp); !st.ok())
                    spdlog::error("set warp {}: {}", *pending_warp, st.error().message);
                pending_warp.reset();
            }
            if (std::optional<SceneLoader::Done> done = loader.take()) {
                if (!done->scene.ok()) {
                    scene_error = done->scene.error().message;
                    spdlog::error("{}; keeping the running scene {}", scene_error,
                                  scene_path.string());
                } else {
                    auto next = std::make_unique<Scene>(std::move(done->scene).value());
                    if (Status st = node.replace_scene(*next); !st.ok()) {
                        scene_error = st.error().message;
                        spdlog::error("scene {}: {}; keeping the running scene {}",
                                      done->path.string(), scene_error, scene_path.string());
                    } else {
                        scene = std::move(next);  // the old one is freed: nothing refers to it
                        scene_path = done->path;
                        scene_error.clear();
                        metrics.last_levels.clear();
                        metrics.last_levels.reserve(node.objects().size());
                        spdlog::info("scene swapped: {} ({} objects)", scene_path.string(),
                                     node.objects().size());
                    }
                }
            }
        }
        if (g_reload) {
            // SIGHUP, at a frame boundary: the new config is read and checked whole; a bad one
            // keeps the running config. What can change without a restart is applied.
            g_reload = 0;
            notifier.notify("RELOADING=1");
            Result<DaemonConfig> next = load_daemon_config(config_path);
            if (!next.ok()) {
                spdlog::error("reload: {}; keeping the running config", next.error().message);
            } else {
                node.set_predict(next->node.predict);
                (void)node.set_lod_tolerance_px(next->node.lod.tolerance_px);  // checked: >= 0
                // Checked by the config reader (in range, finite).
                (void)node.set_prediction_offset_ms(next->node.prediction_offset_ms);
                (void)node.set_lod_bias(next->node.lod_bias);
                cfg->status_path = next->status_path;
                cfg->status_every_s = next->status_every_s;
                std::string restart;
                auto needs_restart = [&restart](const char* what) {
                    restart += (restart.empty() ? "" : ", ") + std::string(what);
                };
                // The scene is read again (the file may have been replaced under the same name)
                // off the loop, and swapped in at a frame boundary; a bad one keeps the running.
                std::string scene_note;
                if (loader.busy()) {
                    scene_note = "; a scene is loading already, the scene is not read again";
                } else {
                    loader.start(next->scene);
                    scene_note = "; reading the scene " + next->scene.string();
                }
                cfg->scene = next->scene;
                if (next->renderer_backend != cfg->renderer_backend) needs_restart("renderer");
                if (next->simulated_clock != cfg->simulated_clock) needs_restart("clock");
                if (next->tracker_backend != cfg->tracker_backend || next->trace != cfg->trace ||
                    next->from != cfg->from || next->device != cfg->device ||
                    next->start_s != cfg->start_s)
                    needs_restart("tracker");
                if (next->display_type != cfg->display_type ||
                    next->display.eye_width != cfg->display.eye_width ||
                    next->display.eye_height != cfg->display.eye_height ||
                    next->display.refresh_hz != cfg->display.refresh_hz ||
                    next->kms.device != cfg->kms.device ||
                    next->kms.connector != cfg->kms.connector || next->kms.mode != cfg->kms.mode ||
                    next->msaa_samples != cfg->msaa_samples)
                    needs_restart("display");
                if (next->node.warp != cfg->node.warp ||
                    next->node.distortion != cfg->node.distortion)
                    needs_restart("node.warp/distortion");
                if (next->node.lod_allocator != cfg->node.lod_allocator)
                    needs_restart("node.lod_allocator");
                if (next->node.lod_fade_frames != cfg->node.lod_fade_frames)
                    needs_restart("node.lod_fade_frames");
                if (next->control_path != cfg->control_path) needs_restart("control");
                spdlog::info(
                    "reload: applied predict, prediction_ms, lod_tolerance_px, lod_bias, "
                    "status{}{}{}",
                    scene_note, restart.empty() ? "" : "; needs a restart to change: ", restart);
            }
            notifier.notify(ready ? "READY=1" : "STATUS=reloaded, waiting for the first frame");
        }
        if (paused) {
            // Paused on purpose: the loop is alive, so the watchdog is petted; no frame is made.
            clock->sleep_until_ns(clock->now_ns() + parts.display().info().period_ns);
            if (ready && pet_every.count() > 0 && WallClock::now() >= next_pet) {
                notifier.notify("WATCHDOG=1");
                next_pet = WallClock::now() + pet_every;
            }
            continue;
        }
        if (node.tracker_finished()) {
            if (!cfg->loop) {
                spdlog::info("{} finished", parts.tracker_label());
                break;
            }
            NodePart failed = NodePart::tracker;
            if (Status st = parts.restart_trackers(&failed); !st.ok()) {
                if (failed == NodePart::tracker || failed == NodePart::start)
                    spdlog::error("cannot restart {}; stopping", parts.tracker_label());
                else
                    spdlog::error("cannot restart the eye tracker; stopping");
                break;
            }
            spdlog::info("{} restarted", parts.tracker_label());
        }
        Result<FrameOutcome> fr = parts.run_frame(&rec);
        if (!fr.ok()) {
            // A failure of the world: log it, count it, keep running.
            ++errors;
            ++metrics.errors;
            spdlog::warn("frame {} failed: {}", frames, fr.error().message);
            clock->sleep_until_ns(clock->now_ns() + parts.display().info().period_ns);
            continue;
        }
        if (*fr == FrameOutcome::no_pose_yet) {
            ++no_pose_frames;
            ++metrics.no_pose_frames;
            if (clock->now_ns() >= next_wait_log) {
                std::string last_error;
                if (DeviceTracker* dt = parts.device_tracker())
                    last_error = dt->status().last_error;
                spdlog::info("waiting for tracker {}{}{}", parts.tracker_label(),
                             last_error.empty() ? "" : ": ", last_error);
                next_wait_log = clock->now_ns() + 5 * kNsPerSecond;
                // The loop keeps its pace without a pose: not a hung start.
                if (!ready)
                    notifier.notify("EXTEND_TIMEOUT_USEC=15000000\nSTATUS=waiting for tracker " +
                                    std::string(tracker_backend_name(cfg->tracker_backend)) + " (" +
                                    parts.tracker_label() + ")" +
                                    (last_error.empty() ? "" : ": " + last_error));
            }
        } else {
            ++frames;
            metrics.add_frame(rec, frames == 1);
            if (!ready) {
                ready = true;
                notifier.notify("READY=1\nSTATUS=running: first frame presented");
                spdlog::info("ready: first frame presented");
            }
            ++window_frames;
            window_on_time += rec.on_time;
            window_vsyncs += 1 + size_t(window_frames > 1 ? rec.missed_vsyncs_before : 0);
            window_late += rec.late;
            window_rewarps += rec.kind == FrameKind::rewarp;
            if (rec.kind == FrameKind::new_frame) {
                ++window_new_frames;
                window_gaze_frames += rec.gaze_source == GazeSource::eye_tracker;
            }
            lat.push_back(rec.latency_ms);
            if (rec.kind == FrameKind::new_frame) render_ms.push_back(rec.render_ms);
            warp_ms.push_back(rec.warp_ms);
        }
        // Every status window: log it, write the status file when one is configured, start anew
        // (so the window never grows, with or without a status file).
        if (clock->now_ns() >= next_status) {
            // A window without frames (no pose yet) has no rate or latencies: null.
            Percentiles p = percentiles(lat);
            nlohmann::json s = {
                {"time_unix_s",
                 std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch())
                     .count()},
                {"frames", frames},
                {"errors", errors},
                {"has_pose", node.has_pose()},
                {"no_pose_frames", no_pose_frames},
                {"window_frames", window_frames},
                {"window_vsyncs", window_vsyncs},
                {"missed_vsyncs", window_vsyncs - window_on_time},
                {"late_frames", window_late},
                {"rewarps", window_rewarps},
                {"eye_tracker", eye_tracker_backend_name(cfg->eye_tracker)},
                // LOD eccentricity measured from: "eye_tracker" (every new frame of the window),
                // "lens_centre" (none), "mixed"; the count of new frames that used the gaze.
                {"gaze_source", window_gaze_frames == 0                   ? "lens_centre"
                                : window_gaze_frames == window_new_frames ? "eye_tracker"
                                                                          : "mixed"},
                {"gaze_frames", window_gaze_frames},
                {"on_time_rate",
                 window_vsyncs ? nlohmann::json(double(window_on_time) / double(window_vsyncs))
                               : nlohmann::json()},
                {"latency_ms", percentiles_json(p)},
                {"render_ms", percentiles_json(percentiles(render_ms))},
                {"warp_ms", percentiles_json(percentiles(warp_ms))},
                {"triangles", metrics.triangles},
                {"lod_switches", metrics.lod_switches},
                {"renderer_backend", renderer_backend},
                {"lod_pops", metrics.lod_pops},
                {"lod_pops_per_min", metrics.lod_pops_per_min()},
                // The lens pass, and the pixel-cost ladder and render rate of the last present
                // (docs/latency.md); presents per step and per rate since the start.
                {"lens_pass", node.lens_pass()},
                {"ladder_step", node.ladder().steps()[size_t(metrics.ladder_step)].name},
                {"render_scale", metrics.render_scale},
                {"render_rate_divisor", metrics.render_divisor}};
            if (DeviceTracker* dt = parts.device_tracker()) {
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
            last_window = s;
            // The status file is written on a thread of its own (a stalled disk never costs a
            // vsync); one that cannot be written does not stop the loop (said once when it starts
            // failing, once when it works again).
            if (!cfg->status_path.empty()) {
                if (!status_writer) status_writer.emplace(cfg->status_every_s);
                status_writer->post(
                    cfg->status_path,
                    s.dump(1, ' ', false, nlohmann::json::error_handler_t::replace));
            }
            notifier.notify(fmt::format(
                "STATUS=frames {}, on time {}, MTP p50 {:.1f} ms p99 {:.1f} ms, render p50 {:.1f} "
                "ms, errors {}{}",
                frames,
                window_vsyncs
                    ? fmt::format("{:.1f}%", 100.0 * double(window_on_time) / double(window_vsyncs))
                    : std::string("n/a"),
                p.p50, p.p99, percentiles(render_ms).p50, errors,
                node.has_pose() ? "" : ", no pose yet"));
            if (window_vsyncs)
                spdlog::info(
                    "frames {} vsyncs on time {:.1f}% ({} missed, {} re-warped) latency p50 {:.1f} "
                    "ms p99 {:.1f} ms",
                    frames, 100.0 * double(window_on_time) / double(window_vsyncs),
                    window_vsyncs - window_on_time, window_rewarps, p.p50, p.p99);
            lat.clear();
            render_ms.clear();
            warp_ms.clear();
            window_frames = window_on_time = window_vsyncs = window_late = window_rewarps = 0;
            window_new_frames = window_gaze_frames = 0;
            next_status = clock->now_ns() + s_to_ns(cfg->status_every_s);
        }
        // The watchdog: only when frames were presented since the last pet.
        if (ready && pet_every.count() > 0 && WallClock::now() >= next_pet) {
            if (frames > frames_at_pet) {
                notifier.notify("WATCHDOG=1");
                frames_at_pet = frames;
            }
            next_pet = WallClock::now() + pet_every;
        }
    }
    notifier.notify("STOPPING=1");
    node.stop();
    spdlog::info("hmdnoded: stopped after {} frames ({} failed)", frames, errors);
    return 0;
}
