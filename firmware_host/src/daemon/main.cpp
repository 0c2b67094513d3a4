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
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <spdlog/spdlog.h>
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "daemon/config.hpp"
#include "daemon/metrics.hpp"
#include "daemon/sd_notify.hpp"
#include "hmdnode/core/atomic_file.hpp"
#include "hmdnode/core/gltf.hpp"
#include "hmdnode/core/trace.hpp"
#include "hmdnode/firmware_host/control_protocol.hpp"
#include "hmdnode/firmware_host/control_socket.hpp"
#include "hmdnode/firmware_host/node.hpp"
#include "hmdnode/firmware_host/replay.hpp"
#include "hmdnode/hal/sim/sim_reference_device.hpp"
#include "hmdnode/hal/tracking/device_tracker.hpp"
#include "tool/cli_checks.hpp"

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
    tool::refuse_non_finite_numbers(app);
    // --help exits 0; a usage error exits 2 like a bad config, so the unit does not restart.
    if (std::optional<int> code = tool::parse_command_line(app, argc, argv)) return *code;
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

    Result<Scene> scene = load_gltf(cfg->scene);
    if (!scene.ok()) {
        spdlog::error("{}", scene.error().message);
        return 2;
    }
    std::shared_ptr<const Trace> trace;  // sim-trace replays it; sim-device moves along it
    if (!cfg->trace.empty()) {
        Result<Trace> trace_r = read_trace_csv(cfg->trace);
        if (!trace_r.ok()) {
            spdlog::error("{}", trace_r.error().message);
            return 2;
        }
        trace = std::make_shared<const Trace>(std::move(trace_r).value());
    }

    std::unique_ptr<Clock> clock;
    if (cfg->simulated_clock)
        clock = std::make_unique<SimulatedClock>(0);
    else
        clock = std::make_unique<SystemClock>();

    // A device tracker (hidapi, libusb, sim-device) reconnects by itself and never finishes.
    DeviceTracker* device_tracker = nullptr;
    auto make_tracker = [&]() -> Result<std::unique_ptr<Tracker>> {
        if (cfg->tracker_backend == "sim-trace") {
            SimTrackerConfig tc = cfg->tracker;
            tc.host_start_ns = clock->now_ns();
            return create_sim_tracker(trace, *clock, tc);
        }
        std::unique_ptr<TransportBackend> backend;
        if (cfg->tracker_backend == "sim-device") {
            SimReferenceDeviceConfig sc;
            sc.vendor_id = cfg->tracker_device.vendor_id;
            sc.product_id = cfg->tracker_device.product_id;
            if (!cfg->tracker_device.serial.empty()) sc.serial = cfg->tracker_device.serial;
            backend = create_sim_reference_backend(
                *clock, sc,
                trace ? motion_from_trace(trace, clock->now_ns()) : sinusoidal_motion());
        } else {
            auto b = create_transport_backend(cfg->tracker_backend);
            if (!b.ok()) return b.error();
            backend = std::move(*b);
        }
        DeviceTrackerConfig tc;
        tc.filter = cfg->tracker_device;
        auto t = create_device_tracker(
            std::move(backend),
            make_codec_for(cfg->tracker_device.vendor_id, cfg->tracker_device.product_id), *clock,
            tc);
        if (!t.ok()) return t.error();
        device_tracker = t->get();
        return std::unique_ptr<Tracker>(std::move(*t));
    };
    Result<std::unique_ptr<Tracker>> tracker = make_tracker();
    if (!tracker.ok()) {
        spdlog::error("tracker {}: {}", cfg->tracker_backend, tracker.error().message);
        return 2;
    }
    MockDisplayConfig dc = cfg->display;
    dc.vsync_epoch_ns = clock->now_ns();
    Result<std::unique_ptr<Display>> display = create_mock_display(*clock, dc);
    if (!display.ok()) {
        spdlog::error("{}", display.error().message);
        return 2;
    }
    RendererConfig rc;
    rc.eye_width = dc.eye_width;
    rc.eye_height = dc.eye_height;
    rc.backend = cfg->renderer_backend;
    Result<std::unique_ptr<Renderer>> renderer = create_renderer(rc);
    if (!renderer.ok()) {
        spdlog::error("{}", renderer.error().message);
        return 2;
    }
    // Pixels come back to the CPU only for the frames the mock display writes.
    NodeConfig nc = cfg->node;
    nc.read_back = nc.read_back && !dc.frames_dir.empty();
    NodeRuntime node(*clock, **tracker, **display, **renderer, *scene, nc);
    if (Status st = node.start(); !st.ok()) {
        spdlog::error("{}", st.error().message);
        return 2;
    }
    // This renderer's costs seed the pacing estimates (and are the simulated clock's model).
    if (Result<FrameCostModel> m = node.calibrate_frame_cost(); m.ok()) {
        if (clock->is_simulated()) node.set_sim_cost(*m);
        spdlog::info("frame cost: render {:.2f} ms + {:.3f} ms per 1k triangles, warp {:.2f} ms",
                     ns_to_ms(m->base_ns), m->per_triangle_ns * 1e-3, ns_to_ms(m->warp_ns));
    } else {
        spdlog::error("{}", m.error().message);
        return 2;
    }
    spdlog::info(
        "hmdnoded: scene {} ({} objects), tracker {} {} ({} trace samples), {}x{} per eye at {} "
        "Hz, renderer {} ({})",
        cfg->scene.string(), node.objects().size(), cfg->tracker_backend,
        cfg->tracker_backend == "sim-trace"
            ? cfg->trace.string()
            : format_vid_pid(cfg->tracker_device.vendor_id, cfg->tracker_device.product_id),
        trace ? trace->samples.size() : 0, dc.eye_width, dc.eye_height, dc.refresh_hz,
        (*renderer)->device_name(), (*renderer)->backend_name());
    const std::string renderer_backend = (*renderer)->backend_name();

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
           window_rewarps = 0, errors = 0;
    uint64_t frames = 0, no_pose_frames = 0;
    // Until the tracker's first sample each frame renders nothing (run_frame returns at once, so
    // SIGTERM is seen between frames); say so every 5 s.
    int64_t next_wait_log = clock->now_ns();
    int64_t next_status = clock->now_ns() + s_to_ns(cfg->status_every_s);
    // The status window's latencies: reserved once, so the frame loop does not allocate.
    for (std::vector<double>* v : {&lat, &render_ms, &warp_ms})
        v->reserve(size_t(cfg->status_every_s * dc.refresh_hz * 2.0) + 16);
    FrameRecord rec;
    bool status_failing = false;  // the last status write failed (said once)

    // The control socket, served between frames (docs/daemon.md, "Control socket").
    DaemonMetrics metrics;
    metrics.last_levels.reserve(node.objects().size());
    nlohmann::json last_window;  // the last status window, as the status file has it
    bool paused = false;
    std::unique_ptr<ControlServer> control;
    if (!cfg->control_path.empty()) {
        auto handler = [&](const nlohmann::json& c) -> nlohmann::json {
            using Kind = ControlCommand::Kind;
            Result<ControlCommand> cmd = parse_control_command(c);
            if (!cmd.ok()) return {{"ok", false}, {"error", cmd.error().message}};
            switch (cmd->kind) {
                case Kind::status:
                    return {{"ok", true},
                            {"frames", frames},
                            {"errors", errors},
                            {"ready", ready},
                            {"paused", paused},
                            {"has_pose", node.has_pose()},
                            {"predict", node.config().predict},
                            {"lod_tolerance_px", node.config().lod.tolerance_px},
                            {"renderer_backend", renderer_backend},
                            {"window", last_window}};
                case Kind::metrics: {
                    std::optional<DeviceTrackerStatus> ts;
                    if (device_tracker) ts = device_tracker->status();
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
                case Kind::set_lod_tolerance_px:
                    if (Status st = node.set_lod_tolerance_px(cmd->lod_tolerance_px); !st.ok())
                        return {{"ok", false}, {"error", st.error().message}};
                    spdlog::info("control: set lod_tolerance_px {}", cmd->lod_tolerance_px);
                    return {{"ok", true},
                            {"key", "lod_tolerance_px"},
                            {"value", cmd->lod_tolerance_px}};
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
                cfg->status_path = next->status_path;
                cfg->status_every_s = next->status_every_s;
                std::string restart;
                auto needs_restart = [&restart](const char* what) {
                    restart += (restart.empty() ? "" : ", ") + std::string(what);
                };
                if (next->scene != cfg->scene) needs_restart("scene");
                if (next->renderer_backend != cfg->renderer_backend) needs_restart("renderer");
                if (next->simulated_clock != cfg->simulated_clock) needs_restart("clock");
                if (next->tracker_backend != cfg->tracker_backend || next->trace != cfg->trace ||
                    !(next->tracker_device.vendor_id == cfg->tracker_device.vendor_id &&
                      next->tracker_device.product_id == cfg->tracker_device.product_id &&
                      next->tracker_device.serial == cfg->tracker_device.serial))
                    needs_restart("tracker");
                if (next->display.eye_width != cfg->display.eye_width ||
                    next->display.eye_height != cfg->display.eye_height ||
                    next->display.refresh_hz != cfg->display.refresh_hz)
                    needs_restart("display");
                if (next->node.warp != cfg->node.warp ||
                    next->node.distortion != cfg->node.distortion)
                    needs_restart("node.warp/distortion");
                if (next->node.lod_allocator != cfg->node.lod_allocator)
                    needs_restart("node.lod_allocator");
                if (next->control_path != cfg->control_path) needs_restart("control");
                spdlog::info("reload: applied predict, lod_tolerance_px, status{}{}",
                             restart.empty() ? "" : "; needs a restart to change: ", restart);
            }
            notifier.notify(ready ? "READY=1" : "STATUS=reloaded, waiting for the first frame");
        }
        if (paused) {
            // Paused on purpose: the loop is alive, so the watchdog is petted; no frame is made.
            clock->sleep_until_ns(clock->now_ns() + (*display)->info().period_ns);
            if (ready && pet_every.count() > 0 && WallClock::now() >= next_pet) {
                notifier.notify("WATCHDOG=1");
                next_pet = WallClock::now() + pet_every;
            }
            continue;
        }
        if (node.tracker_finished()) {
            if (!cfg->loop) {
                spdlog::info("trace finished");
                break;
            }
            Result<std::unique_ptr<Tracker>> next = make_tracker();
            if (!next.ok() || !node.replace_tracker(**next).ok()) {
                spdlog::error("cannot restart the trace replay; stopping");
                break;
            }
            tracker = std::move(next);
            spdlog::info("trace restarted");
        }
        Result<FrameOutcome> fr = node.run_frame(&rec, nullptr);
        if (!fr.ok()) {
            // A failure of the world: log it, count it, keep running.
            ++errors;
            ++metrics.errors;
            spdlog::warn("frame {} failed: {}", frames, fr.error().message);
            clock->sleep_until_ns(clock->now_ns() + (*display)->info().period_ns);
            continue;
        }
        if (*fr == FrameOutcome::no_pose_yet) {
            ++no_pose_frames;
            ++metrics.no_pose_frames;
            if (clock->now_ns() >= next_wait_log) {
                std::string last_error;
                if (device_tracker) last_error = device_tracker->status().last_error;
                spdlog::info("waiting for tracker {} via {}{}{}",
                             cfg->tracker_backend == "sim-trace"
                                 ? cfg->trace.string()
                                 : format_vid_pid(cfg->tracker_device.vendor_id,
                                                  cfg->tracker_device.product_id),
                             cfg->tracker_backend, last_error.empty() ? "" : ": ", last_error);
                next_wait_log = clock->now_ns() + 5 * kNsPerSecond;
                // The loop keeps its pace without a pose: not a hung start.
                if (!ready)
                    notifier.notify("EXTEND_TIMEOUT_USEC=15000000\nSTATUS=waiting for tracker " +
                                    cfg->tracker_backend +
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
                {"on_time_rate",
                 window_vsyncs ? nlohmann::json(double(window_on_time) / double(window_vsyncs))
                               : nlohmann::json()},
                {"latency_ms", percentiles_json(p)},
                {"render_ms", percentiles_json(percentiles(render_ms))},
                {"warp_ms", percentiles_json(percentiles(warp_ms))},
                {"triangles", metrics.triangles},
                {"lod_switches", metrics.lod_switches},
                {"renderer_backend", renderer_backend}};
            if (device_tracker) {
                // Recovery figures: a replug shows as a disconnect and the gap it left.
                const DeviceTrackerStatus ts = device_tracker->status();
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
            // A status file that cannot be written (its directory read-only, full or gone) does
            // not stop the loop: said once when it starts failing, once when it works again.
            if (!cfg->status_path.empty()) {
                const Status ws = write_file_atomically(
                    cfg->status_path,
                    s.dump(1, ' ', false, nlohmann::json::error_handler_t::replace));
                if (!ws.ok() && !status_failing)
                    spdlog::warn("status file: {}; the loop goes on, retried every {} s",
                                 ws.error().message, cfg->status_every_s);
                else if (ws.ok() && status_failing)
                    spdlog::info("status file: {} written again", cfg->status_path.string());
                status_failing = !ws.ok();
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
