// The latency marker overlay's rectangles as both backends fill them after the lens pass
// (Vulkan: vkCmdClearAttachments inside the panel's render pass; GLES: scissored glClear), so the
// two draw the same pixels: core/latency_marker.hpp's rects, clipped to the panel. Cost: O(1), no
// allocation.
#pragma once

#include <span>

#include "hmdnode/render/renderer.hpp"

namespace hmdnode::gpu {

// The overlay's rects clipped to a panel_width x panel_height eye (empty ones dropped), in fill
// order; out has room for kLatencyMarkerMaxRects.
size_t latency_overlay_rects(const LatencyMarkerOverlay& overlay, int panel_width, int panel_height,
                             std::span<LatencyMarkerRect> out);

}  // namespace hmdnode::gpu
