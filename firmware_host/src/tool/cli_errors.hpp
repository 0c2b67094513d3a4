// The tool's one error reporter: every subcommand reports a failure as "hmdnode COMMAND: message"
// on stderr and sets the exit status, 1 for a failure of the work (an unreadable input, an output
// that cannot be written), 2 for a usage error (a bad or missing option, options that do not go
// together), or a status of the command's own (`record`: 3). The message names what failed (the
// option, the file, the line or field); a command that writes nothing on failure says so in the
// message ("; nothing written"), which the tests look for. Warnings and notes, which leave the
// status alone, go the same way: "hmdnode COMMAND: warning: message", "hmdnode COMMAND: note: ...".
//
// Use: one per command file, `const CliErrors errors{"lod"};` (a subcommand's full name for a
// command with subcommands: `CliErrors{"trace import"}`), then `return errors.fail(...)` or
// `return errors.usage(...)` from the command's callback, and `if (!errors.check_outputs(...))
// return;` before the work starts.
#pragma once

#include <cstdio>
#include <initializer_list>
#include <string>
#include <string_view>
#include <utility>

#include "cli/cli_checks.hpp"
#include "tool/commands.hpp"

namespace hmdnode::tool {

class CliErrors {
  public:
    explicit constexpr CliErrors(std::string_view command) : command_(command) {}

    // The work failed: exit status 1.
    void fail(const std::string& message) const { fail_with(1, message); }
    // A bad or missing option, or options that do not go together: exit status 2.
    void usage(const std::string& message) const { fail_with(2, message); }
    // A failure with a status of the command's own (docs/commands.md, "Exit status").
    void fail_with(int code, const std::string& message) const {
        print(message);
        set_exit_code(code);
    }
    // Something the user should know that does not fail the command.
    void warning(const std::string& message) const { print("warning: " + message); }
    void note(const std::string& message) const { print("note: " + message); }

    // cli::check_outputs under this command's name: false (and exit status 1) when an output
    // cannot be written, "hmdnode COMMAND: FLAG why; nothing written" printed.
    bool check_outputs(std::initializer_list<std::pair<const char*, std::string>> outputs) const {
        if (cli::check_outputs(("hmdnode " + std::string(command_)).c_str(), outputs)) return true;
        set_exit_code(1);
        return false;
    }

  private:
    void print(const std::string& message) const {
        std::fprintf(stderr, "hmdnode %.*s: %s\n", int(command_.size()), command_.data(),
                     message.c_str());
    }

    std::string_view command_;
};

}  // namespace hmdnode::tool
