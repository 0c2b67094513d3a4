// Noise measures of a baked lightmap (docs/baking.md "Noise"), used by the tests and the noise
// bench on the lightmaps the bake ships.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

namespace hmdnode {

// An isolated bright texel (a "firefly" or a speck of dust in the lightmap): a texel whose
// luminance (Rec. 709 weights) is more than `ratio` (1.3) times the luminance of each of its 8
// neighbours, counted only where the texel and all 8 neighbours lie in the map and are filled
// (filled[i] != 0; all texels when `filled` is empty), so chart borders next to empty texels do
// not count. Luminance 0 never counts. Cost: O(9 x texels).
size_t count_isolated_bright_texels(const std::vector<glm::vec3>& texels,
                                    const std::vector<uint8_t>& filled, int width, int height,
                                    float ratio = 1.3f);

}  // namespace hmdnode
