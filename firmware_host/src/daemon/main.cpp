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
#include <csignal>
#include <cstdint>
#include <optional>
#include <string>

#include <spdlog/spdlog.h>
#include <CLI/CLI.hpp>

#include "cli/cli_checks.hpp"
#include "daemon/config.hpp"
#include "daemon/daemon.hpp"
#include "daemon/sd_notify.hpp"

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
    cli::refuse_non_finite_numbers(app);
    // --help exits 0; a usage error exits 2 like a bad config, so the unit does not restart.
    if (std::optional<int> code = cli::parse_command_line(app, argc, argv)) return *code;
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

    // The scene, the trace, the node, the calibration, the control socket; then the frame loop
    // (daemon/daemon.hpp).
    Daemon daemon(config_path, std::move(cfg).value(), notifier, DaemonSignals{&g_stop, &g_reload});
    if (std::optional<int> code = daemon.start()) return *code;
    return daemon.run();
}
