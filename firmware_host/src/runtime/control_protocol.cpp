// The control protocol (control_protocol.hpp): line -> JSON -> command -> reply, no exceptions out.
#include "hmdnode/firmware_host/control_protocol.hpp"

#include <cmath>
#include <exception>
#include <limits>

namespace hmdnode {

nlohmann::json answer_control_line(std::string_view line, const ControlHandler& handler) {
    const nlohmann::json cmd = nlohmann::json::parse(line, nullptr, false);
    if (cmd.is_discarded() || !cmd.is_object() || !cmd.contains("cmd") || !cmd["cmd"].is_string())
        return {{"ok", false},
                {"error", "not a command: give one JSON object with \"cmd\" a line"}};
    try {
        return handler(cmd);
    } catch (const std::exception& e) {  // a field of the wrong type, say
        return {{"ok", false}, {"error", std::string("bad command: ") + e.what()}};
    }
}

Result<ControlCommand> parse_control_command(const nlohmann::json& command) {
    using Kind = ControlCommand::Kind;
    const auto c = command.find("cmd");
    if (!command.is_object() || c == command.end() || !c->is_string())
        return make_error("not a command: give one JSON object with \"cmd\" a line");
    const std::string& name = c->get_ref<const std::string&>();
    ControlCommand out;
    if (name == "status") {
        out.kind = Kind::status;
    } else if (name == "metrics") {
        out.kind = Kind::metrics;
    } else if (name == "pause") {
        out.kind = Kind::pause;
    } else if (name == "resume") {
        out.kind = Kind::resume;
    } else if (name == "recentre") {
        out.kind = Kind::recentre;
    } else if (name == "load-scene") {
        const auto p = command.find("path");
        if (p == command.end() || !p->is_string() || p->get_ref<const std::string&>().empty() ||
            p->get_ref<const std::string&>().find('\0') != std::string::npos)
            return make_error("load-scene: give \"path\": the scene file (.glb/.gltf)");
        out.kind = Kind::load_scene;
        out.path = p->get<std::string>();
    } else if (name == "set") {
        const auto k = command.find("key");
        const auto v = command.find("value");
        const std::string key = k != command.end() && k->is_string() ? k->get<std::string>() : "";
        const bool is_bool = v != command.end() && v->is_boolean();
        const bool is_number = v != command.end() && v->is_number();
        // A number in [lo, hi] (finite), or an error naming the key.
        auto number = [&](double lo, double hi, const char* what, double* outv) -> Status {
            const double x = v->get<double>();
            if (!std::isfinite(x) || x < lo || x > hi)
                return make_error(std::string("set ") + key + ": " + what);
            *outv = x;
            return {};
        };
        Status st;
        if (key == "predict" && is_bool) {
            out.kind = Kind::set_predict;
            out.predict = v->get<bool>();
        } else if (key == "warp" && is_bool) {
            out.kind = Kind::set_warp;
            out.warp = v->get<bool>();
        } else if (key == "lod_tolerance_px" && is_number) {
            out.kind = Kind::set_lod_tolerance_px;
            st = number(0.0, std::numeric_limits<double>::max(),
                        "LOD tolerance must be a finite number >= 0 (pixels)",
                        &out.lod_tolerance_px);
        } else if (key == "prediction_ms" && is_number) {
            out.kind = Kind::set_prediction_ms;
            st = number(-100.0, 100.0, "the prediction offset must be between -100 and 100 ms",
                        &out.prediction_ms);
        } else if (key == "lod_bias" && is_number) {
            out.kind = Kind::set_lod_bias;
            st = number(-8.0, 8.0, "the LOD bias must be between -8 and 8 (tolerance x 2^bias)",
                        &out.lod_bias);
        } else {
            return make_error(
                "set: give \"key\": \"predict\" or \"warp\" with a boolean value, or "
                "\"lod_tolerance_px\" (>= 0), \"prediction_ms\" (-100..100) or \"lod_bias\" "
                "(-8..8) with a number");
        }
        if (!st.ok()) return st.error();
    } else {
        // note: the name is valid UTF-8 (the parser checked it), so the reply dumps.
        return make_error("unknown command \"" + name +
                          "\" (status, metrics, pause, resume, recentre, load-scene, set)");
    }
    return out;
}

}  // namespace hmdnode
