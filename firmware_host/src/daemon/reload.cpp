// hmdnoded's SIGHUP reload, at a frame boundary: the new config is read and checked whole; a bad
// one keeps the running config. What can change without a restart is applied; the rest is named.
#include <string>

#include <spdlog/spdlog.h>

#include "daemon/daemon.hpp"

namespace hmdnode {
namespace {

// What differs between the running config and the next one and needs a restart to change, as a
// list ("renderer, display"); empty: nothing.
std::string needs_restart(const DaemonConfig& cfg, const DaemonConfig& next) {
    std::string restart;
    auto add = [&restart](const char* what) {
        restart += (restart.empty() ? "" : ", ") + std::string(what);
    };
    if (next.renderer_backend != cfg.renderer_backend) add("renderer");
    if (next.simulated_clock != cfg.simulated_clock) add("clock");
    if (next.tracker_backend != cfg.tracker_backend || next.trace != cfg.trace ||
        next.from != cfg.from || next.device != cfg.device || next.start_s != cfg.start_s)
        add("tracker");
    if (next.display_type != cfg.display_type || next.display.eye_width != cfg.display.eye_width ||
        next.display.eye_height != cfg.display.eye_height ||
        next.display.refresh_hz != cfg.display.refresh_hz || next.kms.device != cfg.kms.device ||
        next.kms.connector != cfg.kms.connector || next.kms.mode != cfg.kms.mode ||
        next.msaa_samples != cfg.msaa_samples)
        add("display");
    if (next.node.warp != cfg.node.warp || next.node.distortion != cfg.node.distortion)
        add("node.warp/distortion");
    if (next.node.lod_allocator != cfg.node.lod_allocator) add("node.lod_allocator");
    if (next.node.lod_fade_frames != cfg.node.lod_fade_frames) add("node.lod_fade_frames");
    if (next.control_path != cfg.control_path) add("control");
    return restart;
}

}  // namespace

void Daemon::reload() {
    *signals_.reload = 0;
    notifier_.notify("RELOADING=1");
    Result<DaemonConfig> next = load_daemon_config(config_path_);
    if (!next.ok()) {
        spdlog::error("reload: {}; keeping the running config", next.error().message);
    } else {
        NodeRuntime& node = node_->runtime();
        node.set_predict(next->node.predict);
        (void)node.set_lod_tolerance_px(next->node.lod.tolerance_px);  // checked: >= 0
        // Checked by the config reader (in range, finite).
        (void)node.set_prediction_offset_ms(next->node.prediction_offset_ms);
        (void)node.set_lod_bias(next->node.lod_bias);
        cfg_.status_path = next->status_path;
        cfg_.status_every_s = next->status_every_s;
        // The scene is read again (the file may have been replaced under the same name) off the
        // loop, and swapped in at a frame boundary; a bad one keeps the running.
        std::string scene_note;
        if (loader_.busy()) {
            scene_note = "; a scene is loading already, the scene is not read again";
        } else {
            loader_.start(next->scene);
            scene_note = "; reading the scene " + next->scene.string();
        }
        cfg_.scene = next->scene;
        const std::string restart = needs_restart(cfg_, *next);
        spdlog::info(
            "reload: applied predict, prediction_ms, lod_tolerance_px, lod_bias, status{}{}{}",
            scene_note, restart.empty() ? "" : "; needs a restart to change: ", restart);
    }
    notifier_.notify(ready_ ? "READY=1" : "STATUS=reloaded, waiting for the first frame");
}

}  // namespace hmdnode
