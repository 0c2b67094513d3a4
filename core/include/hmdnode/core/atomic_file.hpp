// Whole-file output that never leaves a half-written file: the bytes go to a temporary file in the
// target's directory, are flushed, and the temporary is renamed over the target.
#pragma once

#include <filesystem>
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

// Reads a whole file; the error names the file.
Result<std::string> read_file(const std::filesystem::path& path);

}  // namespace hmdnode
