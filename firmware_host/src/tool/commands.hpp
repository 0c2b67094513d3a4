// Subcommand registry of the hmdnode tool. Each add_*_command registers one subcommand whose
// callback runs the work and sets the exit code.
//
// A command file may also register itself, without touching this header's list, by defining at
// namespace scope:   static const CommandRegistration reg{40, add_lod_command};
// Commands appear in `hmdnode --help` in the order of their numbers (replay 10, trace 20,
// scene 30, then the self-registered ones).
#pragma once

#include <CLI/CLI.hpp>

namespace hmdnode::tool {

void register_commands(CLI::App& app);
int exit_code();
void set_exit_code(int code);

void add_replay_command(CLI::App& app);
void add_trace_command(CLI::App& app);
void add_scene_command(CLI::App& app);

// Registers `add` to be called by register_commands(); for static objects in tool/*.cpp (linked
// into the executable directly, so they are never dropped as unused library members).
struct CommandRegistration {
    CommandRegistration(int order, void (*add)(CLI::App&));
};

}  // namespace hmdnode::tool
