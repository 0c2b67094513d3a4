// hmdnode: the command-line tool. Subcommands are registered in tool/*.cpp.
#include <cstdio>

#include <CLI/CLI.hpp>

#include "tool/commands.hpp"

int main(int argc, char** argv) {
    CLI::App app{"hmdnode: the tools of the hmdnode head-mounted display rendering node"};
    app.require_subcommand(1);
    hmdnode::tool::register_commands(app);
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        // --help and --version exit 0; every usage error (unknown option, bad value) exits 2.
        return app.exit(e) == 0 ? 0 : 2;
    }
    return hmdnode::tool::exit_code();
}
