// Lightmap encodings: OpenEXR (the HDR master, through tinyexr; OpenEXR file layout per the
// "OpenEXR File Layout" document: scanline image, ZIP compression, channels sorted B, G, R), the
// glTF's scaled RGBA8 (a single global scale in MOZ_lightmap.intensity, chosen as a quantile of
// the per-texel maximum channel), and RGBM (shared-exponent-like 8-bit HDR: Karis' / Unreal's
// "RGBM color encoding" with the multiplier rounded up to the next 1/255 step so the colour
// never clamps below the range).
// Cost: O(N) per image of N texels (the quantile is nth_element, O(N) expected); memory O(N).
// Departures: RGBM here rounds m up (ceil) instead of the usual ceil-after-scale variant, to get
// the bound in lightmap_encode.hpp; no sRGB/gamma curve anywhere (the renderer samples the
// lightmap through a UNORM view, so texels are linear).
#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstring>

#include <tinyexr.h>

#include "hmdnode/bake/lightmap_encode.hpp"
#include "hmdnode/core/atomic_file.hpp"
#include "hmdnode/core/percentile.hpp"

namespace hmdnode {

namespace {

Status check_image(const HdrImage& image) {
    if (image.width <= 0 || image.height <= 0)
        return make_error("lightmap image is empty (" + std::to_string(image.width) + " x " +
                          std::to_string(image.height) + ")");
    if (image.rgb.size() != size_t(image.width) * size_t(image.height))
        return make_error("lightmap image has " + std::to_string(image.rgb.size()) +
                          " pixels, expected " +
                          std::to_string(size_t(image.width) * size_t(image.height)));
    return Status::success();
}

float clean(float v) {
    return std::isfinite(v) && v > 0.0f ? v : 0.0f;
}

uint8_t quantise(float v) {
    return uint8_t(std::lround(std::clamp(v, 0.0f, 1.0f) * 255.0f));
}

}  // namespace

Result<std::string> encode_exr(const HdrImage& image, ExrPixel pixel) {
    if (Status s = check_image(image); !s.ok()) return s.error();
    const size_t n = image.rgb.size();
    std::vector<float> planes[3];
    for (int c = 0; c < 3; ++c) {
        planes[c].resize(n);
        for (size_t i = 0; i < n; ++i) planes[c][i] = image.rgb[i][c];
    }
    // OpenEXR readers expect channels in alphabetical order: B, G, R.
    float* ptrs[3] = {planes[2].data(), planes[1].data(), planes[0].data()};
    EXRImage img;
    InitEXRImage(&img);
    img.num_channels = 3;
    img.images = reinterpret_cast<unsigned char**>(ptrs);
    img.width = image.width;
    img.height = image.height;

    EXRHeader header;
    InitEXRHeader(&header);
    EXRChannelInfo channels[3];
    std::memset(channels, 0, sizeof channels);
    std::strcpy(channels[0].name, "B");
    std::strcpy(channels[1].name, "G");
    std::strcpy(channels[2].name, "R");
    int pixel_types[3], requested[3];
    for (int c = 0; c < 3; ++c) {
        pixel_types[c] = TINYEXR_PIXELTYPE_FLOAT;  // what we pass
        requested[c] = pixel == ExrPixel::Half ? TINYEXR_PIXELTYPE_HALF : TINYEXR_PIXELTYPE_FLOAT;
    }
    header.num_channels = 3;
    header.channels = channels;
    header.pixel_types = pixel_types;
    header.requested_pixel_types = requested;
    header.compression_type = TINYEXR_COMPRESSIONTYPE_ZIP;

    unsigned char* memory = nullptr;
    const char* err = nullptr;
    const size_t size = SaveEXRImageToMemory(&img, &header, &memory, &err);
    if (size == 0) {
        std::string msg = "EXR encoding failed: ";
        msg += err ? err : "unknown tinyexr error";
        if (err) FreeEXRErrorMessage(err);
        return make_error(msg);
    }
    std::string bytes(reinterpret_cast<const char*>(memory), size);
    free(memory);
    return bytes;
}

Status write_exr(const std::filesystem::path& path, const HdrImage& image, ExrPixel pixel) {
    auto bytes = encode_exr(image, pixel);
    if (!bytes.ok()) return make_error(path.string() + ": " + bytes.error().message);
    return write_file_atomically(path, *bytes);
}

Result<HdrImage> decode_exr(const std::string& bytes, const std::string& name) {
    const auto* data = reinterpret_cast<const unsigned char*>(bytes.data());
    EXRVersion version;
    if (ParseEXRVersionFromMemory(&version, data, bytes.size()) != TINYEXR_SUCCESS)
        return make_error(name + ": not an OpenEXR file (bad magic or version)");
    if (version.multipart || version.non_image)
        return make_error(name + ": multipart or deep EXR is not supported");
    EXRHeader header;
    InitEXRHeader(&header);
    const char* err = nullptr;
    if (ParseEXRHeaderFromMemory(&header, &version, data, bytes.size(), &err) != TINYEXR_SUCCESS) {
        std::string msg = name + ": bad EXR header: " + (err ? err : "?");
        if (err) FreeEXRErrorMessage(err);
        return make_error(msg);
    }
    int idx[3] = {-1, -1, -1};
    const char* names[3] = {"R", "G", "B"};
    for (int c = 0; c < header.num_channels; ++c) {
        for (int k = 0; k < 3; ++k)
            if (std::strcmp(header.channels[c].name, names[k]) == 0) idx[k] = c;
        if (header.pixel_types[c] == TINYEXR_PIXELTYPE_HALF)
            header.requested_pixel_types[c] = TINYEXR_PIXELTYPE_FLOAT;
    }
    for (int k = 0; k < 3; ++k)
        if (idx[k] < 0) {
            FreeEXRHeader(&header);
            return make_error(name + ": EXR has no channel '" + names[k] + "'");
        }
    for (int k = 0; k < 3; ++k)
        if (header.requested_pixel_types[idx[k]] != TINYEXR_PIXELTYPE_FLOAT) {
            FreeEXRHeader(&header);
            return make_error(name + ": EXR channel '" + names[k] + "' is not float or half");
        }
    if (header.tiled) {
        FreeEXRHeader(&header);
        return make_error(name + ": tiled EXR is not supported");
    }
    EXRImage img;
    InitEXRImage(&img);
    if (LoadEXRImageFromMemory(&img, &header, data, bytes.size(), &err) != TINYEXR_SUCCESS) {
        std::string msg = name + ": EXR decoding failed: " + (err ? err : "?");
        if (err) FreeEXRErrorMessage(err);
        FreeEXRHeader(&header);
        return make_error(msg);
    }
    HdrImage out;
    out.width = img.width;
    out.height = img.height;
    out.rgb.resize(size_t(img.width) * size_t(img.height));
    for (int k = 0; k < 3; ++k) {
        const float* plane = reinterpret_cast<const float*>(img.images[idx[k]]);
        for (size_t i = 0; i < out.rgb.size(); ++i) out.rgb[i][k] = plane[i];
    }
    FreeEXRImage(&img);
    FreeEXRHeader(&header);
    return out;
}

Result<HdrImage> read_exr(const std::filesystem::path& path) {
    auto bytes = read_file(path);
    if (!bytes.ok()) return bytes.error();
    return decode_exr(*bytes, path.string());
}

ScaledRgba8 encode_scaled_rgba8(const HdrImage& image, double percentile,
                                const std::vector<uint8_t>& mask) {
    assert(percentile >= 0.0 && percentile <= 1.0);
    ScaledRgba8 out;
    const size_t n = image.rgb.size();
    std::vector<float> peaks;
    peaks.reserve(n);
    for (size_t i = 0; i < n; ++i) {
        if (!mask.empty() && (i >= mask.size() || mask[i] == 0)) continue;
        const glm::vec3& e = image.rgb[i];
        peaks.push_back(std::max({clean(e.r), clean(e.g), clean(e.b)}));
    }
    float intensity = 0.0f;
    if (!peaks.empty()) {
        intensity = percentile_in_place(peaks.begin(), peaks.end(), percentile);
    }
    if (!(intensity > 0.0f)) intensity = 1.0f;
    assert(intensity > 0.0f && std::isfinite(intensity));  // clean() kept the peaks finite
    out.intensity = intensity;
    out.rgba8.resize(n * 4);
    for (size_t i = 0; i < n; ++i) {
        const glm::vec3& e = image.rgb[i];
        bool clamped = false;
        for (int c = 0; c < 3; ++c) {
            const float v = clean(e[c]) / intensity;
            clamped |= v > 1.0f + 0.5f / 255.0f;
            out.rgba8[4 * i + size_t(c)] = quantise(v);
        }
        out.rgba8[4 * i + 3] = 255;
        out.clamped += clamped ? 1 : 0;
    }
    return out;
}

HdrImage decode_scaled_rgba8(const std::vector<uint8_t>& rgba8, int width, int height,
                             float intensity) {
    assert(width >= 0 && height >= 0 && intensity >= 0.0f);
    HdrImage out;
    out.width = width;
    out.height = height;
    out.rgb.resize(size_t(width) * size_t(height));
    for (size_t i = 0; i < out.rgb.size() && 4 * i + 3 < rgba8.size(); ++i)
        for (int c = 0; c < 3; ++c)
            out.rgb[i][c] = float(rgba8[4 * i + size_t(c)]) / 255.0f * intensity;
    return out;
}

Result<float> store_lightmap(Scene& scene, int texture, const HdrImage& image, double percentile,
                             const std::vector<uint8_t>& mask, LightmapEncoding encoding) {
    if (texture < 0 || size_t(texture) >= scene.textures.size())
        return make_error("lightmap texture " + std::to_string(texture) + " out of range (" +
                          std::to_string(scene.textures.size()) + " textures)");
    if (Status s = check_image(image); !s.ok()) return s.error();
    ScaledRgba8 enc = encode_scaled_rgba8(image, percentile, mask);
    Texture& t = scene.textures[size_t(texture)];
    t.width = image.width;
    t.height = image.height;
    t.rgba8 = encoding == LightmapEncoding::Rgbm ? encode_rgbm(image, enc.intensity)
                                                 : std::move(enc.rgba8);
    for (Material& m : scene.materials)
        if (m.lightmap.texture == texture) {
            m.lightmap.intensity = enc.intensity;
            m.lightmap.encoding = encoding;
        }
    return enc.intensity;
}

std::vector<uint8_t> encode_rgbm(const HdrImage& image, float range) {
    assert(range > 0.0f && std::isfinite(range));
    std::vector<uint8_t> out(image.rgb.size() * 4);
    for (size_t i = 0; i < image.rgb.size(); ++i) {
        glm::vec3 e(clean(image.rgb[i].r), clean(image.rgb[i].g), clean(image.rgb[i].b));
        e = glm::min(e, glm::vec3(range));
        const float peak = std::max({e.r, e.g, e.b});
        const int k = std::clamp(int(std::ceil(255.0f * peak / range - 1e-4f)), 1, 255);
        const float m = float(k) / 255.0f;
        assert(k >= 1 && k <= 255 && m * range >= peak * (1.0f - 1e-3f));  // m never clamps E
        for (int c = 0; c < 3; ++c) out[4 * i + size_t(c)] = quantise(e[c] / (m * range));
        out[4 * i + 3] = uint8_t(k);
    }
    return out;
}

HdrImage decode_rgbm(const std::vector<uint8_t>& rgba8, int width, int height, float range) {
    assert(width >= 0 && height >= 0 && range > 0.0f);
    HdrImage out;
    out.width = width;
    out.height = height;
    out.rgb.resize(size_t(width) * size_t(height));
    for (size_t i = 0; i < out.rgb.size() && 4 * i + 3 < rgba8.size(); ++i) {
        const float m = float(rgba8[4 * i + 3]) / 255.0f;
        for (int c = 0; c < 3; ++c)
            out.rgb[i][c] = float(rgba8[4 * i + size_t(c)]) / 255.0f * m * range;
    }
    return out;
}

}  // namespace hmdnode
