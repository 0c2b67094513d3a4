// Whole-file output that never leaves a half-written file: the bytes go to a temporary file in the
// target's directory, are flushed, and the temporary is renamed over the target.
#pragma once

#include <filesystem>
#include <string_view>

#include "hmdnode/core/result.hpp"

namespace hmdnode {

Status write_file_atomically(const std::filesystem::path& path, std::string_view bytes);

// Reads a whole file; the error names the file.
Result<std::string> read_file(const std::filesystem::path& path);

}  // namespace hmdnode
