// Per-vertex attributes carried from a mesh onto a simplified version of it (an LOD level), so
// that every level of a chain shows the same surface attribute as its base: baked per-vertex light
// above all. Baking each level on its own gives each level its own Monte-Carlo noise, and the
// levels then differ from the base by that noise more than by their geometry
// (docs/lod-selection.md, "The heavy scene").
//
// Threads: pure functions of their arguments.
#pragma once

#include <vector>

#include <glm/glm.hpp>

#include "hmdnode/core/result.hpp"
#include "hmdnode/core/scene.hpp"

namespace hmdnode {

// The base's `light` (_LIGHT_0) filtered onto `level`'s vertices (attribute_transfer.cpp):
// each level vertex gets the mean of the base vertices within its footprint (half the mean length
// of the level's edges at that vertex), weighted by the base vertices' areas and a tent falling to
// zero at the footprint's edge, taking only base vertices whose normal faces the same way (so the
// two sides of a thin part stay apart); where none is inside, the nearest such base vertex.
// Errors: the base has no light or no normals, or the level has no normals.
Result<std::vector<glm::vec3>> transfer_vertex_light(const Primitive& base, const Primitive& level);

// Gives `level` (a simplified version of `base`) the base's light where the simplifier did not
// carry it by its own vertex correspondence: nothing when the base has no light or the level
// already has one value per vertex; else transfer_vertex_light(), with area-weighted vertex normals
// made for the filter where the base or the level has none (the level's own arrays are otherwise
// untouched). simplify() and build_progressive_mesh() call it on every level they return, so every
// algorithm's levels carry _LIGHT_0. Errors: those of transfer_vertex_light (none for valid input).
Status carry_vertex_light(const Primitive& base, Primitive& level);

}  // namespace hmdnode
