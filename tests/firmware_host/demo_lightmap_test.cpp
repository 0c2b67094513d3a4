// The demo room's lightmap as the build ships it (HMDNODE_DEMO_SCENE, baked at
// demo_bake_options()): at most 20 isolated bright texels (lightmap_noise.hpp, docs/baking.md
// "Noise"), counted on the RGBM-decoded texels wherever a texel and its 8 neighbours hold light.
#include <gtest/gtest.h>

#include <cstdio>

#include "hmdnode/bake/lightmap_encode.hpp"
#include "hmdnode/bake/lightmap_noise.hpp"
#include "hmdnode/core/gltf.hpp"

namespace hmdnode {
namespace {

TEST(DemoLightmap, AtMostTwentyIsolatedBrightTexels) {
    Result<Scene> scene = load_gltf(HMDNODE_DEMO_SCENE);
    ASSERT_TRUE(scene.ok()) << scene.error().message;
    std::vector<int> maps;
    float intensity = 1.0f;
    for (const Material& m : scene->materials)
        if (m.lightmap.texture >= 0 && m.lightmap.encoding == LightmapEncoding::Rgbm) {
            if (std::find(maps.begin(), maps.end(), m.lightmap.texture) == maps.end())
                maps.push_back(m.lightmap.texture);
            intensity = m.lightmap.intensity;
        }
    ASSERT_FALSE(maps.empty()) << "the demo scene has no RGBM lightmap";
    size_t isolated = 0, lit = 0;
    for (int t : maps) {
        const Texture& tex = scene->textures[size_t(t)];
        const HdrImage e = decode_rgbm(tex.rgba8, tex.width, tex.height, intensity);
        std::vector<uint8_t> filled(e.rgb.size());
        for (size_t i = 0; i < filled.size(); ++i) {
            filled[i] = std::max(e.rgb[i].r, std::max(e.rgb[i].g, e.rgb[i].b)) > 0.0f;
            lit += filled[i];
        }
        isolated += count_isolated_bright_texels(e.rgb, filled, tex.width, tex.height);
    }
    std::printf("demo lightmap: %zu lit texels, %zu isolated bright texels\n", lit, isolated);
    EXPECT_GT(lit, 100000u);
    EXPECT_LE(isolated, 20u);
}

}  // namespace
}  // namespace hmdnode
