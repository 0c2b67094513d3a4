// The vsync grid a display paces on when its vsyncs are anchor_ns + k * period_ns (KMS, and the
// VK_KHR_display pacing in firmware_host): the first vsync after a time, and the first free one a
// frame presented at a time can make. O(1).
#pragma once

#include <cassert>
#include <cstdint>

namespace hmdnode {

// The first vsync of the grid strictly after t_ns.
inline int64_t grid_vsync_after(int64_t anchor_ns, int64_t period_ns, int64_t t_ns) {
    assert(period_ns > 0);
    const int64_t rel = t_ns - anchor_ns;
    const int64_t k = rel >= 0 ? rel / period_ns + 1 : -((-rel) / period_ns);
    const int64_t v = anchor_ns + k * period_ns;
    const int64_t after = v <= t_ns ? v + period_ns : v;
    assert(after > t_ns && after - period_ns <= t_ns);  // strictly after t, within one period
    return after;
}

// The first vsync of the grid whose latch point (vsync - latch_ns) is not before t_ns and that is
// after last_vsync_ns (the one an earlier present holds): Display::free_vsync_ns on the grid.
inline int64_t grid_free_vsync(int64_t anchor_ns, int64_t period_ns, int64_t latch_ns,
                               int64_t last_vsync_ns, int64_t t_ns) {
    assert(latch_ns >= 0);
    const int64_t v = grid_vsync_after(anchor_ns, period_ns, t_ns + latch_ns - 1);
    const int64_t free =
        v <= last_vsync_ns ? grid_vsync_after(anchor_ns, period_ns, last_vsync_ns) : v;
    assert(free > last_vsync_ns && free - latch_ns >= t_ns);
    return free;
}

}  // namespace hmdnode
