// The control protocol (control_protocol.hpp): line -> JSON -> command -> reply, no exceptions out.
#include "hmdnode/firmware_host/control_protocol.hpp"

#include <cmath>
#include <exception>

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
    } else if (name == "set") {
        const auto k = command.find("key");
        const auto v = command.find("value");
        const bool has_value = v != command.end();
        if (k != command.end() && k->is_string() && *k == "predict" && has_value &&
            v->is_boolean()) {
            out.kind = Kind::set_predict;
            out.predict = v->get<bool>();
        } else if (k != command.end() && k->is_string() && *k == "lod_tolerance_px" && has_value &&
                   v->is_number()) {
            out.kind = Kind::set_lod_tolerance_px;
            out.lod_tolerance_px = v->get<double>();
            if (!(out.lod_tolerance_px >= 0.0) || !std::isfinite(out.lod_tolerance_px))
                return make_error("LOD tolerance must be a finite number >= 0 (pixels)");
        } else {
            return make_error(
                "set: give \"key\": \"predict\" with a boolean value, or \"lod_tolerance_px\" "
                "with a number >= 0");
        }
    } else {
        // note: the name is valid UTF-8 (the parser checked it), so the reply dumps.
        return make_error("unknown command \"" + name + "\" (status, metrics, pause, resume, set)");
    }
    return out;
}

}  // namespace hmdnode
