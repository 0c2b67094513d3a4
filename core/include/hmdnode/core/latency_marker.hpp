// The latency marker: a small binary code the lens pass draws into the panel image (render/) and
// the camera observer reads back from what a camera filmed (firmware_host/), so that motion-to-
// photon latency can be measured from the panel's own light (docs/latency.md, "The observer").
// Both ends need the one definition of the format, so it lives in core.
//
// Format (a square of 14 x 14 cells, cell_px panel pixels each, rows top to bottom):
//   ring 0   quiet zone, black: separates the marker from whatever the scene shows around it
//   ring 1   guard, white: the finder pattern (a square ring, found as one bright component)
//   ring 2   separator, black: keeps the data cells from touching the guard
//   8 x 8    data cells, white = 1: 64 bits, row-major from the top-left cell, most significant
//            bit first: sample time (32 bits: the tracker sample's host time in microseconds,
//            modulo 2^32), present sequence (16 bits, modulo 2^16), then a CRC-16/CCITT-FALSE
//            (polynomial 0x1021, initial value 0xFFFF, no reflection, no final xor) over the six
//            payload bytes, big-endian.
// Pixels are pure black (0) or pure white (255) in every channel, so the marker is the same bytes
// in any 8-bit RGBA/BGRA/XRGB panel format and its drawing is exact on every backend.
//
// Decoding (decode_latency_marker) follows QR-code practice (ISO/IEC 18004: finder pattern,
// quiet zone, sampling at module centres, a checksum): threshold the region between its 0.1st
// and 99.9th percentile (at half, then 0.3, 0.7, 0.15 of the way: a small marker dimmer than the
// scene's highlights separates only at a lower one), find bright 4-connected components shaped like
// the guard ring (square bounding box, every pixel within 1.6 cells of the box's edge), take the
// cell grid from the ring's box, measure the white and black references on the guard and separator
// cells of each row of cells (the adaptive threshold: a rolling scan-out or shutter, or a lens's
// vignetting, lights rows unevenly), read each cell from the mean of its central half, and accept
// only when every guard, separator and data cell is clearly on its side of the threshold (a margin
// of a fifth of the contrast) and the CRC matches. Anything else is reported, never guessed: a
// camera exposure that saw two markers leaves cells half-lit, which the margin rejects.
//
// Cost: encoding O(1), no allocation (rects into a caller's span); drawing O(marker pixels);
// decoding O(region pixels), allocating one label per pixel.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>

#include "hmdnode/core/image.hpp"

namespace hmdnode {

inline constexpr int kLatencyMarkerDataCells = 8;                // data cells per side
inline constexpr int kLatencyMarkerCells = 8 + 6;                // cells per side, rings included
inline constexpr size_t kLatencyMarkerMaxRects = 1 + 4 + 8 * 4;  // background, guard, data runs

struct LatencyMarkerPayload {
    uint32_t sample_time_us = 0;    // the sample's host time in microseconds, modulo 2^32
    uint16_t present_sequence = 0;  // the present's index, modulo 2^16
    bool operator==(const LatencyMarkerPayload&) const = default;
};

// The payload of a sample's host time (ns, >= 0) and a present's index.
LatencyMarkerPayload make_latency_marker_payload(int64_t sample_time_ns, uint64_t present_index);

// CRC-16/CCITT-FALSE of `bytes` (check value of "123456789": 0x29B1).
uint16_t latency_marker_crc(std::span<const uint8_t> bytes);

// The 64 data bits (payload and CRC), the first data cell's bit the most significant.
uint64_t latency_marker_bits(const LatencyMarkerPayload& payload);

// One axis-aligned rectangle of marker pixels, in pixels of the image it is drawn into.
struct LatencyMarkerRect {
    int x = 0, y = 0, width = 0, height = 0;
    bool white = false;
};

// The marker at top-left (x0, y0), cell_px (>= 1) pixels per cell, as rectangles to fill in order:
// first the whole marker black, then the white guard ring (four rects) and the white runs of each
// data row. Returns how many of `out` (at least kLatencyMarkerMaxRects) it filled. Allocates
// nothing: for the frame path.
size_t latency_marker_rects(const LatencyMarkerPayload& payload, int x0, int y0, int cell_px,
                            std::span<LatencyMarkerRect> out);

// Side of the marker in pixels.
constexpr int latency_marker_size_px(int cell_px) {
    return kLatencyMarkerCells * cell_px;
}

// Draws the marker into `image` (the CPU reference of what the lens pass draws; rects outside
// the image are clipped).
void draw_latency_marker(ImageRGBA8& image, const LatencyMarkerPayload& payload, int x0, int y0,
                         int cell_px);

struct LatencyMarkerDecode {
    bool ok = false;
    LatencyMarkerPayload payload;
    std::string reason;       // why not, when !ok
    double x = 0.0, y = 0.0;  // centre of the marker in the region, pixels
    double cell_px = 0.0;     // the cell size found
    double contrast = 0.0;    // white reference - black reference, grey levels
};

// Reads a marker from an 8-bit grey region (`stride` bytes per row, rows top to bottom). The
// marker must appear upright (rotated by at most a few degrees) with cells of at least 3 pixels.
LatencyMarkerDecode decode_latency_marker(const uint8_t* grey, int width, int height, int stride);

// Luma (BT.601, integer) of an RGBA8 image, for decoding a panel image.
std::vector<uint8_t> grey_of(const ImageRGBA8& image);

}  // namespace hmdnode
