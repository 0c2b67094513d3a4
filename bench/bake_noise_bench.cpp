// Lightmap noise of the demo room at its build-time bake settings (demo_bake_options(),
// firmware_host/src/tool/demo_scene.hpp), before and after the firefly clamp moved to the indirect
// part and the indirect light got its own variance-guided filter: isolated bright texels
// (lightmap_noise.hpp; on the lightmap as shipped, RGBM-decoded) and a crop of the atlas around
// the worst 128 x 128 window of "before", for docs/baking.md "Noise" (the table in
// docs/results/bake-noise-bench.md).
//
// usage: bench_bake_noise_bench [demo_room.glb] [threads] [--write-docs]
//   (default: the built demo scene, all cores; --write-docs: the table into
//   docs/results/bake-noise-bench.md and the crops to docs/images/bake_noise_{before,after}.png)
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "doc_table.hpp"
#include "hmdnode/bake/bake.hpp"
#include "hmdnode/bake/lightmap_encode.hpp"
#include "hmdnode/bake/lightmap_noise.hpp"
#include "hmdnode/core/gltf.hpp"
#include "hmdnode/core/image.hpp"
#include "tool/demo_scene.hpp"

using namespace hmdnode;

namespace {

struct Baked {
    HdrImage shipped;  // the lightmap as the .glb holds it, decoded
    std::vector<uint8_t> filled;
    size_t isolated = 0, isolated_raw = 0;
    float intensity = 1.0f;
    double seconds = 0.0;
};

bool bake(const std::string& path, const BakeOptions& options, Baked& out) {
    Result<Scene> scene = load_gltf(path);
    if (!scene) {
        std::fprintf(stderr, "%s: %s\n", path.c_str(), scene.error().message.c_str());
        return false;
    }
    Result<BakeReport> r = bake_scene(*scene, options);
    if (!r || r->maps.empty()) {
        std::fprintf(stderr, "bake: %s\n", r ? "no lightmap" : r.error().message.c_str());
        return false;
    }
    const BakedMap& m = r->maps[0];
    const Texture& t = scene->textures[size_t(m.texture)];
    out.shipped = decode_rgbm(t.rgba8, t.width, t.height, m.intensity);
    out.filled.assign(out.shipped.rgb.size(), 0);
    for (size_t i = 0; i < out.filled.size(); ++i)
        out.filled[i] = glm::max(out.shipped.rgb[i].r,
                                 glm::max(out.shipped.rgb[i].g, out.shipped.rgb[i].b)) > 0.0f;
    out.isolated = count_isolated_bright_texels(out.shipped.rgb, out.filled, t.width, t.height);
    out.isolated_raw = count_isolated_bright_texels(m.raw, m.valid, m.width, m.height);
    out.intensity = m.intensity;
    out.seconds = r->seconds;
    return true;
}

// The 128 x 128 window (on a 32-texel grid) with the most isolated bright texels.
void worst_window(const Baked& b, int& wx, int& wy) {
    const int w = b.shipped.width, h = b.shipped.height, s = std::min({128, w, h});
    size_t best = 0;
    wx = wy = 0;
    for (int y = 0; y + s <= h; y += 32)
        for (int x = 0; x + s <= w; x += 32) {
            std::vector<glm::vec3> crop(size_t(s) * s);
            std::vector<uint8_t> f(crop.size());
            for (int j = 0; j < s; ++j)
                for (int i = 0; i < s; ++i) {
                    const size_t src = size_t(y + j) * w + (x + i);
                    crop[size_t(j) * s + i] = b.shipped.rgb[src];
                    f[size_t(j) * s + i] = b.filled[src];
                }
            const size_t c = count_isolated_bright_texels(crop, f, s, s);
            if (c > best) best = c, wx = x, wy = y;
        }
}

// The window, 3x nearest, E / scale through the sRGB curve.
ImageRGBA8 crop_png(const Baked& b, int wx, int wy, float scale) {
    const int s = std::min({128, b.shipped.width, b.shipped.height}), z = 3;
    ImageRGBA8 img;
    img.width = img.height = s * z;
    img.pixels.assign(size_t(img.width) * img.height * 4, 255);
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x) {
            const glm::vec3 e = b.shipped.rgb[size_t(wy + y / z) * b.shipped.width + (wx + x / z)];
            for (int c = 0; c < 3; ++c) {
                const float v = std::clamp(e[c] / scale, 0.0f, 1.0f);
                const float srgb =
                    v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1 / 2.4f) - 0.055f;
                img.pixels[(size_t(y) * img.width + x) * 4 + c] = uint8_t(std::lround(srgb * 255));
            }
        }
    return img;
}

}  // namespace

