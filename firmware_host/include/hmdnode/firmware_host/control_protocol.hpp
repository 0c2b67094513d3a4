// The control socket's protocol (docs/daemon.md, "Control socket"), apart from the socket: one
// command line to its reply, and a command object to what it asks. Both take untrusted bytes and
// never throw (tests/fuzz/control_protocol_fuzz.cpp). Cost: one JSON parse of at most
// ControlServer::kMaxLine bytes per command.
#pragma once

#include <functional>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

#include "hmdnode/core/result.hpp"

namespace hmdnode {

// Maps a command (a JSON object with a string "cmd") to its reply object ("ok": true/false, ...).
using ControlHandler = std::function<nlohmann::json(const nlohmann::json& command)>;

// One command line (without its newline) to its reply: an error reply when the line is not a JSON
// object with a string "cmd" or when `handler` throws; otherwise the handler's reply.
nlohmann::json answer_control_line(std::string_view line, const ControlHandler& handler);

// The commands the daemon knows, checked whole: a wrong field gives an error naming it.
//   {"cmd": "status"} {"cmd": "metrics"} {"cmd": "pause"} {"cmd": "resume"} {"cmd": "recentre"}
//   {"cmd": "load-scene", "path": "FILE.glb"}
//   {"cmd": "set", "key": K, "value": V} with K "predict" (boolean), "lod_tolerance_px" (>= 0),
//     "warp" (boolean), "prediction_ms" (-100..100), "lod_bias" (-8..8)
struct ControlCommand {
    enum class Kind {
        status,
        metrics,
        pause,
        resume,
        recentre,
        load_scene,
        set_predict,
        set_lod_tolerance_px,
        set_warp,
        set_prediction_ms,
        set_lod_bias,
    };
    Kind kind = Kind::status;
    bool predict = false;           // set_predict
    double lod_tolerance_px = 0.0;  // set_lod_tolerance_px: finite, >= 0
    bool warp = false;              // set_warp
    double prediction_ms = 0.0;     // set_prediction_ms: finite, |ms| <= 100
    double lod_bias = 0.0;          // set_lod_bias: finite, |bias| <= 8
    std::string path;               // load_scene: not empty, no NUL
};
Result<ControlCommand> parse_control_command(const nlohmann::json& command);

}  // namespace hmdnode
