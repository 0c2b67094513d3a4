// libFuzzer harness: the control socket's protocol (firmware_host's control_protocol.cpp,
// docs/daemon.md "Control socket") on untrusted bytes: each line of the input, as the socket
// would pass it, to its reply through the daemon's command parser. Invariants: nothing throws,
// every reply is an object with a boolean "ok" ("error" a string when false) that dumps as strict
// JSON (valid UTF-8), and an accepted LOD tolerance is finite and >= 0.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "hmdnode/firmware_host/control_protocol.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    using namespace hmdnode;
    const ControlHandler handler = [](const nlohmann::json& c) -> nlohmann::json {
        Result<ControlCommand> cmd = parse_control_command(c);
        if (!cmd.ok()) return {{"ok", false}, {"error", cmd.error().message}};
        if (cmd->kind == ControlCommand::Kind::set_lod_tolerance_px &&
            !(std::isfinite(cmd->lod_tolerance_px) && cmd->lod_tolerance_px >= 0.0))
            abort();
        return {{"ok", true}, {"cmd", c["cmd"]}};
    };
    std::string_view in(reinterpret_cast<const char*>(data), size);
    while (!in.empty()) {
        const size_t nl = in.find('\n');
        const std::string_view line = in.substr(0, nl);
        in = nl == std::string_view::npos ? std::string_view() : in.substr(nl + 1);
        try {
            const nlohmann::json reply = answer_control_line(line, handler);
            if (!reply.is_object() || !reply.contains("ok") || !reply.at("ok").is_boolean())
                abort();
            if (!reply.at("ok").get<bool>() &&
                !(reply.contains("error") && reply.at("error").is_string()))
                abort();
            (void)reply.dump();  // note: strict; throws on invalid UTF-8
        } catch (...) {
            abort();
        }
    }
    return 0;
}
