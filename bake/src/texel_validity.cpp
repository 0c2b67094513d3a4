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
#include <cassert>
#include <cmath>
#include <limits>
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
    // The raster's CSR: n + 1 offsets, rising, the last one the sample count.
    assert(raster.width >= 0 && raster.height >= 0 && raster.first.size() == n + 1);
    assert(raster.texel_size_m.size() == n && raster.first.back() == raster.samples.size());
    assert(threshold >= 0.0f && threshold <= 1.0f);
    ValidityResult out;
    out.valid.assign(n, 0);
    out.visible.assign(n, 0);
    std::vector<uint32_t> pushed(n, 0), invalid(n, 0), buried(n, 0);
    std::vector<uint64_t> rays(n, 0);
    rays_per_sample = std::max(1, rays_per_sample);
    parallel_for(n, threads, 64, [&](size_t texel, int) {
        if (!raster.is_covered(texel)) return;
        Pcg32 rng(seed ^ 0x9e3779b97f4a7c15ULL, texel);
        const float len = 1.5f * std::max(raster.texel_size_m[texel], 1e-5f);
        const uint32_t b = raster.first[texel], e = raster.first[texel + 1];
        assert(b < e && e <= raster.samples.size());
        // The texel's rays, all samples', as one stream: unbounded, over the hemisphere of the
        // sample's face (the other half only meets the sample's own surface).
        thread_local std::vector<TraceQuery> q;
        thread_local std::vector<std::optional<TraceHit>> hits;
        thread_local std::vector<uint8_t> inside;
        q.clear();
        for (uint32_t si = b; si < e; ++si) {
            const TexelSample& s = raster.samples[si];
            const glm::vec3 origin = s.position + s.face_normal * tracer.ray_offset(s.position);
            glm::vec3 t, bt;
            tangent_frame(s.face_normal, t, bt);
            for (int k = 0; k < rays_per_sample; ++k) {
                // Uniform over the hemisphere, stratified in its cosine.
                const float z = (float(k) + rng.uniform()) / float(rays_per_sample);
                const float phi = 2.0f * std::numbers::pi_v<float> * rng.uniform();
                const float r = std::sqrt(std::max(0.0f, 1.0f - z * z));
                const glm::vec3 d =
                    t * (r * std::cos(phi)) + bt * (r * std::sin(phi)) + s.face_normal * z;
                q.push_back(TraceQuery{origin, d, 0.0f, std::numeric_limits<float>::infinity()});
            }
        }
        assert(q.size() == size_t(e - b) * size_t(rays_per_sample));
        hits.resize(q.size());
        tracer.intersect_batch(q.size(), q.data(), hits.data());
        inside.assign(e - b, 0);
        size_t back = 0, total = 0, ray = 0;
        for (uint32_t si = b; si < e; ++si) {
            TexelSample& s = raster.samples[si];
            const float off = tracer.ray_offset(s.position);
            float nearest = INFINITY;
            glm::vec3 push_to(0.0f), push_n(0.0f);
            size_t back_any = 0, back_near = 0;
            for (int k = 0; k < rays_per_sample; ++k, ++ray) {
                ++rays[texel];
                std::optional<TraceHit>& h = hits[ray];
                if (!h) continue;
                const glm::vec3 hit = q[ray].origin + q[ray].dir * h->t;
                if (std::abs(glm::dot(hit - s.position, s.face_normal)) <= 2.0f * off &&
                    std::abs(glm::dot(h->face_normal, s.face_normal)) > kCoplanarCos)
                    continue;  // on the sample's own plane: touching, not covering
                // Inside test: the ray leaves a solid first, here or where two solids touch (the
                // touching faces' facing one is returned; the one behind it still says "inside").
                const bool back_face = !h->front && !h->double_sided;
                if (back_face || h->back_face_there) ++back_any;
                if (!back_face || h->t > len) continue;
                ++back_near;
                if (h->t < nearest) {
                    nearest = h->t;
                    push_n = h->face_normal;  // front side of the back face we see
                    push_to = hit;
                }
            }
            // A front face where two solids touch may hide a back face on the same spot (Embree
            // returns either): looked for when the sample may be inside (some back face seen).
            if (back_any > 0 && 4 * back_any < 3 * size_t(rays_per_sample))
                for (size_t k = ray - size_t(rays_per_sample); k < ray; ++k) {
                    std::optional<TraceHit>& h = hits[k];
                    if (!h || !h->front || h->back_face_there) continue;
                    const glm::vec3 hit = q[k].origin + q[k].dir * h->t;
                    if (std::abs(glm::dot(hit - s.position, s.face_normal)) <= 2.0f * off &&
                        std::abs(glm::dot(h->face_normal, s.face_normal)) > kCoplanarCos)
                        continue;
                    if (tracer.find_back_face_there(q[k].origin, q[k].dir, *h)) ++back_any;
                }
            if (4 * back_any >= 3 * size_t(rays_per_sample)) {
                // Inside a solid: most of its hemisphere first meets a face from behind, however
                // far. Not moved (through the nearer face it may come out on the wrong side of a
                // thick wall) and not traced: the texel's visible samples take its paths.
                inside[si - b] = 1;
                ++buried[texel];
                continue;
            }
            back += back_near;
            total += size_t(rays_per_sample);
            if (nearest < INFINITY) {
                s.position = push_to + push_n * (2.0f * tracer.ray_offset(push_to));
                ++pushed[texel];
            }
        }
        assert(ray == q.size());  // every ray of the stream read once, in order
        // Visible samples first (in their order), buried ones after.
        thread_local std::vector<TexelSample> keep;
        keep.clear();
        for (int pass = 0; pass < 2; ++pass)
            for (uint32_t si = b; si < e; ++si)
                if (inside[si - b] == pass) keep.push_back(raster.samples[si]);
        assert(keep.size() == size_t(e - b) && buried[texel] <= e - b);
        std::copy(keep.begin(), keep.end(), raster.samples.begin() + b);
        out.visible[texel] = uint32_t(e - b) - buried[texel];
        const bool bad = total == 0 || float(back) > threshold * float(total);
        invalid[texel] = bad ? 1 : 0;
        out.valid[texel] = bad ? 0 : 1;
    });
    for (size_t i = 0; i < n; ++i) {
        out.pushed += pushed[i];
        out.buried += buried[i];
        out.invalid += invalid[i];
        out.rays += rays[i];
    }
    return out;
}

}  // namespace hmdnode::detail
