// Test support for the command-line suites: run a command through the shell and collect its exit
// code and output, and make an empty scratch directory.
#pragma once

#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <string>

namespace hmdnode::test {

struct CommandRun {
    int code = -1;
    std::string output;  // stdout and stderr
};

// Runs `cmd` with stderr merged into stdout; code is -1 when it did not exit normally.
inline CommandRun run(const std::string& cmd) {
    CommandRun r;
    FILE* p = popen((cmd + " 2>&1").c_str(), "r");
    if (!p) return r;
    std::array<char, 4096> buf;
    size_t n;
    while ((n = fread(buf.data(), 1, buf.size(), p)) > 0) r.output.append(buf.data(), n);
    const int st = pclose(p);
    r.code = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
    return r;
}

// An empty directory <tmp>/<name>, removed first if it exists.
inline std::filesystem::path fresh_temp_dir(const std::string& name) {
    const std::filesystem::path d = std::filesystem::temp_directory_path() / name;
    std::filesystem::remove_all(d);
    std::filesystem::create_directories(d);
    return d;
}

}  // namespace hmdnode::test
