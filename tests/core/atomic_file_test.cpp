// core's atomic writes under termination signals (atomic_file.hpp): a temporary file of a write in
// flight is removed when SIGTERM/SIGINT/SIGHUP ends the process, which then dies by that signal
// (its parent sees WTERMSIG, the shell 128 + the signal); a finished write is left alone.
#include <gtest/gtest.h>

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "hmdnode/core/atomic_file.hpp"

namespace fs = std::filesystem;

namespace {

fs::path fresh_dir(const std::string& name) {
    const fs::path d = fs::temp_directory_path() / name;
    fs::remove_all(d);
    fs::create_directories(d);
    return d;
}

// Runs `child` in a forked process and returns its wait status.
template <class F>
int in_child(F child) {
    const pid_t pid = fork();
    if (pid == 0) {
        child();
        _exit(0);
    }
    int st = 0;
    waitpid(pid, &st, 0);
    return st;
}

}  // namespace

TEST(AtomicFile, TerminationSignalRemovesTheTemporaryInFlightAndEndsByTheSignal) {
    const fs::path dir = fresh_dir("hmdnode_atomic_file_signal");
    const fs::path tmp = dir / ".out.glb.tmp.abcdef";
    for (int sig : {SIGTERM, SIGINT, SIGHUP}) {
        const int st = in_child([&] {
            hmdnode::remove_temporaries_on_termination();
            std::ofstream(tmp) << "half of a file";
            const hmdnode::TemporaryFileGuard guard(tmp.string());
            raise(sig);
        });
        ASSERT_TRUE(WIFSIGNALED(st)) << "signal " << sig << ": exited with " << WEXITSTATUS(st);
        EXPECT_EQ(WTERMSIG(st), sig);
        EXPECT_FALSE(fs::exists(tmp)) << "signal " << sig << " left the temporary file";
    }
}

TEST(AtomicFile, FinishedWritesAndReleasedGuardsAreLeftAlone) {
    const fs::path dir = fresh_dir("hmdnode_atomic_file_finished");
    const fs::path out = dir / "out.txt", kept = dir / "kept.txt";
    const int st = in_child([&] {
        hmdnode::remove_temporaries_on_termination();
        if (!hmdnode::write_file_atomically(out, "whole").ok()) _exit(3);
        std::ofstream(kept) << "x";
        { const hmdnode::TemporaryFileGuard guard(kept.string()); }
        raise(SIGTERM);
    });
    ASSERT_TRUE(WIFSIGNALED(st));
    EXPECT_EQ(WTERMSIG(st), SIGTERM);
    std::ifstream in(out);
    EXPECT_EQ(std::string(std::istreambuf_iterator<char>(in), {}), "whole");
    EXPECT_TRUE(fs::exists(kept));
    size_t files = 0;
    for (const auto& e : fs::directory_iterator(dir)) files += e.is_regular_file();
    EXPECT_EQ(files, 2u) << "no temporary file is left beside the outputs";
}
