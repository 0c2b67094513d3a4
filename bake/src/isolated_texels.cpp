// Counting isolated bright texels (lightmap_noise.hpp): a texel brighter than `ratio` x every one
// of its 8 neighbours. A local-maximum test with a contrast margin, the way a viewer sees dust:
// a real light feature (a hot spot, a lit edge) spans several texels, so its brightest texel has a
// neighbour within the margin. Cost: O(9 x texels), no allocation.
#include "hmdnode/bake/lightmap_noise.hpp"

#include <cassert>

namespace hmdnode {

size_t count_isolated_bright_texels(const std::vector<glm::vec3>& texels,
                                    const std::vector<uint8_t>& filled, int width, int height,
                                    float ratio) {
    assert(width >= 0 && height >= 0 && texels.size() == size_t(width) * size_t(height));
    assert(filled.empty() || filled.size() == texels.size());
    auto lum = [](const glm::vec3& c) { return 0.2126f * c.r + 0.7152f * c.g + 0.0722f * c.b; };
    auto in = [&](size_t i) { return filled.empty() || filled[i] != 0; };
    size_t count = 0;
    for (int y = 1; y + 1 < height; ++y)
        for (int x = 1; x + 1 < width; ++x) {
            const size_t i = size_t(y) * width + x;
            const float l = lum(texels[i]);
            if (!in(i) || !(l > 0.0f)) continue;
            bool isolated = true;
            for (int dy = -1; dy <= 1 && isolated; ++dy)
                for (int dx = -1; dx <= 1 && isolated; ++dx) {
                    if (dx == 0 && dy == 0) continue;
                    const size_t j = size_t(y + dy) * width + (x + dx);
                    if (!in(j) || !(l > ratio * lum(texels[j]))) isolated = false;
                }
            if (isolated) ++count;
        }
    return count;
}

}  // namespace hmdnode
