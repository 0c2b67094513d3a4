// Recording and replaying the baker's rays (path_tracer.hpp): the throughput bench's reference is
// the baker's own ray mix (bounce, shadow, validity and coplanar re-queries, in the order each
// thread cast them) through raw Embree, single rays as the baker casts them, or Embree 3's packet
// (rtcIntersect8 / rtcOccluded8, Wald et al., "Embree: A Kernel Framework for Efficient CPU Ray
// Tracing", SIGGRAPH 2014, sec. 4) and stream (rtcIntersect1M / rtcOccluded1M) queries for the
// shadow and short rays. Recording: a thread-local buffer per thread, appended to the shared log
// under a mutex when the thread ends or the recording stops. Cost: O(rays) time and 36 bytes per
// kept ray; one relaxed atomic load per ray while off.
#include <time.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <limits>
#include <mutex>
#include <vector>

#include "embree_scene.hpp"
#include "hmdnode/bake/path_tracer.hpp"

namespace hmdnode {
namespace detail {

std::atomic<uint32_t> g_record_every{0};

namespace {

std::mutex g_log_mutex;
std::vector<RecordedRay> g_log;
std::atomic<uint64_t> g_generation{0};  // a new recording: stale thread buffers are dropped

struct LocalLog {
    std::vector<RecordedRay> rays;
    uint64_t generation = 0;
    uint32_t count = 0;
    void flush() {
        if (!rays.empty() && generation == g_generation.load()) {
            std::lock_guard<std::mutex> lock(g_log_mutex);
            g_log.insert(g_log.end(), rays.begin(), rays.end());
        }
        rays.clear();
    }
    ~LocalLog() { flush(); }
};
thread_local LocalLog t_log;

}  // namespace

void record_ray(const glm::vec3& o, const glm::vec3& d, float t_near, float t_far, int kind) {
    const uint32_t every = g_record_every.load(std::memory_order_relaxed);
    if (every == 0) return;
    const uint64_t gen = g_generation.load(std::memory_order_relaxed);
    if (t_log.generation != gen) {
        t_log.rays.clear();
        t_log.generation = gen;
        t_log.count = 0;
    }
    if (t_log.count++ % every != 0) return;
    t_log.rays.push_back(RecordedRay{o, t_near, d, t_far, RayKind(kind)});
}

}  // namespace detail

void start_ray_recording(uint32_t every) {
    {
        std::lock_guard<std::mutex> lock(detail::g_log_mutex);
        detail::g_log.clear();
    }
    ++detail::g_generation;
    detail::g_record_every = std::max<uint32_t>(1, every);
}

std::vector<RecordedRay> stop_ray_recording() {
    detail::g_record_every = 0;
    detail::t_log.flush();  // the calling thread's (workers flushed when they ended)
    std::lock_guard<std::mutex> lock(detail::g_log_mutex);
    std::vector<RecordedRay> out = std::move(detail::g_log);
    detail::g_log.clear();
    return out;
}

namespace {

double cpu_now() {
    timespec ts{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

void fill(RTCRay& r, const RecordedRay& x) {
    r = detail::EmbreeScene::make_ray(x.origin, x.dir, x.t_near, x.t_far);
}

// One ray as the baker casts it; returns 1 on a hit (nearest) or occlusion (shadow).
uint64_t single(RTCScene scene, const RecordedRay& x) {
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    if (x.kind == RayKind::Shadow) {
        RTCRay r;
        fill(r, x);
        rtcOccluded1(scene, &ctx, &r);
        return r.tfar < 0.0f ? 1 : 0;
    }
    RTCRayHit rh;
    fill(rh.ray, x);
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(scene, &ctx, &rh);
    return rh.hit.geomID != RTC_INVALID_GEOMETRY_ID ? 1 : 0;
}

// Up to 8 rays into a packet; lanes past n repeat the last ray and are masked off.
void fill8(RTCRay8& p, const RecordedRay* rays, int n, int valid[8]) {
    for (int i = 0; i < 8; ++i) {
        const RecordedRay& x = rays[std::min(i, n - 1)];
        valid[i] = i < n ? -1 : 0;
        p.org_x[i] = x.origin.x;
        p.org_y[i] = x.origin.y;
        p.org_z[i] = x.origin.z;
        p.dir_x[i] = x.dir.x;
        p.dir_y[i] = x.dir.y;
        p.dir_z[i] = x.dir.z;
        p.tnear[i] = x.t_near;
        p.tfar[i] = x.t_far;
        p.time[i] = 0.0f;
        p.mask[i] = 0xFFFFFFFFu;
        p.id[i] = 0;
        p.flags[i] = 0;
    }
}

// A chunk's shadow and short rays grouped (in order) by kind, cast as packets or streams; the
// rest single.
uint64_t grouped(RTCScene scene, const RecordedRay* rays, size_t n, ReplayMode mode) {
    uint64_t hits = 0;
    thread_local std::vector<const RecordedRay*> shadow, shorts;
    shadow.clear();
    shorts.clear();
    for (size_t i = 0; i < n; ++i) {
        if (rays[i].kind == RayKind::Shadow)
            shadow.push_back(&rays[i]);
        else if (rays[i].kind == RayKind::Short)
            shorts.push_back(&rays[i]);
        else
            hits += single(scene, rays[i]);
    }
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    if (mode == ReplayMode::Packet8) {
        RecordedRay buf[8];
        for (size_t b = 0; b < shadow.size(); b += 8) {
            const int m = int(std::min<size_t>(8, shadow.size() - b));
            for (int i = 0; i < m; ++i) buf[i] = *shadow[b + size_t(i)];
            alignas(32) RTCRay8 p;
            alignas(32) int valid[8];
            fill8(p, buf, m, valid);
            rtcOccluded8(valid, scene, &ctx, &p);
            for (int i = 0; i < m; ++i) hits += p.tfar[i] < 0.0f ? 1 : 0;
        }
        for (size_t b = 0; b < shorts.size(); b += 8) {
            const int m = int(std::min<size_t>(8, shorts.size() - b));
            for (int i = 0; i < m; ++i) buf[i] = *shorts[b + size_t(i)];
            alignas(32) RTCRayHit8 p;
            alignas(32) int valid[8];
            fill8(p.ray, buf, m, valid);
            for (int i = 0; i < 8; ++i) {
                p.hit.geomID[i] = RTC_INVALID_GEOMETRY_ID;
                p.hit.instID[0][i] = RTC_INVALID_GEOMETRY_ID;
            }
            rtcIntersect8(valid, scene, &ctx, &p);
            for (int i = 0; i < m; ++i) hits += p.hit.geomID[i] != RTC_INVALID_GEOMETRY_ID;
        }
        return hits;
    }
    // Streams of 64 (AOS, one RTCRay / RTCRayHit per ray).
    thread_local std::vector<RTCRay> sr;
    thread_local std::vector<RTCRayHit> sh;
    for (size_t b = 0; b < shadow.size(); b += 64) {
        const size_t m = std::min<size_t>(64, shadow.size() - b);
        sr.resize(m);
        for (size_t i = 0; i < m; ++i) fill(sr[i], *shadow[b + i]);
        rtcOccluded1M(scene, &ctx, sr.data(), unsigned(m), sizeof(RTCRay));
        for (size_t i = 0; i < m; ++i) hits += sr[i].tfar < 0.0f ? 1 : 0;
    }
    for (size_t b = 0; b < shorts.size(); b += 64) {
        const size_t m = std::min<size_t>(64, shorts.size() - b);
        sh.resize(m);
        for (size_t i = 0; i < m; ++i) {
            fill(sh[i].ray, *shorts[b + i]);
            sh[i].hit.geomID = RTC_INVALID_GEOMETRY_ID;
            sh[i].hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
        }
        rtcIntersect1M(scene, &ctx, sh.data(), unsigned(m), sizeof(RTCRayHit));
        for (size_t i = 0; i < m; ++i) hits += sh[i].hit.geomID != RTC_INVALID_GEOMETRY_ID;
    }
    return hits;
}

}  // namespace

ReplayTiming detail::replay(const EmbreeScene& embree, const std::vector<RecordedRay>& rays,
                            int threads, ReplayMode mode) {
    const RTCScene scene = embree.handle();
    const size_t chunk = 4096, chunks = (rays.size() + chunk - 1) / chunk;
    std::atomic<uint64_t> hits{0};
    const double cpu0 = cpu_now();
    const auto t0 = std::chrono::steady_clock::now();
    parallel_for(chunks, threads, 1, [&](size_t c, int) {
        const size_t b = c * chunk, n = std::min(rays.size(), b + chunk) - b;
        uint64_t h = 0;
        if (mode == ReplayMode::Single)
            for (size_t i = 0; i < n; ++i) h += single(scene, rays[b + i]);
        else
            h = grouped(scene, rays.data() + b, n, mode);
        hits += h;
    });
    ReplayTiming t;
    t.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    t.cpu_seconds = cpu_now() - cpu0;
    t.rays = rays.size();
    t.hits = hits;
    return t;
}

}  // namespace hmdnode
