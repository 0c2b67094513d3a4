// `hmdnode ctl`: one command to a running hmdnoded through its control socket (docs/daemon.md,
// "Control socket"), its reply printed: `status` as JSON, `metrics` as the Prometheus text,
// the others as "ok". Exit 0 on an ok reply, 1 on an error reply or no daemon, 2 on a usage error.
#include <cstdio>
#include <memory>
#include <string>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "hmdnode/firmware_host/control_socket.hpp"
#include "tool/commands.hpp"

namespace hmdnode::tool {
namespace {

struct CtlArgs {
    std::string socket = "/run/hmdnode/control";
    std::string key, value;
};

void run_ctl(const CtlArgs& args, const nlohmann::json& command) {
    Result<nlohmann::json> r = control_request(args.socket, command);
    if (!r.ok()) {
        std::fprintf(stderr, "hmdnode ctl: %s\n", r.error().message.c_str());
        return set_exit_code(1);
    }
    const nlohmann::json& j = *r;
    if (!j.value("ok", false)) {
        std::fprintf(stderr, "hmdnode ctl: %s\n", j.value("error", j.dump()).c_str());
        return set_exit_code(1);
    }
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
    ctl->require_subcommand(1);
    for (const char* name : {"status", "metrics", "pause", "resume"}) {
        CLI::App* sub = ctl->add_subcommand(name, std::string("Send `") + name + "`");
        sub->callback([args, name] { run_ctl(*args, {{"cmd", name}}); });
    }
    CLI::App* set = ctl->add_subcommand(
        "set", "Set predict (true/false) or lod_tolerance_px (pixels) in the running daemon");
    set->add_option("key", args->key, "predict or lod_tolerance_px")
        ->required()
        ->check(CLI::IsMember({"predict", "lod_tolerance_px"}));
    set->add_option("value", args->value, "true/false, or a number >= 0")->required();
    set->callback([args] {
        nlohmann::json v = nlohmann::json::parse(args->value, nullptr, false);
        if (v.is_discarded() || !(v.is_boolean() || v.is_number())) {
            std::fprintf(stderr, "hmdnode ctl set: \"%s\" is not true, false or a number\n",
                         args->value.c_str());
            return set_exit_code(2);
        }
        run_ctl(*args, {{"cmd", "set"}, {"key", args->key}, {"value", v}});
    });
}

const CommandRegistration reg{90, add_ctl_command};

}  // namespace
}  // namespace hmdnode::tool