int main(int argc, char** argv) {
    const bool write_docs = bench::wants_docs(argc, argv);
    std::vector<std::string> args;
    for (int i = 1; i < argc; ++i)
        if (std::string(argv[i]) != "--write-docs") args.push_back(argv[i]);
    const std::string path = !args.empty() ? args[0] : HMDNODE_BINARY_DIR "/data/demo_room.glb";
    const int threads = args.size() > 1 ? std::atoi(args[1].c_str()) : 0;
    std::string command = "build/release/bench/bench_bake_noise_bench";
    for (const std::string& a : args) command += ' ' + bench::in_tree(a);
    if (write_docs) command += " --write-docs";

    BakeOptions after = demo_bake_options();
    after.threads = threads;
    BakeOptions before = after;  // the demo's settings before the split
    before.firefly_factor = 4.0f;
    before.firefly_indirect_only = false;
    before.indirect_denoise_iterations = 0;
    const std::string machine = bench::machine_facts();
    Baked b, a;
    if (!bake(path, before, b) || !bake(path, after, a)) return 1;
    int wx = 0, wy = 0;
    worst_window(b, wx, wy);

    char buf[2048];
    const std::string measured_by =
        "Measured by `" + command + "` (" + bench::build_kind() + "; " + machine + "): ";
    // The results file names the command and the machine in its header: it holds the rest.
    std::string out =
        "the demo room rebaked at its build-time settings (32 paths per texel, "
        "firefly factor 8 (before: 4), 5 filter passes, 2 bounces), one 512 x 512 lightmap; "
        "isolated bright texels (above 1.3 x each of their 8 neighbours) counted on "
        "the lightmap as the .glb ships it (RGBM decoded) and on the unfiltered "
        "estimate:\n\n"
        "| settings | isolated bright texels (shipped) | unfiltered | bake (s) |\n"
        "|---|---|---|---|\n";
    std::snprintf(
        buf, sizeof buf,
        "| before: whole paths clamped at 4x, one edge-aware A-trous over direct + indirect "
        "| %zu | %zu | %.1f |\n"
        "| after: indirect part clamped at 8x, direct and indirect filtered apart (variance-guided "
        "A-trous on the indirect) | %zu | %zu | %.1f |\n",
        b.isolated, b.isolated_raw, b.seconds, a.isolated, a.isolated_raw, a.seconds);
    out += buf;
    std::snprintf(buf, sizeof buf,
                  "\nCrops (`docs/images/bake_noise_before.png`, `bake_noise_after.png`): atlas "
                  "texels [%d, %d) x [%d, %d), the 128 x 128 window with the most isolated "
                  "texels before, 3x nearest, E / %.2f through the sRGB curve.\n",
                  wx, wx + 128, wy, wy + 128, a.intensity);
    out += buf;
    std::fputs((measured_by + out).c_str(), stdout);
    if (write_docs) {
        if (Status s = write_png(crop_png(b, wx, wy, a.intensity),
                                 HMDNODE_SOURCE_DIR "/docs/images/bake_noise_before.png");
            !s.ok())
            return std::fprintf(stderr, "%s\n", s.error().message.c_str()), 1;
        if (Status s = write_png(crop_png(a, wx, wy, a.intensity),
                                 HMDNODE_SOURCE_DIR "/docs/images/bake_noise_after.png");
            !s.ok())
            return std::fprintf(stderr, "%s\n", s.error().message.c_str()), 1;
        out[0] = 'T';  // "The demo room rebaked ..."
        if (!bench::write_result("bake-noise-bench",
                                 "Lightmap noise of the demo room, before and after the indirect "
                                 "light's own clamp and filter",
                                 command, out))
            return 1;
        std::fprintf(stderr, "bake noise bench: wrote the crops\n");
    }
    return 0;
}
