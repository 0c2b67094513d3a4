// gzip / zlib streams inflated to memory with zlib (RFC 1952, 1950; the format is detected).
// Cost: O(inflated size) time and memory; capped at 4 GiB.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "hmdnode/core/result.hpp"

namespace hmdnode {

// The inflated bytes; a stream cut short gives what it inflated to and sets *truncated. Corrupt
// data is an error naming the compressed byte offset.
Result<std::vector<uint8_t>> gunzip(std::span<const uint8_t> in, bool* truncated);

}  // namespace hmdnode
