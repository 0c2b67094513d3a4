// hmdnoded's running node (main.cpp reads the arguments and the config, then runs it): start-up
// (the scene, the trace, the node from the one assembly place, the calibration, the control
// socket), then the frame loop with what it serves between frames -- the control commands
// (control.cpp), the SIGHUP reload (reload.cpp), the status window and systemd's readiness and
// watchdog (status.cpp). One thread: the frame loop's.
#pragma once

#include <chrono>
#include <csignal>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "daemon/config.hpp"
#include "daemon/metrics.hpp"
#include "daemon/scene_loader.hpp"
#include "daemon/sd_notify.hpp"
#include "hmdnode/core/trace.hpp"
#include "hmdnode/firmware_host/control_socket.hpp"
#include "hmdnode/firmware_host/node_assembly.hpp"
#include "hmdnode/firmware_host/replay.hpp"
#include "hmdnode/firmware_host/status_writer.hpp"

namespace hmdnode {

// The signal handlers' flags: stop (SIGINT, SIGTERM) and reload (SIGHUP, cleared when done).
struct DaemonSignals {
    volatile std::sig_atomic_t* stop = nullptr;
    volatile std::sig_atomic_t* reload = nullptr;
};

class Daemon {
  public:
    Daemon(std::filesystem::path config_path, DaemonConfig config, SystemdNotifier& notifier,
           DaemonSignals signals);

    // Everything before the first frame. Empty to go on to run(); else the exit status (2: the
    // config's fault, which the unit does not restart; 1: the world's; 0: stopped meanwhile).
    std::optional<int> start();
    // The frame loop, until a signal, max_frames or a file backend's end; the exit status.
    int run();

  private:
    using WallClock = std::chrono::steady_clock;

    // start()'s steps.
    std::optional<int> load_inputs();
    std::optional<int> assemble();
    std::optional<int> calibrate();
    void raise_priority();
    std::optional<int> open_control();

    // The frame loop's steps.
    void at_frame_boundary();
    void swap_scene(SceneLoader::Done done);
    void reload();                                                      // reload.cpp
    nlohmann::json control(const nlohmann::json& command);              // control.cpp
    nlohmann::json control_status();                                    // control.cpp
    nlohmann::json load_scene_command(const std::filesystem::path& p);  // control.cpp
    bool restart_finished_tracker();
    void note_no_pose();                                     // status.cpp
    void note_frame(const FrameRecord& record);              // status.cpp
    void status_window();                                    // status.cpp
    nlohmann::json status_json(const Percentiles& latency);  // status.cpp
    void pet_watchdog(bool needs_frames);                    // status.cpp

    // Arguments and config.
    std::filesystem::path config_path_;
    DaemonConfig cfg_;
    SystemdNotifier& notifier_;
    DaemonSignals signals_;

    // The scene running (a new one, from SIGHUP or load-scene, is read off the loop's thread and
    // swapped in at a frame boundary, the old one freed after the swap) and the trace.
    std::unique_ptr<Scene> scene_;
    std::filesystem::path scene_path_;
    std::string scene_error_;  // why the last scene that was asked for is not running
    SceneLoader loader_;
    std::shared_ptr<const Trace> trace_;  // the trace backend replays it; sim moves along it

    // The node, from the one assembly place.
    std::unique_ptr<AssembledNode> node_;
    std::string renderer_backend_;

    // systemd: readiness after the first presented frame, the watchdog from the loop's progress.
    std::chrono::microseconds pet_every_{0};
    WallClock::time_point next_pet_;
    uint64_t frames_at_pet_ = 0;
    bool ready_ = false;

    // The status window: the frames since the last status write. Honest accounting
    // (docs/latency.md): every vsync without a new or re-warped frame on time is missed; a present
    // after a gap adds the vsyncs it skipped.
    std::vector<double> lat_, render_ms_, warp_ms_;
    size_t window_frames_ = 0, window_on_time_ = 0, window_vsyncs_ = 0, window_late_ = 0,
           window_rewarps_ = 0, errors_ = 0, window_new_frames_ = 0, window_gaze_frames_ = 0;
    uint64_t frames_ = 0, no_pose_frames_ = 0;
    int64_t next_wait_log_ = 0;
    int64_t next_status_ = 0;
    FrameRecord rec_;
    std::optional<StatusWriter> status_writer_;  // started with the first status window
    // tracker.place_base_stations: the placed setup written to tracker.base_stations off the
    // loop's thread when it grows (setup_stored_: base stations posted; setup_failed_: the
    // writer's failures seen, a new one re-posts).
    void store_placed_setup();
    std::optional<StatusWriter> setup_writer_;
    size_t setup_stored_ = 0;
    uint64_t setup_failed_ = 0;

    // The control socket, served between frames (docs/daemon.md, "Control socket").
    DaemonMetrics metrics_;
    nlohmann::json last_window_;  // the last status window, as the status file has it
    bool paused_ = false;
    std::optional<bool> pending_warp_;  // set warp: applied at the next frame boundary
    std::unique_ptr<ControlServer> control_;
};

}  // namespace hmdnode
