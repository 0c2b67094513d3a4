// The latency marker's encoder and decoder (format and method: latency_marker.hpp; finder
// pattern, quiet zone and module sampling after ISO/IEC 18004, the QR code). Cost: encoding O(1);
// decoding O(region pixels) for the threshold, the labels and the components, O(cells) per
// candidate ring.
#include "hmdnode/core/latency_marker.hpp"

#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <vector>

namespace hmdnode {
namespace {

constexpr int kGuardRing = 1, kSeparatorRing = 2, kDataOrigin = 3;
constexpr int kRingCells = kLatencyMarkerCells - 2;  // the guard ring's outer box, in cells
constexpr double kMarginOfContrast = 0.2;
constexpr double kMinContrast = 24.0;
constexpr int kMinCellPx = 3;

int ring_of(int cx, int cy) {
    return std::min({cx, cy, kLatencyMarkerCells - 1 - cx, kLatencyMarkerCells - 1 - cy});
}

// The mean grey of the central half of a cell whose box is [x0, x0 + w) x [y0, y0 + h).
double cell_mean(const uint8_t* grey, int width, int height, int stride, double x0, double y0,
                 double w, double h) {
    const int ax = int(std::floor(x0 + 0.25 * w)), bx = int(std::ceil(x0 + 0.75 * w));
    const int ay = int(std::floor(y0 + 0.25 * h)), by = int(std::ceil(y0 + 0.75 * h));
    double sum = 0.0;
    int n = 0;
    for (int y = std::max(ay, 0); y < std::min(by, height); ++y)
        for (int x = std::max(ax, 0); x < std::min(bx, width); ++x) {
            sum += grey[size_t(y) * stride + x];
            ++n;
        }
    return n ? sum / n : -1.0;
}

struct Box {
    int x0 = 0, y0 = 0, x1 = 0, y1 = 0;  // inclusive
    size_t area = 0;
};

// Reads the cells of the marker whose guard ring's outer box is `b` (pixels, inclusive).
LatencyMarkerDecode read_cells(const uint8_t* grey, int width, int height, int stride,
                               const Box& b) {
    LatencyMarkerDecode d;
    const double cw = double(b.x1 + 1 - b.x0) / kRingCells,
                 ch = double(b.y1 + 1 - b.y0) / kRingCells;
    d.cell_px = 0.5 * (cw + ch);
    d.x = b.x0 + 0.5 * (b.x1 + 1 - b.x0);
    d.y = b.y0 + 0.5 * (b.y1 + 1 - b.y0);
    // Cell (cx, cy) of the whole marker: the guard's box starts at cell 1.
    auto mean = [&](int cx, int cy) {
        return cell_mean(grey, width, height, stride, b.x0 + (cx - 1) * cw, b.y0 + (cy - 1) * ch,
                         cw, ch);
    };
    // The references: the whole guard ring and separator, and per row of cells the guard and
    // separator cells of that row (a rolling scan-out or shutter lights rows unevenly).
    double white = 0.0, black = 0.0;
    int nw = 0, nb = 0;
    for (int cy = 1; cy < kLatencyMarkerCells - 1; ++cy)
        for (int cx = 1; cx < kLatencyMarkerCells - 1; ++cx) {
            const int r = ring_of(cx, cy);
            if (r == kGuardRing) white += mean(cx, cy), ++nw;
            if (r == kSeparatorRing) black += mean(cx, cy), ++nb;
        }
    white /= nw;
    black /= nb;
    d.contrast = white - black;
    if (d.contrast < kMinContrast) {
        d.reason =
            "guard pattern without contrast (" + std::to_string(int(d.contrast)) + " grey levels)";
        return d;
    }
    uint64_t bits = 0;
    for (int cy = 1; cy < kLatencyMarkerCells - 1; ++cy) {
        const int n = kLatencyMarkerCells;
        const double row_white = 0.5 * (mean(1, cy) + mean(n - 2, cy));
        const double row_black =
            cy == 1 || cy == n - 2 ? black : 0.5 * (mean(2, cy) + mean(n - 3, cy));
        const double contrast = row_white - row_black;
        if (contrast < 0.5 * kMinContrast) {
            d.reason = "cell row " + std::to_string(cy) + " without contrast (" +
                       std::to_string(int(contrast)) + " grey levels)";
            return d;
        }
        const double mid = 0.5 * (row_white + row_black), margin = kMarginOfContrast * contrast;
        for (int cx = 1; cx < n - 1; ++cx) {
            const int r = ring_of(cx, cy);
            const double v = mean(cx, cy);
            if (std::abs(v - mid) < margin) {
                d.reason = std::string(r == kGuardRing       ? "guard"
                                       : r == kSeparatorRing ? "separator"
                                                             : "data") +
                           " cell (" + std::to_string(cx) + ", " + std::to_string(cy) +
                           ") neither black nor white";
                return d;
            }
            const bool is_white = v > mid;
            if ((r == kGuardRing && !is_white) || (r == kSeparatorRing && is_white)) {
                d.reason = "guard pattern broken at cell (" + std::to_string(cx) + ", " +
                           std::to_string(cy) + ")";
                return d;
            }
            if (r >= kDataOrigin) bits = (bits << 1) | (is_white ? 1u : 0u);
        }
    }
    const uint8_t bytes[6] = {uint8_t(bits >> 56), uint8_t(bits >> 48), uint8_t(bits >> 40),
                              uint8_t(bits >> 32), uint8_t(bits >> 24), uint8_t(bits >> 16)};
    if (latency_marker_crc(bytes) != uint16_t(bits & 0xffff)) {
        d.reason = "checksum mismatch";
        return d;
    }
    d.payload.sample_time_us = uint32_t(bits >> 32);
    d.payload.present_sequence = uint16_t(bits >> 16);
    d.ok = true;
    return d;
}

// Whether the component of `label` inside box b is a ring: every pixel within 1.6 cells of the
// box's edge, and it covers a plausible share of the box.
bool ring_shaped(const std::vector<int>& labels, int width, int label, const Box& b) {
    const int w = b.x1 + 1 - b.x0, h = b.y1 + 1 - b.y0;
    if (w < kRingCells * kMinCellPx || h < kRingCells * kMinCellPx) return false;
    if (std::abs(w - h) > 0.15 * std::max(w, h)) return false;
    const double fill = double(b.area) / (double(w) * h);
    if (fill < 0.15 || fill > 0.55) return false;
    const double band_x = 1.6 * w / kRingCells, band_y = 1.6 * h / kRingCells;
    for (int y = b.y0; y <= b.y1; ++y)
        for (int x = b.x0; x <= b.x1; ++x) {
            if (labels[size_t(y) * width + x] != label) continue;
            const double dx = std::min(x - b.x0, b.x1 - x), dy = std::min(y - b.y0, b.y1 - y);
            if (dx > band_x && dy > band_y) return false;
        }
    return true;
}

// Bright (> threshold) 4-connected components of the region, with their bounding boxes.
void label_components(const uint8_t* grey, int width, int height, int stride, int threshold,
                      std::vector<int>& labels, std::vector<Box>& boxes,
                      std::vector<size_t>& stack) {
    const size_t total = size_t(width) * height;
    for (size_t seed = 0; seed < total; ++seed) {
        const int sx = int(seed % size_t(width)), sy = int(seed / size_t(width));
        if (labels[seed] != -1 || grey[size_t(sy) * stride + sx] <= threshold) continue;
        const int label = int(boxes.size());
        Box b{sx, sy, sx, sy, 0};
        labels[seed] = label;
        stack.push_back(seed);
        while (!stack.empty()) {
            const size_t i = stack.back();
            stack.pop_back();
            const int x = int(i % size_t(width)), y = int(i / size_t(width));
            ++b.area;
            b.x0 = std::min(b.x0, x), b.x1 = std::max(b.x1, x);
            b.y0 = std::min(b.y0, y), b.y1 = std::max(b.y1, y);
            const int nx[4] = {x - 1, x + 1, x, x}, ny[4] = {y, y, y - 1, y + 1};
            for (int k = 0; k < 4; ++k) {
                if (nx[k] < 0 || ny[k] < 0 || nx[k] >= width || ny[k] >= height) continue;
                const size_t j = size_t(ny[k]) * width + nx[k];
                if (labels[j] != -1 || grey[size_t(ny[k]) * stride + nx[k]] <= threshold) continue;
                labels[j] = label;
                stack.push_back(j);
            }
        }
        boxes.push_back(b);
    }
}

}  // namespace

LatencyMarkerPayload make_latency_marker_payload(int64_t sample_time_ns, uint64_t present_index) {
    assert(sample_time_ns >= 0);
    LatencyMarkerPayload p;
    p.sample_time_us = uint32_t(uint64_t(sample_time_ns / 1000) & 0xffffffffu);
    p.present_sequence = uint16_t(present_index & 0xffffu);
    return p;
}

uint16_t latency_marker_crc(std::span<const uint8_t> bytes) {
    uint16_t crc = 0xffff;
    for (uint8_t byte : bytes) {
        crc ^= uint16_t(byte) << 8;
        for (int i = 0; i < 8; ++i)
            crc = (crc & 0x8000) ? uint16_t((crc << 1) ^ 0x1021) : uint16_t(crc << 1);
    }
    return crc;
}

uint64_t latency_marker_bits(const LatencyMarkerPayload& p) {
    const uint8_t bytes[6] = {uint8_t(p.sample_time_us >> 24),  uint8_t(p.sample_time_us >> 16),
                              uint8_t(p.sample_time_us >> 8),   uint8_t(p.sample_time_us),
                              uint8_t(p.present_sequence >> 8), uint8_t(p.present_sequence)};
    return (uint64_t(p.sample_time_us) << 32) | (uint64_t(p.present_sequence) << 16) |
           latency_marker_crc(bytes);
}

size_t latency_marker_rects(const LatencyMarkerPayload& payload, int x0, int y0, int cell_px,
                            std::span<LatencyMarkerRect> out) {
    assert(cell_px >= 1 && out.size() >= kLatencyMarkerMaxRects);
    const int c = cell_px, n = kLatencyMarkerCells;
    size_t k = 0;
    out[k++] = {x0, y0, n * c, n * c, false};
    // The guard ring: top and bottom rows, then the left and right columns between them.
    out[k++] = {x0 + c, y0 + c, (n - 2) * c, c, true};
    out[k++] = {x0 + c, y0 + (n - 2) * c, (n - 2) * c, c, true};
    out[k++] = {x0 + c, y0 + 2 * c, c, (n - 4) * c, true};
    out[k++] = {x0 + (n - 2) * c, y0 + 2 * c, c, (n - 4) * c, true};
    const uint64_t bits = latency_marker_bits(payload);
    for (int row = 0; row < kLatencyMarkerDataCells; ++row) {
        const int shift = 64 - kLatencyMarkerDataCells * (row + 1);
        const unsigned byte = unsigned(bits >> shift) & 0xffu;
        for (int col = 0; col < kLatencyMarkerDataCells;) {
            if (!(byte & (0x80u >> col))) {
                ++col;
                continue;
            }
            int end = col;
            while (end < kLatencyMarkerDataCells && (byte & (0x80u >> end))) ++end;
            out[k++] = {x0 + (kDataOrigin + col) * c, y0 + (kDataOrigin + row) * c, (end - col) * c,
                        c, true};
            col = end;
        }
    }
    assert(k <= kLatencyMarkerMaxRects);
    return k;
}

void draw_latency_marker(ImageRGBA8& image, const LatencyMarkerPayload& payload, int x0, int y0,
                         int cell_px) {
    std::array<LatencyMarkerRect, kLatencyMarkerMaxRects> rects;
    const size_t n = latency_marker_rects(payload, x0, y0, cell_px, rects);
    for (size_t i = 0; i < n; ++i) {
        const LatencyMarkerRect& r = rects[i];
        const uint8_t v = r.white ? 255 : 0;
        for (int y = std::max(r.y, 0); y < std::min(r.y + r.height, image.height); ++y)
            for (int x = std::max(r.x, 0); x < std::min(r.x + r.width, image.width); ++x) {
                uint8_t* p = image.at(x, y);
                p[0] = p[1] = p[2] = v;
                p[3] = 255;
            }
    }
}

std::vector<uint8_t> grey_of(const ImageRGBA8& image) {
    std::vector<uint8_t> grey(size_t(image.width) * image.height);
    for (size_t i = 0; i < grey.size(); ++i) {
        const uint8_t* p = &image.pixels[i * 4];
        grey[i] = uint8_t((77u * p[0] + 150u * p[1] + 29u * p[2] + 128u) >> 8);
    }
    return grey;
}

LatencyMarkerDecode decode_latency_marker(const uint8_t* grey, int width, int height, int stride) {
    LatencyMarkerDecode fail;
    if (!grey || width <= 0 || height <= 0 || stride < width) {
        fail.reason = "empty region";
        return fail;
    }
    // The global threshold: midway between the 2nd and 98th percentile of the region.
    std::array<size_t, 256> hist{};
    for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x) ++hist[grey[size_t(y) * stride + x]];
    const size_t total = size_t(width) * height;
    auto level = [&](double p) {
        size_t acc = 0;
        for (int v = 0; v < 256; ++v)
            if ((acc += hist[size_t(v)]) >= size_t(p * double(total))) return v;
        return 255;
    };
    const int lo = level(0.001), hi = level(0.999);
    if (hi - lo < kMinContrast) {
        fail.reason = "no marker: the region has no contrast";
        return fail;
    }
    // Thresholds from the middle outwards: a small marker dimmer than the scene's highlights
    // separates only at a lower one.
    LatencyMarkerDecode first;
    first.reason = "no marker: no guard pattern in the region";
    bool have_first = false;
    std::vector<int> labels(total);
    std::vector<Box> boxes;
    std::vector<size_t> stack;
    for (double f : {0.5, 0.3, 0.7, 0.15}) {
        const int threshold = lo + int(f * (hi - lo));
        std::fill(labels.begin(), labels.end(), -1);
        boxes.clear();
        label_components(grey, width, height, stride, threshold, labels, boxes, stack);
        std::vector<int> rings;
        for (int i = 0; i < int(boxes.size()); ++i)
            if (ring_shaped(labels, width, i, boxes[size_t(i)])) rings.push_back(i);
        std::sort(rings.begin(), rings.end(),
                  [&](int x, int y) { return boxes[size_t(x)].area > boxes[size_t(y)].area; });
        for (int r : rings) {
            LatencyMarkerDecode d = read_cells(grey, width, height, stride, boxes[size_t(r)]);
            if (d.ok) return d;
            if (!have_first) first = d, have_first = true;
        }
    }
    return first;
}

}  // namespace hmdnode
