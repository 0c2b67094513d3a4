// The frame's draw list and its pieces (see frame_queue.hpp).
#include "frame_queue.hpp"

#include <algorithm>
#include <cassert>
#include <chrono>
#include <string>

namespace hmdnode::gpu {

int64_t now_ns() {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(
               std::chrono::steady_clock::now().time_since_epoch())
        .count();
}

Status FrameQueue::begin(std::span<const DrawItem> draw, std::span<const MeshRange> meshes) {
    triangles.clear();
    for (const DrawItem& item : draw) {
        if (item.mesh < 0 || size_t(item.mesh) >= meshes.size()) {
            open = false;
            return make_error("renderer: draw item refers to mesh " + std::to_string(item.mesh) +
                              " but the uploaded scene has " + std::to_string(meshes.size()));
        }
        if (item.dither < -kMaxDither || item.dither > kMaxDither) {
            open = false;
            return make_error("renderer: draw item dither " + std::to_string(item.dither) +
                              " is outside -" + std::to_string(kMaxDither) + ".." +
                              std::to_string(kMaxDither));
        }
        triangles.push_back(meshes[size_t(item.mesh)].triangles);
    }
    items.assign(draw.begin(), draw.end());    // allocates only when the list grows
    assert(triangles.size() == items.size());  // one count per item
    cursor = 0;
    open = true;
    return Status::success();
}

size_t FrameQueue::piece_end(uint64_t max_triangles) const {
    // A begun frame whose cursor has not passed its end.
    assert(open && cursor <= items.size() && triangles.size() == items.size());
    size_t last = cursor;
    uint64_t sum = 0;
    do {
        sum += last < items.size() ? triangles[last] : 0;
        ++last;
    } while (last < items.size() && sum + triangles[last] <= max_triangles);
    const size_t end = std::min(last, items.size());
    // At least one item when any is left, and never past the end.
    assert(end <= items.size() && (cursor == items.size() || end > cursor));
    return end;
}

uint64_t FrameQueue::total_triangles() const {
    uint64_t sum = 0;
    for (uint64_t t : triangles) sum += t;
    return sum;
}

}  // namespace hmdnode::gpu
