// Test support for the lod suites: meshes with closed-form answers.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <utility>
#include <vector>

#include <glm/glm.hpp>

#include "hmdnode/core/scene.hpp"

namespace hmdnode::test {

// Each triangle split into 4 at its edges' midpoints (shared between neighbours), `levels` times;
// `place` maps each new midpoint (the average of its edge's ends) to where it goes.
template <class Place>
Primitive subdivided(Primitive p, int levels, Place place) {
    for (int l = 0; l < levels; ++l) {
        std::map<std::pair<uint32_t, uint32_t>, uint32_t> mid;
        auto midpoint = [&](uint32_t a, uint32_t b) {
            auto [it, added] = mid.emplace(std::minmax(a, b), uint32_t(p.positions.size()));
            if (added) p.positions.push_back(place(0.5f * (p.positions[a] + p.positions[b])));
            return it->second;
        };
        std::vector<uint32_t> next;
        for (size_t i = 0; i < p.indices.size(); i += 3) {
            const uint32_t a = p.indices[i], b = p.indices[i + 1], c = p.indices[i + 2];
            const uint32_t ab = midpoint(a, b), bc = midpoint(b, c), ca = midpoint(c, a);
            next.insert(next.end(), {a, ab, ca, b, bc, ab, c, ca, bc, ab, bc, ca});
        }
        p.indices = std::move(next);
    }
    return p;
}

// The icosahedron with each triangle split into 4, `levels` times, every vertex on the unit
// sphere: 20 * 4^levels triangles, closed and manifold. Positions and indices only.
inline Primitive unit_icosphere(int levels) {
    const float t = (1.0f + std::sqrt(5.0f)) / 2.0f;
    Primitive p;
    p.positions = {{-1, t, 0},  {1, t, 0},  {-1, -t, 0}, {1, -t, 0}, {0, -1, t},  {0, 1, t},
                   {0, -1, -t}, {0, 1, -t}, {t, 0, -1},  {t, 0, 1},  {-t, 0, -1}, {-t, 0, 1}};
    for (glm::vec3& v : p.positions) v = glm::normalize(v);
    p.indices = {0, 11, 5,  0, 5,  1, 0, 1, 7, 0, 7,  10, 0, 10, 11, 1, 5, 9, 5, 11,
                 4, 11, 10, 2, 10, 7, 6, 7, 1, 8, 3,  9,  4, 3,  4,  2, 3, 2, 6, 3,
                 6, 8,  3,  8, 9,  4, 9, 5, 2, 4, 11, 6,  2, 10, 8,  6, 7, 9, 8, 1};
    return subdivided(std::move(p), levels, [](glm::vec3 m) { return glm::normalize(m); });
}

// The triangles split on their own planes: piecewise-flat input, like a tessellated wall or CAD
// part, where most collapses cost zero. Positions and indices only.
inline Primitive subdivided_flat(Primitive p, int levels) {
    return subdivided(std::move(p), levels, [](glm::vec3 m) { return m; });
}

}  // namespace hmdnode::test
