// A set of positions compared bit for bit (+0 == -0), for SimplifyOptions::locked_positions.
// Cost: O(L log L) to build, O(log L) per lookup.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstring>
#include <span>
#include <vector>

#include <glm/glm.hpp>

namespace hmdnode::lod_detail {

class PositionSet {
  public:
    PositionSet() = default;
    explicit PositionSet(std::span<const glm::vec3> positions) {
        keys_.reserve(positions.size());
        for (const glm::vec3& p : positions) keys_.push_back(key(p));
        std::sort(keys_.begin(), keys_.end());
        keys_.erase(std::unique(keys_.begin(), keys_.end()), keys_.end());
    }
    bool empty() const { return keys_.empty(); }
    bool contains(const glm::vec3& p) const {
        return std::binary_search(keys_.begin(), keys_.end(), key(p));
    }

    // The bits of p's coordinates, -0 as +0: equal keys, equal positions.
    using Key = std::array<uint32_t, 3>;
    static Key key(const glm::vec3& p) {
        Key k;
        const float v[3] = {p.x + 0.0f, p.y + 0.0f, p.z + 0.0f};  // note: -0 becomes +0
        std::memcpy(k.data(), v, sizeof v);
        return k;
    }

  private:
    std::vector<Key> keys_;
};

}  // namespace hmdnode::lod_detail
