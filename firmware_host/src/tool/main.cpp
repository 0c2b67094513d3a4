// hmdnode: the command-line tool. Subcommands are registered in tool/*.cpp.
#include <cstdio>

#include <CLI/CLI.hpp>

#include "cli/cli_checks.hpp"
#include "hmdnode/core/atomic_file.hpp"
#include "tool/commands.hpp"

int main(int argc, char** argv) {
    // SIGTERM/SIGINT/SIGHUP in the middle of a command: the temporary file of an output being
    // written is removed, then the process ends by the signal (README, "Exit status").
    hmdnode::remove_temporaries_on_termination();
    CLI::App app{"hmdnode: the tools of the hmdnode head-mounted display rendering node"};
    app.require_subcommand(1);
    hmdnode::tool::register_commands(app);
    hmdnode::cli::refuse_non_finite_numbers(app);
    // --help and --version exit 0; every usage error (unknown option, bad value) exits 2.
    if (std::optional<int> code = hmdnode::cli::parse_command_line(app, argc, argv)) return *code;
    return hmdnode::tool::exit_code();
}
