// Whole-file output that never leaves a half-written file: the bytes go to a temporary file in the
// target's directory, are flushed, and the temporary is renamed over the target.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>

#include "hmdnode/core/result.hpp"

namespace hmdnode {

Status write_file_atomically(const std::filesystem::path& path, std::string_view bytes);

// Whether write_file_atomically could write `path` now: the path is not a directory, its directory
// exists and takes a new file (tried with a temporary file, removed at once). Tools check every
// output with it before their work starts, so a bad output path fails at once and leaves nothing.
// The error names the path and the reason ("is a directory", "directory D does not exist",
// "cannot create a file in D: <errno text>").
Status check_output_file(const std::filesystem::path& path);

// SIGTERM, SIGINT or SIGHUP in the middle of an atomic write would leave its temporary file
// behind (the default action ends the process at once). After this call such a signal first
// unlinks the temporary files of the writes in flight (async-signal-safe: unlink(2) on paths kept
// in a fixed table), then ends the process by the same signal with its default action, so the
// caller's shell sees 128 + the signal (143 for SIGTERM). A target file is then either untouched
// or whole. A handler a program installs later for one of these signals (hmdnode record's SIGINT)
// replaces this one while it is installed. Idempotent.
void remove_temporaries_on_termination();

// A temporary file of an output in flight (write_file_atomically registers its own): while the
// guard lives, a signal handled by remove_temporaries_on_termination() unlinks `path`. At most 16
// at once (more are written without the cleanup); paths longer than 4095 bytes are not kept.
class TemporaryFileGuard {
  public:
    explicit TemporaryFileGuard(const std::string& path);
    ~TemporaryFileGuard();
    TemporaryFileGuard(const TemporaryFileGuard&) = delete;
    TemporaryFileGuard& operator=(const TemporaryFileGuard&) = delete;

  private:
    int slot_ = -1;
};

// Reads a whole file; the error names the file.
Result<std::string> read_file(const std::filesystem::path& path);

}  // namespace hmdnode
