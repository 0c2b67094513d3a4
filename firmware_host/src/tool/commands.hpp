// Subcommand registry of the hmdnode tool. Each add_*_command registers one subcommand whose
// callback runs the work and sets the exit code.
#pragma once

#include <CLI/CLI.hpp>

namespace hmdnode::tool {

void register_commands(CLI::App& app);
int exit_code();
void set_exit_code(int code);

void add_replay_command(CLI::App& app);
void add_trace_command(CLI::App& app);
void add_scene_command(CLI::App& app);

}  // namespace hmdnode::tool
