// hmdnoded's control commands (docs/daemon.md, "Control socket"), served between frames on the
// frame loop's thread: each command parsed (control_protocol.hpp), applied to the running node or
// left for the next frame boundary (a scene, the warp), and answered.
#include <system_error>

#include <spdlog/spdlog.h>

#include "daemon/daemon.hpp"
#include "hmdnode/firmware_host/control_protocol.hpp"
#include "hmdnode/hal/tracking/device_tracker.hpp"

namespace hmdnode {

nlohmann::json Daemon::control(const nlohmann::json& c) {
    using Kind = ControlCommand::Kind;
    Result<ControlCommand> cmd = parse_control_command(c);
    if (!cmd.ok()) return {{"ok", false}, {"error", cmd.error().message}};
    NodeRuntime& node = node_->runtime();
    // A numeric setting's reply, once the node has taken (or refused) it.
    auto setting = [](const char* key, double value, const Status& st) -> nlohmann::json {
        if (!st.ok()) return {{"ok", false}, {"error", st.error().message}};
        spdlog::info("control: set {} {}", key, value);
        return {{"ok", true}, {"key", key}, {"value", value}};
    };
    switch (cmd->kind) {
        case Kind::status:
            return control_status();
        case Kind::metrics: {
            std::optional<DeviceTrackerStatus> ts;
            if (DeviceTracker* dt = node_->device_tracker()) ts = dt->status();
            return {{"ok", true}, {"metrics", metrics_.prometheus(ts ? &*ts : nullptr)}};
        }
        case Kind::pause:
        case Kind::resume:
            paused_ = cmd->kind == Kind::pause;
            spdlog::info("control: {}", paused_ ? "pause" : "resume");
            return {{"ok", true}, {"paused", paused_}};
        case Kind::set_predict:
            node.set_predict(cmd->predict);
            spdlog::info("control: set predict {}", cmd->predict);
            return {{"ok", true}, {"key", "predict"}, {"value", cmd->predict}};
        case Kind::recentre:
            if (Status st = node.recentre(); !st.ok())
                return {{"ok", false}, {"error", st.error().message}};
            spdlog::info("control: recentre");
            return {{"ok", true}};
        case Kind::load_scene:
            return load_scene_command(cmd->path);
        case Kind::set_warp:
            pending_warp_ = cmd->warp;  // at the next frame boundary
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
}

nlohmann::json Daemon::control_status() {
    const NodeRuntime& node = node_->runtime();
    return {{"ok", true},
            {"frames", frames_},
            {"errors", errors_},
            {"ready", ready_},
            {"paused", paused_},
            {"has_pose", node.has_pose()},
            {"predict", node.config().predict},
            {"prediction_ms", node.prediction_offset_ms()},
            {"warp", pending_warp_.value_or(node.config().warp)},
            {"lod_tolerance_px", node.config().lod.tolerance_px},
            {"lod_bias", node.lod_bias()},
            {"scene", scene_path_.string()},
            {"objects", node.objects().size()},
            {"scene_loading", loader_.busy()},
            {"scene_error", scene_error_},
            {"renderer_backend", renderer_backend_},
            {"window", last_window_}};
}

// load-scene: read off the loop's thread, swapped in at a frame boundary (Daemon::swap_scene).
nlohmann::json Daemon::load_scene_command(const std::filesystem::path& path) {
    std::filesystem::path p = path;
    if (p.is_relative()) p = config_path_.parent_path() / p;
    if (std::error_code ec; !std::filesystem::is_regular_file(p, ec))
        return {{"ok", false}, {"error", "load-scene: " + p.string() + ": no such file"}};
    if (loader_.busy()) return {{"ok", false}, {"error", "load-scene: a scene is loading already"}};
    loader_.start(p);
    spdlog::info("control: load-scene {}", p.string());
    return {{"ok", true}, {"loading", p.string()}};
}

}  // namespace hmdnode
