// CPU images: 8-bit RGBA, rows top to bottom, tightly packed.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "hmdnode/core/result.hpp"

namespace hmdnode {

struct ImageRGBA8 {
    int width = 0;
    int height = 0;
    std::vector<uint8_t> pixels;  // width * height * 4

    bool empty() const { return width == 0 || height == 0; }
    const uint8_t* at(int x, int y) const { return &pixels[(size_t(y) * width + x) * 4]; }
    uint8_t* at(int x, int y) { return &pixels[(size_t(y) * width + x) * 4]; }
};

// A stereo frame: two eyes of equal size, eye 0 = left, eye 1 = right.
struct StereoImage {
    ImageRGBA8 eye[2];
};

// PNG bytes of an RGBA8 image (empty on failure).
std::string encode_png(const uint8_t* rgba, int width, int height);
inline std::string encode_png(const ImageRGBA8& image) {
    return encode_png(image.pixels.data(), image.width, image.height);
}
// Writes a PNG atomically (temporary file, then rename).
Status write_png(const ImageRGBA8& image, const std::filesystem::path& path);
// Both eyes side by side, left eye on the left.
ImageRGBA8 side_by_side(const StereoImage& stereo);
// JPEG bytes (baseline, stb_image_write) of 8-bit pixels with 1 (grey), 3 (RGB) or 4 (RGBA, alpha
// dropped) channels, tightly packed; quality 1..100. Empty on failure.
std::string encode_jpeg(const uint8_t* pixels, int width, int height, int channels, int quality);
// Decodes PNG/JPEG bytes in memory to 8-bit grey (luma). Errors: bytes stb cannot decode.
struct GreyImage {
    int width = 0, height = 0;
    std::vector<uint8_t> pixels;  // width * height, rows top to bottom
};
Result<GreyImage> decode_image_grey(const std::string& bytes);
// Reads any PNG/JPEG stb understands, converted to RGBA8.
Result<ImageRGBA8> read_image(const std::filesystem::path& path);

}  // namespace hmdnode
