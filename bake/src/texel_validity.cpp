// Texel validity and back-face push-off, as Unity's progressive lightmapper ("texel validity",
// backface tolerance) and Bakery do it: a sample point that sees back faces within about a texel
// is inside or behind geometry (under a box on the floor, inside a wall); it is moved just in
// front of the nearest back face it sees, and a texel whose rays mostly hit back faces is marked
// invalid and later filled from valid neighbours (dilate.cpp).
//
// Departures: rays are spread over the whole sphere (not only the hemisphere), so a sample on a
// floor that passes under a wall's bottom edge sees the wall's back face sideways too. A back face
// lying on the sample's own plane and facing the other way (the wall of a next room that shares
// the wall plane, a box's bottom on the floor) touches the surface without covering it: it is
// ignored (pushing the sample behind it blacked out 42 % of a wall that two rooms share).
// A texel's rays (all its samples') are traced as one Embree stream (PathTracer::intersect_batch).
// Cost: rays_per_sample short rays per sample, O(log T) each; no extra memory but one byte per
// texel.
#include <algorithm>
#include <cmath>
#include <numbers>

#include "lightmap_passes.hpp"

namespace hmdnode::detail {

namespace {
constexpr float kCoplanarCos = 0.9995f;  // faces within 1.8 degrees of anti-parallel
}  // namespace

ValidityResult fix_texel_validity(TexelRaster& raster, const PathTracer& tracer,
                                  int rays_per_sample, float threshold, int threads,
                                  uint64_t seed) {
    const size_t n = size_t(raster.width) * raster.height;
    ValidityResult out;
    out.valid.assign(n, 0);
    std::vector<uint32_t> pushed(n, 0), invalid(n, 0);
    std::vector<uint64_t> rays(n, 0);
    rays_per_sample = std::max(1, rays_per_sample);
    parallel_for(n, threads, 64, [&](size_t texel, int) {
        if (!raster.is_covered(texel)) return;
        Pcg32 rng(seed ^ 0x9e3779b97f4a7c15ULL, texel);
        const float len = 1.5f * std::max(raster.texel_size_m[texel], 1e-5f);
        size_t back = 0, total = 0;
        // The texel's rays, all samples', as one stream; the random numbers as one ray at a time.
        thread_local std::vector<TraceQuery> q;
        thread_local std::vector<std::optional<TraceHit>> hits;
        q.clear();
        for (uint32_t si = raster.first[texel]; si < raster.first[texel + 1]; ++si) {
            const TexelSample& s = raster.samples[si];
            const glm::vec3 origin = s.position + s.face_normal * tracer.ray_offset(s.position);
            for (int k = 0; k < rays_per_sample; ++k) {
                // Stratified in z over the sphere.
                float z = 1.0f - 2.0f * (k + rng.uniform()) / float(rays_per_sample);
                float phi = 2.0f * std::numbers::pi_v<float> * rng.uniform();
                float r = std::sqrt(std::max(0.0f, 1.0f - z * z));
                q.push_back(
                    TraceQuery{origin, {r * std::cos(phi), r * std::sin(phi), z}, 0.0f, len});
            }
        }
        hits.resize(q.size());
        tracer.intersect_batch(q.size(), q.data(), hits.data());
        size_t ray = 0;
        for (uint32_t si = raster.first[texel]; si < raster.first[texel + 1]; ++si) {
            TexelSample& s = raster.samples[si];
            const float off = tracer.ray_offset(s.position);
            float nearest = INFINITY;
            glm::vec3 push_to(0.0f), push_n(0.0f);
            for (int k = 0; k < rays_per_sample; ++k, ++ray) {
                ++total;
                ++rays[texel];
                const std::optional<TraceHit>& h = hits[ray];
                if (!h || h->front || h->double_sided) continue;
                const glm::vec3 hit = q[ray].origin + q[ray].dir * h->t;
                if (glm::dot(h->face_normal, s.face_normal) < -kCoplanarCos &&
                    std::abs(glm::dot(hit - s.position, s.face_normal)) <= 2.0f * off)
                    continue;  // back to back on the sample's own plane: touching, not covering
                ++back;
                if (h->t < nearest) {
                    nearest = h->t;
                    push_n = h->face_normal;  // front side of the back face we see
                    push_to = hit;
                }
            }
            if (nearest < INFINITY) {
                s.position = push_to + push_n * (2.0f * tracer.ray_offset(push_to));
                ++pushed[texel];
            }
        }
        const bool bad = total > 0 && float(back) > threshold * float(total);
        invalid[texel] = bad ? 1 : 0;
        out.valid[texel] = bad ? 0 : 1;
    });
    for (size_t i = 0; i < n; ++i) {
        out.pushed += pushed[i];
        out.invalid += invalid[i];
        out.rays += rays[i];
    }
    return out;
}

}  // namespace hmdnode::detail
