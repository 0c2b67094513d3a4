// Benchmarks write the tables the docs link: `--write-docs` writes each table into its own file,
// docs/results/NAME.md (write_result: a title, the machine, the command that reproduces it and the
// date, then the table), atomically; docs/results/README.md lists them. write_doc_table, which
// replaces the text between `<!-- NAME -->` and `<!-- /NAME -->` in a markdown file, stays for the
// benches not yet moved to results files. Header-only (benches are one file each).
#pragma once

#include <time.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "hmdnode/core/atomic_file.hpp"
#include "hmdnode/core/percentile.hpp"

namespace hmdnode::bench {

// The q-quantile (0..1) of `v` as core/percentile.hpp defines it (nearest rank); 0 for none.
inline double quantile(std::vector<double> v, double q) {
    return v.empty() ? 0.0 : percentile(std::move(v), q);
}

// The steady clock, nanoseconds.
inline int64_t now_ns() {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(
               std::chrono::steady_clock::now().time_since_epoch())
        .count();
}

// This thread's CPU time, milliseconds (on a shared machine, what the work costs).
inline double thread_cpu_ms() {
    timespec t{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
    return double(t.tv_sec) * 1e3 + double(t.tv_nsec) * 1e-6;
}

// The 1-minute load average now; -1 when it cannot be read.
inline double load1() {
    double l[3] = {0, 0, 0};
    return getloadavg(l, 3) == 3 ? l[0] : -1.0;
}

// A frame range "A:B" with 0 <= A < B.
inline bool parse_range(const std::string& s, int64_t* a, int64_t* b) {
    long long x = 0, y = 0;
    char tail = 0;
    if (std::sscanf(s.c_str(), "%lld:%lld%c", &x, &y, &tail) != 2 || x < 0 || y <= x) return false;
    *a = x;
    *b = y;
    return true;
}

// True when --write-docs is among the arguments.
inline bool wants_docs(int argc, char** argv) {
    for (int i = 1; i < argc; ++i)
        if (std::string(argv[i]) == "--write-docs") return true;
    return false;
}

// `arg` relative to the source tree when it lies inside it, so a command quoted in the docs reads
// the same on every checkout.
inline std::string in_tree(const std::string& arg) {
    const std::string root = HMDNODE_SOURCE_DIR "/";
    return arg.rfind(root, 0) == 0 ? arg.substr(root.size()) : arg;
}

// "optimised build" or "unoptimised build", as the compiler saw this bench.
inline const char* build_kind() {
#if defined(__OPTIMIZE__)
    return "optimised build";
#else
    return "unoptimised build";
#endif
}

// The CPU's model name as /proc/cpuinfo gives it, e.g. "AMD EPYC 7B13"; "unknown CPU" when it
// cannot be read.
inline std::string cpu_model() {
    std::ifstream in("/proc/cpuinfo");
    for (std::string l; std::getline(in, l);)
        if (l.rfind("model name", 0) == 0 && l.find(':') != std::string::npos) {
            std::string model = l.substr(l.find(':') + 1);
            model.erase(0, model.find_first_not_of(" \t"));
            return model;
        }
    return "unknown CPU";
}

// What the bench can read about the machine it runs on: the CPU's model name (/proc/cpuinfo), its
// hardware threads and the 1-minute load average now, e.g. "Intel Xeon ..., 2 hardware threads,
// 1-minute load average 3.1 at the start". Printed on the terminal; results files carry
// machine_line() instead.
inline std::string machine_facts() {
    double load[3] = {0.0, 0.0, 0.0};
    char load_text[32] = "unknown";
    if (getloadavg(load, 3) == 3) std::snprintf(load_text, sizeof load_text, "%.1f", load[0]);
    return cpu_model() + ", " + std::to_string(std::thread::hardware_concurrency()) +
           " hardware threads, 1-minute load average " + load_text + " at the start";
}

// The machine a results file names: the CPU's model name, its hardware threads and, where the
// bench knows it, the renderer's device, e.g. "AMD EPYC 7B13, 2 hardware threads; renderer
// llvmpipe (LLVM 15.0.6, 256 bits)".
inline std::string machine_line(const std::string& renderer = "") {
    std::string line = cpu_model() + ", " + std::to_string(std::thread::hardware_concurrency()) +
                       " hardware threads";
    if (!renderer.empty()) line += "; renderer " + renderer;
    return line;
}

// The command that ran this bench, as a results file quotes it: the binary under
// build/release/bench/ and the arguments, paths inside the source tree relative to it (in_tree).
inline std::string command_line(int argc, char** argv) {
    std::string command =
        "build/release/bench/" + std::filesystem::path(argv[0]).filename().string();
    for (int i = 1; i < argc; ++i) command += ' ' + in_tree(argv[i]);
    return command;
}

// Today's date (UTC), YYYY-MM-DD.
inline std::string today() {
    const std::time_t now = std::time(nullptr);
    std::tm utc{};
    gmtime_r(&now, &utc);
    char text[16];
    std::strftime(text, sizeof text, "%Y-%m-%d", &utc);
    return text;
}

// Writes docs/results/<name>.md, atomically: a one-line title, the machine (machine_line with
// `renderer`), the command that reproduces the table (`command`, as the bench prints it; this
// build's kind beside it) and today's date, then `table` (markdown: what was measured, the table,
// what its columns mean). One table per file. Prints why and returns false when it cannot write.
inline bool write_result(const std::string& name, const std::string& title,
                         const std::string& command, const std::string& table,
                         const std::string& renderer = "") {
    const std::string path = HMDNODE_SOURCE_DIR "/docs/results/" + name + ".md";
    std::string text = "# " + title + "\n\n";
    text += "- Machine: " + machine_line(renderer) + "\n";
    text += "- Command: `" + command + "` (" + build_kind() + ")\n";
    text += "- Date: " + today() + "\n\n";
    text += table;
    if (text.back() != '\n') text += '\n';
    text +=
        "\n<!-- Written by the command above (bench/doc_table.hpp, write_result): edit the "
        "bench, not this file. -->\n";
    if (Status s = write_file_atomically(path, text); !s.ok()) {
        std::fprintf(stderr, "%s\n", s.error().message.c_str());
        return false;
    }
    std::fprintf(stderr, "wrote docs/results/%s.md\n", name.c_str());
    return true;
}

// Replaces the marked block of `path` with `text`; prints why and returns false when it cannot.
inline bool write_doc_table(const std::string& path, const std::string& name,
                            const std::string& text) {
    std::ifstream in(path);
    std::stringstream ss;
    ss << in.rdbuf();
    std::string doc = ss.str();
    const std::string open = "<!-- " + name + " -->", close = "<!-- /" + name + " -->";
    const size_t a = doc.find(open), b = doc.find(close);
    if (a == std::string::npos || b == std::string::npos || b < a) {
        std::fprintf(stderr, "%s: no %s ... %s markers\n", path.c_str(), open.c_str(),
                     close.c_str());
        return false;
    }
    doc = doc.substr(0, a + open.size()) + "\n" + text + doc.substr(b);
    if (Status s = write_file_atomically(path, doc); !s.ok()) {
        std::fprintf(stderr, "%s\n", s.error().message.c_str());
        return false;
    }
    return true;
}

}  // namespace hmdnode::bench
