// Gutter dilation (the "edge padding" / push-pull-free dilation of every lightmapper): each pass
// fills the empty texels bordering valued ones with the mean of their valued 8-neighbours, so
// bilinear filtering and mipmapping at chart borders never read the black gutter, and invalid
// texels (inside geometry) take their valid neighbours' light.
// Cost: O(rings x texels) time, one copy of the valid mask per pass. No departure.
#include <cassert>
#include <vector>

#include "lightmap_passes.hpp"

namespace hmdnode::detail {

size_t dilate(std::vector<glm::vec3>& texels, std::vector<uint8_t>& valid, int width, int height,
              int rings) {
    assert(width >= 0 && height >= 0 && rings >= 0);
    assert(texels.size() == size_t(width) * size_t(height) && valid.size() == texels.size());
    size_t filled = 0;
    for (int pass = 0; pass < rings; ++pass) {
        const std::vector<uint8_t> before = valid;
        size_t this_pass = 0;
        for (int y = 0; y < height; ++y)
            for (int x = 0; x < width; ++x) {
                const size_t idx = size_t(y) * width + x;
                if (before[idx]) continue;
                glm::vec3 sum(0.0f);
                int count = 0;
                for (int dy = -1; dy <= 1; ++dy)
                    for (int dx = -1; dx <= 1; ++dx) {
                        const int nx = x + dx, ny = y + dy;
                        if ((dx == 0 && dy == 0) || nx < 0 || ny < 0 || nx >= width || ny >= height)
                            continue;
                        const size_t nidx = size_t(ny) * width + nx;
                        if (!before[nidx]) continue;
                        sum += texels[nidx];
                        ++count;
                    }
                if (count == 0) continue;
                texels[idx] = sum / float(count);
                valid[idx] = 1;
                ++this_pass;
            }
        filled += this_pass;
        assert(filled <= texels.size());  // a texel is filled once: it is valued from then on
        if (this_pass == 0) break;
    }
    return filled;
}

}  // namespace hmdnode::detail
