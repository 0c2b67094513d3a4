// The output primitive of a collapse state: live faces in id order, the wedges they use in id
// order. One function for the engine's snapshots (collapse_engine.cpp) and refine()
// (progressive_mesh_refine.cpp), so that both agree bit for bit; it needs nothing of the engine.
//
// Cost: O(W + F) time, O(W) scratch.
#include "compact_primitive.hpp"

#include "scratch.hpp"

namespace hmdnode::lod_detail {

Primitive compact_primitive(std::span<const glm::vec3> positions,
                            std::span<const uint32_t> wedge_position,
                            std::span<const PmWedge> wedges, std::span<const uint32_t> corners,
                            std::span<const uint8_t> face_alive, bool has_normals, bool has_uv0,
                            bool has_uv1, bool has_colors, int material) {
    Primitive out;
    out.material = material;
    Scratch<uint32_t> remap(wedge_position.size(), kNone);
    size_t live = 0;
    for (size_t f = 0; f < face_alive.size(); ++f) {
        if (!face_alive[f]) continue;
        ++live;
        for (int k = 0; k < 3; ++k) remap[corners[3 * f + k]] = 0;
    }
    uint32_t next = 0;
    for (size_t w = 0; w < wedge_position.size(); ++w) {
        if (remap[w] == kNone) continue;
        remap[w] = next++;
        out.positions.push_back(positions[wedge_position[w]]);
        if (has_normals) out.normals.push_back(wedges[w].normal);
        if (has_uv0) out.uv0.push_back(wedges[w].uv0);
        if (has_uv1) out.uv1.push_back(wedges[w].uv1);
        if (has_colors) out.colors.push_back(wedges[w].color);
    }
    out.indices.reserve(live * 3);
    for (size_t f = 0; f < face_alive.size(); ++f) {
        if (!face_alive[f]) continue;
        for (int k = 0; k < 3; ++k) out.indices.push_back(remap[corners[3 * f + k]]);
    }
    return out;
}

}  // namespace hmdnode::lod_detail
