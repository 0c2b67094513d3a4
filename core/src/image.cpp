#include "hmdnode/core/image.hpp"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <system_error>

#include <stb_image.h>
#include <stb_image_write.h>

#include "hmdnode/core/atomic_file.hpp"

namespace hmdnode {

std::string encode_png(const uint8_t* rgba, int width, int height) {
    std::string out;
    auto append = [](void* ctx, void* data, int size) {
        static_cast<std::string*>(ctx)->append(static_cast<const char*>(data), size_t(size));
    };
    if (!stbi_write_png_to_func(append, &out, width, height, 4, rgba, width * 4)) out.clear();
    return out;
}

std::string encode_jpeg(const uint8_t* pixels, int width, int height, int channels, int quality) {
    std::string out;
    if (!pixels || width <= 0 || height <= 0 || channels < 1 || channels > 4) return out;
    auto append = [](void* ctx, void* data, int size) {
        static_cast<std::string*>(ctx)->append(static_cast<const char*>(data), size_t(size));
    };
    if (!stbi_write_jpg_to_func(append, &out, width, height, channels, pixels,
                                std::clamp(quality, 1, 100)))
        out.clear();
    return out;
}

Result<GreyImage> decode_image_grey(const std::string& bytes) {
    int w = 0, h = 0, n = 0;
    unsigned char* data = stbi_load_from_memory(
        reinterpret_cast<const stbi_uc*>(bytes.data()),
        int(std::min<size_t>(bytes.size(), size_t(INT32_MAX))), &w, &h, &n, 1);
    if (!data) return make_error(std::string("cannot decode image: ") + stbi_failure_reason());
    GreyImage img;
    img.width = w;
    img.height = h;
    img.pixels.assign(data, data + size_t(w) * h);
    stbi_image_free(data);
    return img;
}

Status write_png(const ImageRGBA8& image, const std::filesystem::path& path) {
    if (image.empty() || image.pixels.size() != size_t(image.width) * image.height * 4)
        return make_error(path.string() + ": cannot write an empty or inconsistent image");
    std::string png = encode_png(image);
    if (png.empty()) return make_error(path.string() + ": PNG encoding failed");
    return write_file_atomically(path, png);
}

ImageRGBA8 side_by_side(const StereoImage& stereo) {
    const ImageRGBA8& l = stereo.eye[0];
    const ImageRGBA8& r = stereo.eye[1];
    ImageRGBA8 out;
    out.width = l.width + r.width;
    out.height = std::max(l.height, r.height);
    out.pixels.assign(size_t(out.width) * out.height * 4, 0);
    for (int y = 0; y < out.height; ++y) {
        if (y < l.height) std::memcpy(out.at(0, y), l.at(0, y), size_t(l.width) * 4);
        if (y < r.height) std::memcpy(out.at(l.width, y), r.at(0, y), size_t(r.width) * 4);
    }
    return out;
}

Result<ImageRGBA8> read_image(const std::filesystem::path& path) {
    int w = 0, h = 0, n = 0;
    unsigned char* data = stbi_load(path.c_str(), &w, &h, &n, 4);
    if (!data) return make_error(path.string() + ": cannot read image: " + stbi_failure_reason());
    ImageRGBA8 img;
    img.width = w;
    img.height = h;
    img.pixels.assign(data, data + size_t(w) * h * 4);
    stbi_image_free(data);
    return img;
}

}  // namespace hmdnode
