// The tool's one error reporter: every subcommand reports a failure as "hmdnode COMMAND: message"
// on stderr and sets the exit status, 1 for a failure of the work (an unreadable input, an output
// that cannot be written), 2 for a usage error (a bad or missing option, options that do not go
// together). The message names what failed; a command that writes nothing on failure says so in
// the message ("; nothing written"), which the tests look for.
//
// Use: one per command file, `const CliErrors errors{"lod"};`, then `return errors.fail(...)` or
// `return errors.usage(...)` from the command's callback.
#pragma once

#include <cstdio>
#include <string>
#include <string_view>

#include "tool/commands.hpp"

namespace hmdnode::tool {

class CliErrors {
  public:
    explicit constexpr CliErrors(std::string_view command) : command_(command) {}

    // The work failed: exit status 1.
    void fail(const std::string& message) const { report(message, 1); }
    // A bad or missing option, or options that do not go together: exit status 2.
    void usage(const std::string& message) const { report(message, 2); }

  private:
    void report(const std::string& message, int code) const {
        std::fprintf(stderr, "hmdnode %.*s: %s\n", int(command_.size()), command_.data(),
                     message.c_str());
        set_exit_code(code);
    }

    std::string_view command_;
};

}  // namespace hmdnode::tool
