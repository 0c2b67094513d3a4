// Private: the scene's node world matrices and its KHR_lights_punctual lights in world space, for
// the path tracer (lights) and the atlas packer (per-mesh world scale).
//
// The path tracer evaluates a punctual light at a point p with unit normal n as
//   E = I * colour * max(0, n.l) * att / r^2 * V
// with I the light's intensity (candela), l the unit vector to the light, r its distance, att the
// KHR_lights_punctual range window max(0, min(1, 1 - (r / range)^4)) (1 when range is 0) times the
// spot cone factor clamp(cos * cone_scale + cone_offset, 0, 1)^2, V the shadow ray's visibility;
// a directional light gives I * colour * max(0, n.l) * V (lux).
//
// Threads: pure functions of the scene; any thread.
#pragma once

#include <vector>

#include <glm/glm.hpp>

#include "hmdnode/core/scene.hpp"

namespace hmdnode::detail {

// A light in world space, ready for evaluation.
struct WorldLight {
    Light::Type type = Light::Type::Point;
    glm::vec3 position{0.0f};
    glm::vec3 direction{0.0f, 0.0f, -1.0f};  // where it shines (spot, directional), unit
    glm::vec3 intensity_rgb{0.0f};           // intensity * colour
    float range = 0.0f;
    float cone_scale = 0.0f, cone_offset = 1.0f;  // spot: clamp(cos * scale + offset, 0, 1)^2
};

// World transform of every node (parents from the children lists; roots and orphans at identity).
std::vector<glm::dmat4> node_world_matrices(const Scene& scene);

// Every KHR_lights_punctual light of the scene in world space: placed by its node (at the origin
// looking down -Z when it has none), intensity times colour, spot cone as clamp(cos * scale +
// offset) with KHR_lights_punctual's reference falloff between the inner and outer cone.
std::vector<WorldLight> world_lights(const Scene& scene);

}  // namespace hmdnode::detail
