// count_isolated_bright_texels (lightmap_noise.hpp): the measure of docs/baking.md "Noise".
#include "hmdnode/bake/lightmap_noise.hpp"

#include <gtest/gtest.h>

#include <vector>

namespace hmdnode {
namespace {

TEST(LightmapNoise, CountsSpecksButNotFeaturesOrBorders) {
    const int w = 16, h = 16;
    std::vector<glm::vec3> e(size_t(w) * h, glm::vec3(1.0f));
    std::vector<uint8_t> filled(e.size(), 1);
    EXPECT_EQ(count_isolated_bright_texels(e, filled, w, h), 0u);
    e[size_t(3) * w + 3] = glm::vec3(1.31f);  // a speck: above 1.3 x all 8 neighbours
    e[size_t(8) * w + 8] = glm::vec3(1.29f);  // within the margin: not a speck
    EXPECT_EQ(count_isolated_bright_texels(e, filled, w, h), 1u);
    // A two-texel highlight is a feature: neither texel is above 1.3 x the other.
    e[size_t(12) * w + 4] = glm::vec3(5.0f);
    e[size_t(12) * w + 5] = glm::vec3(4.5f);
    EXPECT_EQ(count_isolated_bright_texels(e, filled, w, h), 1u);
    // Next to an unfilled texel (a chart border) or on the map's edge: not counted.
    filled[size_t(2) * w + 2] = 0;
    e[0] = glm::vec3(9.0f);
    EXPECT_EQ(count_isolated_bright_texels(e, filled, w, h), 0u);
    // Only the green-heavy luminance counts: a blue speck of the same channel sum is darker.
    e[size_t(8) * w + 12] = glm::vec3(0.0f, 0.0f, 3.0f);  // luminance 0.22 < 1.3
    EXPECT_EQ(count_isolated_bright_texels(e, filled, w, h), 0u);
    // Without a mask every texel counts as filled: the speck is back; the corner texel, on the
    // map's edge, still is not.
    EXPECT_EQ(count_isolated_bright_texels(e, {}, w, h), 1u);
}

}  // namespace
}  // namespace hmdnode
