// The output primitive of a collapse state, shared by the engine and refine(); see
// compact_primitive.cpp.
#pragma once

#include <cstdint>
#include <limits>
#include <span>

#include <glm/glm.hpp>

#include "hmdnode/core/scene.hpp"
#include "hmdnode/lod/progressive_mesh.hpp"

namespace hmdnode::lod_detail {

// "No index" in the engine's arrays.
inline constexpr uint32_t kNone = std::numeric_limits<uint32_t>::max();

// The output primitive of a state: live faces in id order, the wedges they use in id order.
// Shared by the engine's snapshots and refine() so that both agree bit for bit. `wedges` is only
// read for the attributes the flags name (it may be empty when none is set).
Primitive compact_primitive(std::span<const glm::vec3> positions,
                            std::span<const uint32_t> wedge_position,
                            std::span<const PmWedge> wedges, std::span<const uint32_t> corners,
                            std::span<const uint8_t> face_alive, bool has_normals, bool has_uv0,
                            bool has_uv1, bool has_colors, int material);

}  // namespace hmdnode::lod_detail
