// Embree 3 scene of world triangles (Wald et al., "Embree: A Kernel Framework for Efficient CPU
// Ray Tracing", SIGGRAPH 2014): a static, high-quality BVH built once (RTC_BUILD_QUALITY_HIGH,
// robust mode), queried with single rays. Cost: build O(T log T), memory ~ 100 bytes per
// triangle; each query O(log T). Batches go to Embree as streams (rtcOccluded1M / rtcIntersect1M,
// Embree 3's stream API: it regroups the rays into packets of the CPU's SIMD width).
// intersect_skipping uses a context filter function (Embree's documented
// RTC_SCENE_FLAG_CONTEXT_FILTER_FUNCTION) to skip one triangle; the filter runs only on contexts
// that set it, so plain queries are unchanged.
#include "embree_scene.hpp"

#include <algorithm>
#include <cassert>
#include <climits>
#include <cmath>
#include <cstring>
#include <limits>

namespace hmdnode::detail {

EmbreeScene::~EmbreeScene() {
    if (scene_) rtcReleaseScene(scene_);
    if (device_) rtcReleaseDevice(device_);
}

Status EmbreeScene::build(const std::vector<glm::vec3>& corners) {
    // Built once, from 3 finite corners per triangle (PathTracer::build checked the positions).
    assert(device_ == nullptr && scene_ == nullptr && corners.size() % 3 == 0);
    assert(std::all_of(corners.begin(), corners.end(), [](const glm::vec3& c) {
        return std::isfinite(c.x) && std::isfinite(c.y) && std::isfinite(c.z);
    }));
    device_ = rtcNewDevice("verbose=0");
    if (!device_) return make_error("Embree: cannot create a device");
    scene_ = rtcNewScene(device_);
    rtcSetSceneFlags(scene_, RTC_SCENE_FLAG_ROBUST | RTC_SCENE_FLAG_CONTEXT_FILTER_FUNCTION);
    rtcSetSceneBuildQuality(scene_, RTC_BUILD_QUALITY_HIGH);
    const size_t tris = corners.size() / 3;
    if (tris > 0) {
        RTCGeometry geom = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_TRIANGLE);
        float* v = static_cast<float*>(rtcSetNewGeometryBuffer(
            geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), corners.size()));
        uint32_t* idx = static_cast<uint32_t*>(rtcSetNewGeometryBuffer(
            geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(uint32_t), tris));
        if (!v || !idx) {
            rtcReleaseGeometry(geom);
            return make_error("Embree: cannot allocate the triangle buffers");
        }
        for (size_t i = 0; i < corners.size(); ++i) {
            v[3 * i] = corners[i].x;
            v[3 * i + 1] = corners[i].y;
            v[3 * i + 2] = corners[i].z;
            idx[i] = uint32_t(i);
        }
        rtcCommitGeometry(geom);
        rtcAttachGeometry(scene_, geom);
        rtcReleaseGeometry(geom);
    }
    rtcCommitScene(scene_);
    if (rtcGetDeviceError(device_) != RTC_ERROR_NONE)
        return make_error("Embree: building the scene failed");
    return Status::success();
}

namespace {

// The context Embree passes to the filter, with the triangle to skip after it.
struct SkipContext {
    RTCIntersectContext ctx;
    uint32_t skip;
};

void skip_filter(const RTCFilterFunctionNArguments* args) {
    const auto* c = reinterpret_cast<const SkipContext*>(args->context);
    for (unsigned i = 0; i < args->N; ++i)
        if (args->valid[i] != 0 && RTCHitN_primID(args->hit, args->N, i) == c->skip)
            args->valid[i] = 0;
}

std::optional<EmbreeHit> intersect_with(RTCScene scene, RTCIntersectContext* ctx,
                                        const glm::vec3& o, const glm::vec3& d, float t_near,
                                        float t_far) {
    assert(scene != nullptr && ctx != nullptr);  // a built scene
    RTCRayHit rh;
    rh.ray.org_x = o.x;
    rh.ray.org_y = o.y;
    rh.ray.org_z = o.z;
    rh.ray.dir_x = d.x;
    rh.ray.dir_y = d.y;
    rh.ray.dir_z = d.z;
    rh.ray.tnear = t_near;
    rh.ray.tfar = t_far;
    rh.ray.time = 0.0f;
    rh.ray.mask = 0xFFFFFFFFu;
    rh.ray.id = 0;
    rh.ray.flags = 0;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(scene, ctx, &rh);
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return std::nullopt;
    return EmbreeHit{rh.ray.tfar, rh.hit.primID, rh.hit.u, rh.hit.v};
}

}  // namespace

std::optional<EmbreeHit> EmbreeScene::intersect(const glm::vec3& o, const glm::vec3& d,
                                                float t_near, float t_far) const {
    maybe_record(o, d, t_near, t_far, std::isinf(t_far) ? 0 : 1);
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    return intersect_with(scene_, &ctx, o, d, t_near, t_far);
}

std::optional<EmbreeHit> EmbreeScene::intersect_skipping(const glm::vec3& o, const glm::vec3& d,
                                                         float t_near, float t_far,
                                                         uint32_t skip) const {
    maybe_record(o, d, t_near, t_far, 3);
    SkipContext c;
    rtcInitIntersectContext(&c.ctx);
    c.ctx.filter = skip_filter;
    c.skip = skip;
    return intersect_with(scene_, &c.ctx, o, d, t_near, t_far);
}

bool EmbreeScene::occluded(const glm::vec3& o, const glm::vec3& d, float t_near,
                           float t_far) const {
    maybe_record(o, d, t_near, t_far, 2);
    assert(scene_ != nullptr);
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    RTCRay r = make_ray(o, d, t_near, t_far);
    rtcOccluded1(scene_, &ctx, &r);
    return r.tfar < 0.0f;  // Embree sets tfar to -inf on a hit
}

namespace {
void record_stream(const RTCRay& r, int kind) {
    maybe_record({r.org_x, r.org_y, r.org_z}, {r.dir_x, r.dir_y, r.dir_z}, r.tnear, r.tfar, kind);
}
}  // namespace

void EmbreeScene::occluded_stream(RTCRay* rays, size_t count) const {
    if (count == 0) return;
    assert(rays != nullptr && scene_ != nullptr && count <= size_t(UINT_MAX));
    if (g_record_every.load(std::memory_order_relaxed) != 0)
        for (size_t i = 0; i < count; ++i) record_stream(rays[i], 2);
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    rtcOccluded1M(scene_, &ctx, rays, unsigned(count), sizeof(RTCRay));
}

void EmbreeScene::intersect_stream(RTCRayHit* rays, size_t count) const {
    if (count == 0) return;
    assert(rays != nullptr && scene_ != nullptr && count <= size_t(UINT_MAX));
    for (size_t i = 0; i < count; ++i) {
        if (g_record_every.load(std::memory_order_relaxed) != 0) record_stream(rays[i].ray, 1);
        rays[i].hit.geomID = RTC_INVALID_GEOMETRY_ID;
        rays[i].hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    }
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    rtcIntersect1M(scene_, &ctx, rays, unsigned(count), sizeof(RTCRayHit));
}

}  // namespace hmdnode::detail
