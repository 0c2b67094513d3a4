// The private table of simplification algorithms behind simplify() (lod/src/simplify/simplify.cpp).
// Each algorithm file defines one entry point of this signature; simplify.cpp lists them.
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

// Edge collapse runs on one shared engine (lod/src/simplify/collapse_engine.*) with one cost per
// file; the table in simplify.cpp holds their factories (collapse_engine.hpp), not functions of
// this kind. Li and Kim 2020 (docs/references.md): vertex clustering, vertex removal and their
// hybrids, on OpenMesh connectivity.
Result<std::vector<SimplifiedLevel>> simplify_ss(const Primitive&, std::span<const size_t>,
                                                 const SimplifyOptions&);
Result<std::vector<SimplifiedLevel>> simplify_fad(const Primitive&, std::span<const size_t>,
                                                  const SimplifyOptions&);
Result<std::vector<SimplifiedLevel>> simplify_vt(const Primitive&, std::span<const size_t>,
                                                 const SimplifyOptions&);
Result<std::vector<SimplifiedLevel>> simplify_ivdd(const Primitive&, std::span<const size_t>,
                                                   const SimplifyOptions&);
Result<std::vector<SimplifiedLevel>> simplify_vtd(const Primitive&, std::span<const size_t>,
                                                  const SimplifyOptions&);
Result<std::vector<SimplifiedLevel>> simplify_fass(const Primitive&, std::span<const size_t>,
                                                   const SimplifyOptions&);
// Uniform-grid vertex clustering (vertex_clustering.cpp) and OpenMesh's own Decimater with
// ModQuadric (the baseline the benchmark compares with).
Result<std::vector<SimplifiedLevel>> simplify_grid(const Primitive&, std::span<const size_t>,
                                                   const SimplifyOptions&);
Result<std::vector<SimplifiedLevel>> simplify_openmesh_quadric(const Primitive&,
                                                               std::span<const size_t>,
                                                               const SimplifyOptions&);

}  // namespace hmdnode::lod_detail
