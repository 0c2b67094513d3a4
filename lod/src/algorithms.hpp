// The private table of simplification algorithms behind simplify() (lod/src/simplify.cpp). Each
// algorithm file defines one entry point of this signature; simplify.cpp lists them.
//
// Contract for an entry point: `in` is valid (indices in range, finite positions, at least one
// triangle); `targets` is strictly decreasing, each below in.triangle_count(); return one level
// per target, in order. Attribute arrays of the output are exactly those of the input.
#pragma once

#include <span>
#include <vector>

#include "hmdnode/core/result.hpp"
#include "hmdnode/lod/simplify.hpp"

namespace hmdnode::lod_detail {

using AlgorithmFn = Result<std::vector<SimplifiedLevel>> (*)(const Primitive& in,
                                                             std::span<const size_t> targets,
                                                             const SimplifyOptions& options);

}  // namespace hmdnode::lod_detail
