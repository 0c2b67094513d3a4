// The subcommands of `hmdnode tracking` that live in their own files (`tracking eval` is in
// tracking_cmd.cpp, which creates the `tracking` command and adds these).
#pragma once

#include <CLI/CLI.hpp>

namespace hmdnode::tool {

// `hmdnode tracking place` (tracking_place_cmd.cpp).
void add_tracking_place_command(CLI::App& tracking);

}  // namespace hmdnode::tool
