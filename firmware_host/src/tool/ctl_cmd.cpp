// `hmdnode ctl`: one command to a running hmdnoded through its control socket (docs/daemon.md,
// "Control socket"), its reply printed: `status` as JSON, `metrics` as the Prometheus text,
// the others as "ok". Commands: status, metrics, pause, resume, recentre, load-scene PATH,
// set warp on|off, set prediction MS, set lod-bias X, set predict on|off, set lod_tolerance_px PX.
// --timeout S bounds the wait for the reply (default 5 s). Exit 0 on an ok reply, 1 on an error
// reply, no reply in time or no daemon, 2 on a usage error.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "hmdnode/firmware_host/control_socket.hpp"
#include "tool/cli_errors.hpp"
#include "tool/commands.hpp"

namespace hmdnode::tool {
namespace {

const CliErrors errors{"ctl"};

struct CtlArgs {
    std::string socket = "/run/hmdnode/control";
    double timeout_s = 5.0;  // for the reply: the loop serves the socket between frames
    std::string key, value;
};

void run_ctl(const CtlArgs& args, const nlohmann::json& command) {
    Result<nlohmann::json> r =
        control_request(args.socket, command, int(std::lround(args.timeout_s * 1000.0)));
    if (!r.ok()) return errors.fail(r.error().message);
    const nlohmann::json& j = *r;
    if (!j.value("ok", false)) return errors.fail(j.value("error", j.dump()));
    const std::string cmd = command["cmd"].get<std::string>();
    if (cmd == "metrics")
        std::fputs(j.value("metrics", "").c_str(), stdout);
    else if (cmd == "status")
        std::printf("%s\n", j.dump(1).c_str());
    else
        std::printf("ok\n");
}

void add_ctl_command(CLI::App& app) {
    auto args = std::make_shared<CtlArgs>();
    CLI::App* ctl = app.add_subcommand("ctl", "Talk to a running hmdnoded (its control socket)");
    ctl->add_option("--socket", args->socket, "The daemon's control socket")->capture_default_str();
    ctl->add_option("--timeout", args->timeout_s,
                    "Seconds to wait for the reply (the daemon answers between frames; a loop "
                    "that is setting up a pass or a scene answers after it)")
        ->capture_default_str()
        ->check(CLI::Range(0.001, 3600.0));
    ctl->require_subcommand(1);
    for (const char* name : {"status", "metrics", "pause", "resume", "recentre"}) {
        CLI::App* sub = ctl->add_subcommand(name, std::string("Send `") + name + "`");
        sub->callback([args, name] { run_ctl(*args, {{"cmd", name}}); });
    }
    CLI::App* load = ctl->add_subcommand(
        "load-scene", "Read a scene (.glb/.gltf) and swap it in at a frame boundary");
    load->add_option("path", args->value,
                     "The scene file (relative: to the daemon's config file's directory)")
        ->required();
    load->callback([args] {
        // note: an absolute path from here, so "./x.glb" means this directory.
        std::error_code ec;
        const std::filesystem::path p = std::filesystem::absolute(args->value, ec);
        run_ctl(*args, {{"cmd", "load-scene"}, {"path", ec ? args->value : p.string()}});
    });
    CLI::App* set = ctl->add_subcommand(
        "set",
        "Set, in the running daemon: warp on|off, prediction MS (predict this much further "
        "ahead), lod-bias X (LOD tolerance x 2^X), predict on|off, lod_tolerance_px PX");
    set->add_option("key", args->key, "warp, prediction, lod-bias, predict or lod_tolerance_px")
        ->required()
        ->check(CLI::IsMember({"warp", "prediction", "lod-bias", "predict", "lod_tolerance_px"}));
    set->add_option("value", args->value, "on/off (true/false), or a number")->required();
    set->callback([args] {
        // The protocol's key (docs/daemon.md, "Control socket") and a value of its type.
        const std::string key = args->key == "prediction" ? "prediction_ms"
                                : args->key == "lod-bias" ? "lod_bias"
                                                          : args->key;
        const bool boolean = key == "warp" || key == "predict";
        nlohmann::json v;
        if (boolean && (args->value == "on" || args->value == "true"))
            v = true;
        else if (boolean && (args->value == "off" || args->value == "false"))
            v = false;
        else if (!boolean)
            v = nlohmann::json::parse(args->value, nullptr, false);
        if (boolean ? !v.is_boolean() : (v.is_discarded() || !v.is_number())) {
            // "hmdnode ctl set KEY: ...": the command as typed, with the key it sets.
            const std::string command = "ctl set " + args->key;
            return CliErrors{command}.usage("\"" + args->value + "\" is not " +
                                            (boolean ? "on or off" : "a number"));
        }
        run_ctl(*args, {{"cmd", "set"}, {"key", key}, {"value", v}});
    });
}

const CommandRegistration reg{90, add_ctl_command};

}  // namespace
}  // namespace hmdnode::tool
