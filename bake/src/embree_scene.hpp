// Private: the Embree 3 device and scene of the baker's world triangles (one triangle geometry,
// committed once; rtcIntersect1 / rtcOccluded1 with one incoherent context per query, and a
// context filter that skips one triangle for intersect_skipping).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <embree3/rtcore.h>
#include <glm/glm.hpp>

#include "hmdnode/core/result.hpp"

namespace hmdnode::detail {

struct EmbreeHit {
    float t;
    uint32_t prim;
    float u, v;
};

class EmbreeScene {
  public:
    EmbreeScene() = default;
    EmbreeScene(const EmbreeScene&) = delete;
    EmbreeScene& operator=(const EmbreeScene&) = delete;
    ~EmbreeScene();

    // corners: 3 per triangle, world space, all finite.
    Status build(const std::vector<glm::vec3>& corners);

    std::optional<EmbreeHit> intersect(const glm::vec3& o, const glm::vec3& d, float t_near,
                                       float t_far) const;
    bool occluded(const glm::vec3& o, const glm::vec3& d, float t_near, float t_far) const;
    // intersect, ignoring triangle `skip` (an Embree context filter): the other of two
    // coincident triangles, which a plain query may or may not return.
    std::optional<EmbreeHit> intersect_skipping(const glm::vec3& o, const glm::vec3& d,
                                                float t_near, float t_far, uint32_t skip) const;

  private:
    RTCDevice device_ = nullptr;
    RTCScene scene_ = nullptr;
};

}  // namespace hmdnode::detail
