// A frame's draw list and how far it has been drawn, shared by the renderer backends
// (Renderer::begin_frame / render_more): the items, their triangle counts, the cursor, and the
// split into pieces within a triangle budget. Cost: O(items) per frame, no allocation once the
// vectors have grown to the longest draw list.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "hmdnode/render/renderer.hpp"
#include "scene_geometry.hpp"

namespace hmdnode::gpu {

// The steady clock, nanoseconds (the renderers' timings).
int64_t now_ns();

struct FrameQueue {
    std::vector<DrawItem> items;
    std::vector<uint64_t> triangles;  // per item
    size_t cursor = 0;                // items before it are drawn
    bool open = false;                // begun and not complete

    // Starts a frame (dropping an unfinished one). Errors: an item whose mesh is not among
    // `meshes` (nothing is queued then).
    Status begin(std::span<const DrawItem> draw, std::span<const MeshRange> meshes);
    // The end of the next piece from the cursor: at least one item, then items while the piece's
    // triangles stay within max_triangles.
    size_t piece_end(uint64_t max_triangles) const;
    uint64_t total_triangles() const;
};

}  // namespace hmdnode::gpu
