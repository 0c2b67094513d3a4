// RGBA8 to YUYV 4:2:2, BT.601 limited range in 8-bit fixed point (yuyv.hpp, where the formulas
// are). Cost: O(pixels written), no allocation.
#include "hmdnode/hal/camera/yuyv.hpp"

#include <algorithm>
#include <cassert>

namespace hmdnode {
namespace {

uint8_t yuyv_luma(int r, int g, int b) {
    return uint8_t(((66 * r + 129 * g + 25 * b + 128) >> 8) + 16);
}
uint8_t yuyv_cb(int r, int g, int b) {
    return uint8_t(((-38 * r - 74 * g + 112 * b + 128) >> 8) + 128);
}
uint8_t yuyv_cr(int r, int g, int b) {
    return uint8_t(((112 * r - 94 * g - 18 * b + 128) >> 8) + 128);
}

}  // namespace

void fill_yuyv_black(const YuyvFrameView& f) {
    assert(f.bytes.size() >= size_t(f.bytes_per_line) * f.height);
    for (uint32_t y = 0; y < f.height; ++y) {
        uint8_t* row = f.bytes.data() + size_t(y) * f.bytes_per_line;
        for (uint32_t x = 0; x < f.width; ++x) {
            row[2 * x] = 16;
            row[2 * x + 1] = 128;
        }
    }
}

void write_rgba_to_yuyv(const ImageRGBA8& image, int x0, int y0, const YuyvFrameView& f) {
    assert(x0 % 2 == 0 && f.bytes.size() >= size_t(f.bytes_per_line) * f.height);
    const int y_begin = std::max(0, -y0), y_end = std::min(image.height, int(f.height) - y0);
    const int x_begin = std::max(0, -x0), x_end = std::min(image.width, int(f.width) - x0);
    for (int y = y_begin; y < y_end; ++y) {
        uint8_t* row = f.bytes.data() + size_t(y + y0) * f.bytes_per_line;
        for (int x = x_begin; x < x_end; x += 2) {
            const uint8_t* p0 = image.at(x, y);
            static constexpr uint8_t kBlack[4] = {0, 0, 0, 255};
            const uint8_t* p1 = x + 1 < image.width ? image.at(x + 1, y) : kBlack;
            const int r = (p0[0] + p1[0] + 1) / 2, g = (p0[1] + p1[1] + 1) / 2,
                      b = (p0[2] + p1[2] + 1) / 2;
            uint8_t* out = row + 2 * size_t(x + x0);
            out[0] = yuyv_luma(p0[0], p0[1], p0[2]);
            out[1] = yuyv_cb(r, g, b);
            if (x + x0 + 1 < int(f.width)) {
                out[2] = yuyv_luma(p1[0], p1[1], p1[2]);
                out[3] = yuyv_cr(r, g, b);
            }
        }
    }
}

}  // namespace hmdnode
