// Node world matrices and world-space punctual lights (world_lights.hpp). Cost: O(nodes + lights).
#include "world_lights.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>

namespace hmdnode::detail {

std::vector<glm::dmat4> node_world_matrices(const Scene& scene) {
    const size_t n = scene.nodes.size();
    std::vector<int> parent(n, -1);
    for (size_t i = 0; i < n; ++i)
        for (int c : scene.nodes[i].children)
            if (c >= 0 && size_t(c) < n && parent[c] < 0 && size_t(c) != i) parent[c] = int(i);
    std::vector<glm::dmat4> world(n, glm::dmat4(1.0));
    std::vector<char> state(n, 0);  // 0 todo, 1 in progress, 2 done
    for (size_t i = 0; i < n; ++i) {
        // Walk up to the first finished ancestor (or a root), then come back down.
        std::vector<int> chain;
        int k = int(i);
        while (k >= 0 && state[k] == 0) {
            state[k] = 1;
            chain.push_back(k);
            k = parent[k];
        }
        glm::dmat4 m =
            (k >= 0 && state[k] == 2) ? world[k] : glm::dmat4(1.0);  // in progress: a cycle
        for (auto it = chain.rbegin(); it != chain.rend(); ++it) {
            assert(state[size_t(*it)] == 1);  // on this walk's chain, not finished before
            m = m * scene.nodes[*it].local_matrix();
            world[*it] = m;
            state[*it] = 2;
        }
        assert(state[i] == 2);  // each node finished once its walk comes back down
    }
    return world;
}

std::vector<WorldLight> world_lights(const Scene& scene) {
    const std::vector<glm::dmat4> world = node_world_matrices(scene);
    std::vector<WorldLight> lights;
    lights.reserve(scene.lights.size());
    for (const Light& l : scene.lights) {
        WorldLight w;
        w.type = l.type;
        glm::dmat4 m =
            (l.node >= 0 && size_t(l.node) < world.size()) ? world[l.node] : glm::dmat4(1.0);
        w.position = glm::vec3(m[3]);
        glm::vec3 fwd = -glm::vec3(m[2]);
        float len = glm::length(fwd);
        w.direction = len > 0.0f ? fwd / len : glm::vec3(0.0f, 0.0f, -1.0f);
        w.intensity_rgb = l.color * l.intensity;
        w.range = l.range;
        if (l.type == Light::Type::Spot) {
            // KHR_lights_punctual's reference cone falloff.
            float cos_outer = std::cos(l.outer_cone_rad);
            float cos_inner = std::cos(l.inner_cone_rad);
            w.cone_scale = 1.0f / std::max(1e-4f, cos_inner - cos_outer);
            w.cone_offset = -cos_outer * w.cone_scale;
            assert(w.cone_scale > 0.0f);
        }
        lights.push_back(w);
    }
    return lights;
}

}  // namespace hmdnode::detail
