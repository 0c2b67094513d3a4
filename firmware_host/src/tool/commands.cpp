#include "tool/commands.hpp"

namespace hmdnode::tool {
namespace {
int g_exit_code = 0;
}

int exit_code() {
    return g_exit_code;
}
void set_exit_code(int code) {
    g_exit_code = code;
}

void register_commands(CLI::App& app) {
    add_replay_command(app);
    add_trace_command(app);
    add_scene_command(app);
}

}  // namespace hmdnode::tool
