// The latency marker overlay: its default place on the panel and its rects clipped to the panel
// (latency_overlay.hpp; the format is core/latency_marker.hpp). Cost: O(1), no allocation.
#include "latency_overlay.hpp"

#include <algorithm>
#include <cassert>

namespace hmdnode {

LatencyMarkerOverlay default_latency_marker_overlay(int panel_width, int panel_height,
                                                    int cell_px) {
    assert(cell_px >= 1);
    LatencyMarkerOverlay o;
    o.cell_px = cell_px;
    o.x = (panel_width - latency_marker_size_px(cell_px)) / 2;
    o.y = panel_height / 10;
    return o;
}

namespace gpu {

size_t latency_overlay_rects(const LatencyMarkerOverlay& overlay, int panel_width, int panel_height,
                             std::span<LatencyMarkerRect> out) {
    assert(out.size() >= kLatencyMarkerMaxRects && overlay.cell_px >= 1);
    const size_t n =
        latency_marker_rects(overlay.payload, overlay.x, overlay.y, overlay.cell_px, out);
    size_t k = 0;
    for (size_t i = 0; i < n; ++i) {
        LatencyMarkerRect r = out[i];
        const int x0 = std::max(r.x, 0), y0 = std::max(r.y, 0);
        const int x1 = std::min(r.x + r.width, panel_width);
        const int y1 = std::min(r.y + r.height, panel_height);
        if (x1 <= x0 || y1 <= y0) continue;
        out[k++] = {x0, y0, x1 - x0, y1 - y0, r.white};
    }
    return k;
}

}  // namespace gpu
}  // namespace hmdnode
