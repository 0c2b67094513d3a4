// RGBA8 to packed YUYV 4:2:2 (V4L2_PIX_FMT_YUYV: Y0 U Y1 V per pixel pair), for writing panel
// images to a V4L2 output (v4l2_output.hpp). ITU-R BT.601, limited range (Y 16..235, U and V
// 16..240, what V4L2 takes for YUYV by default), in 8-bit fixed point as in ITU-R BT.601 and
// the V4L2 colorspace docs: Y = ((66 R + 129 G + 25 B + 128) >> 8) + 16,
// U = ((-38 R - 74 G + 112 B + 128) >> 8) + 128, V = ((112 R - 94 G - 18 B + 128) >> 8) + 128,
// U and V of a pair from the mean of its two pixels' R, G, B. Black is (16, 128, 128), white
// (235, 128, 128). Cost: O(pixels written), no allocation.
#pragma once

#include <cstdint>
#include <span>

#include "hmdnode/core/image.hpp"

namespace hmdnode {

// A YUYV frame of width x height (width even), bytes_per_line >= 2 x width.
struct YuyvFrameView {
    std::span<uint8_t> bytes;  // at least bytes_per_line x height
    uint32_t width = 0, height = 0, bytes_per_line = 0;
};

// Fills the frame with black.
void fill_yuyv_black(const YuyvFrameView& frame);

// Writes `image` into the frame with its top-left at (x0, y0) (x0 even), clipped to the frame;
// the rest of the frame is left as it is. A pixel of an odd-width image's last column pairs with
// black.
void write_rgba_to_yuyv(const ImageRGBA8& image, int x0, int y0, const YuyvFrameView& frame);

}  // namespace hmdnode
