// Command-line checks shared by the hmdnode tool (src/tool) and hmdnoded (src/daemon), CLI11: every
// floating-point option refuses nan and inf, output paths are checked before any work, and a parse
// error of any kind exits 2 (the project's usage-error status; CLI11's own codes, 105-109, are not
// documented exit statuses). Header-only, in neither executable's folder, so neither includes
// the other's sources.
#pragma once

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <initializer_list>
#include <memory>
#include <optional>
#include <string>
#include <utility>

#include <CLI/CLI.hpp>

#include "hmdnode/core/atomic_file.hpp"

namespace hmdnode::cli {

// Refuses a value that parses as a number but is not finite ("nan", "inf", "1e999"); other text is
// left to the option's own conversion, which names it.
inline CLI::Validator finite_number() {
    return CLI::Validator(
        [](std::string& s) -> std::string {
            const char* begin = s.c_str();
            char* end = nullptr;
            const double v = std::strtod(begin, &end);
            if (end == begin || *end != '\0' || std::isfinite(v)) return {};
            return "\"" + s + "\" is not a finite number";
        },
        "", "FINITE");
}

// `--eye-tracker none|trace` (replay, render-bench): the one vocabulary's eye-tracker names.
inline void add_eye_tracker_option(CLI::App* c, const std::shared_ptr<std::string>& value) {
    c->add_option("--eye-tracker", *value,
                  "Where the gaze that steers LOD comes from: none (the lens centre) or trace "
                  "(the trace's gaze columns; `hmdnode trace add-gaze` makes synthetic ones)")
        ->check(CLI::IsMember({"none", "trace"}));
}

// Adds finite_number() to every option of `app` and of its subcommands, at any depth, whose value
// is floating point (CLI11's type name FLOAT, also for vectors of them): one place, so an option
// added later is covered too.
inline void refuse_non_finite_numbers(CLI::App& app) {
    for (CLI::Option* o : app.get_options())
        if (o->get_type_name().rfind("FLOAT", 0) == 0) o->check(finite_number());
    for (CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; }))
        refuse_non_finite_numbers(*sub);
}

// Checks every output a command will write (core's check_output_file) before its work starts:
// on the first that cannot be written, prints "<command>: <flag> <why>; nothing written" and
// returns false (the caller exits 1, as for any file it cannot read or write). Empty paths (an
// output not asked for) are skipped.
inline bool check_outputs(const char* command,
                          std::initializer_list<std::pair<const char*, std::string>> outputs) {
    for (const auto& [flag, path] : outputs) {
        if (path.empty()) continue;
        if (Status st = check_output_file(path); !st.ok()) {
            std::fprintf(stderr, "%s: %s %s; nothing written\n", command, flag,
                         st.error().message.c_str());
            return false;
        }
    }
    return true;
}

// Parses the command line. Empty to go on; else the exit status: 0 after --help or --version, 2
// after any usage error (CLI11 prints its message and the usage line). A subcommand's callback
// runs inside parse(), so one that throws CLI::ValidationError is a usage error too.
inline std::optional<int> parse_command_line(CLI::App& app, int argc, char** argv) {
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        return app.exit(e) == 0 ? 0 : 2;
    }
    return std::nullopt;
}

}  // namespace hmdnode::cli
