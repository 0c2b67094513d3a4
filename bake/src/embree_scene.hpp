// Private: the Embree 3 device and scene of the baker's world triangles (one triangle geometry,
// committed once; rtcIntersect1 / rtcOccluded1 with one incoherent context per query, streams
// (rtcOccluded1M / rtcIntersect1M) for batches, and a context filter that skips one triangle for
// intersect_skipping).
#pragma once

#include <atomic>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <embree3/rtcore.h>
#include <glm/glm.hpp>

#include "hmdnode/bake/path_tracer.hpp"
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

    // A batch of rays as one Embree stream (rtcOccluded1M / rtcIntersect1M, incoherent): shadow
    // rays come back with tfar < 0 where occluded, nearest-hit rays with their hit (geomID
    // RTC_INVALID_GEOMETRY_ID on a miss). Rays made by make_ray; recorded as shadow rays / as
    // short rays (the validity pass's, the only nearest-hit streams).
    static RTCRay make_ray(const glm::vec3& o, const glm::vec3& d, float t_near, float t_far) {
        RTCRay r;
        r.org_x = o.x;
        r.org_y = o.y;
        r.org_z = o.z;
        r.dir_x = d.x;
        r.dir_y = d.y;
        r.dir_z = d.z;
        r.tnear = t_near;
        r.tfar = t_far;
        r.time = 0.0f;
        r.mask = 0xFFFFFFFFu;
        r.id = 0;
        r.flags = 0;
        return r;
    }
    void occluded_stream(RTCRay* rays, size_t count) const;
    void intersect_stream(RTCRayHit* rays, size_t count) const;

    RTCScene handle() const { return scene_; }  // for the replay (ray_replay.cpp)

  private:
    RTCDevice device_ = nullptr;
    RTCScene scene_ = nullptr;
};

// ray_replay.cpp: the recorded rays through raw Embree (PathTracer::replay_rays).
ReplayTiming replay(const EmbreeScene& embree, const std::vector<RecordedRay>& rays, int threads,
                    ReplayMode mode);

// ray_replay.cpp: keeps the ray when a recording is on (start_ray_recording). Kind as
// hmdnode::RayKind: 0 bounce, 1 short, 2 shadow, 3 coplanar.
extern std::atomic<uint32_t> g_record_every;
void record_ray(const glm::vec3& o, const glm::vec3& d, float t_near, float t_far, int kind);
inline void maybe_record(const glm::vec3& o, const glm::vec3& d, float t_near, float t_far,
                         int kind) {
    if (g_record_every.load(std::memory_order_relaxed) != 0) record_ray(o, d, t_near, t_far, kind);
}

}  // namespace hmdnode::detail
