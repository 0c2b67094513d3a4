// Seam blending between lightmap charts: the texels on both sides of an edge that is shared in 3-D
// but split in uv1 are adjusted so that bilinear lookups along the edge agree -- a simplified form
// of least-squares seam stitching (P.-P. Sloan, "Stitching UV Seams", 2017, venue not recorded:
// docs/references.md; S. Liu, Z. Ferguson, A. Jacobson, Y. Gingold, "Seamless: Seam erasure and
// seam-aware decoupling of shape from mesh resolution", ACM Transactions on Graphics 36(6),
// SIGGRAPH Asia 2017).
//
// Departure: instead of solving the least-squares system, each constraint "lookup on side A =
// lookup on side B" at sample points along the edge is relaxed in turn (Gauss-Seidel / Kaczmarz
// sweeps): half the difference is removed from each side, spread over its four bilinear texels in
// proportion to their weights. No data term: texels only move as much as the seams need. Only
// smooth seams are blended: both sides' vertex normals agree (a crease is a real change of light).
// Cost: O(seam edges x samples x iterations); memory O(edges) for the edge map.
#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <map>
#include <set>
#include <vector>

#include "lightmap_passes.hpp"

namespace hmdnode::detail {
namespace {

struct Footprint {
    size_t idx[4];
    float w[4];
};

Footprint footprint(glm::vec2 uv, int width, int height) {
    assert(width > 0 && height > 0);
    const float x = uv.x * width - 0.5f, y = uv.y * height - 0.5f;
    const int x0 = int(std::floor(x)), y0 = int(std::floor(y));
    const float fx = x - x0, fy = y - y0;
    Footprint f;
    for (int k = 0; k < 4; ++k) {
        const int xi = std::clamp(x0 + (k & 1), 0, width - 1);
        const int yi = std::clamp(y0 + (k >> 1), 0, height - 1);
        f.idx[k] = size_t(yi) * width + xi;
        f.w[k] = ((k & 1) ? fx : 1 - fx) * ((k >> 1) ? fy : 1 - fy);
        assert(f.idx[k] < size_t(width) * size_t(height));  // clamped into the map
    }
    return f;
}

glm::vec3 lookup(const std::vector<glm::vec3>& t, const Footprint& f) {
    glm::vec3 v(0.0f);
    for (int k = 0; k < 4; ++k) v += f.w[k] * t[f.idx[k]];
    return v;
}

void nudge(std::vector<glm::vec3>& t, const Footprint& f, const glm::vec3& delta) {
    float w2 = 0.0f;
    for (int k = 0; k < 4; ++k) w2 += f.w[k] * f.w[k];
    if (w2 <= 0.0f) return;
    for (int k = 0; k < 4; ++k) t[f.idx[k]] += delta * (f.w[k] / w2);
}

glm::vec3 world_normal(const glm::dmat4& world, const glm::vec3& n) {
    const glm::dmat3 nm = glm::transpose(glm::inverse(glm::dmat3(world)));
    const glm::vec3 w(nm * glm::dvec3(n));
    const float len = glm::length(w);
    return len > 0.0f ? w / len : glm::vec3(0.0f);
}

glm::vec3 face_normal(const glm::dmat4& world, const Primitive& prim, size_t t) {
    assert(t + 2 < prim.indices.size());
    glm::vec3 p[3];
    for (int k = 0; k < 3; ++k)
        p[k] = glm::vec3(world * glm::dvec4(glm::dvec3(prim.positions[prim.indices[t + k]]), 1.0));
    const glm::vec3 c = glm::cross(p[1] - p[0], p[2] - p[0]);
    const float len = glm::length(c);
    return len > 0.0f ? c / len : glm::vec3(0.0f);
}

}  // namespace

size_t blend_seams(const Scene& scene, int texture, std::vector<glm::vec3>& texels, int width,
                   int height, int iterations) {
    assert(width > 0 && height > 0 && texels.size() == size_t(width) * size_t(height));
    assert(texture >= 0 && iterations >= 0);
    using Key = std::array<long long, 6>;
    struct Side {
        glm::vec2 uv0, uv1;  // uv of the key's first and second endpoint
        glm::vec3 n0, n1;    // world normals there (face normal when the primitive has none)
    };
    std::map<Key, std::vector<Side>> edges;
    auto quant = [](const glm::vec3& p) {
        return std::array<long long, 3>{std::llround(p.x * 1e5), std::llround(p.y * 1e5),
                                        std::llround(p.z * 1e5)};
    };
    std::set<int> done;
    for (const SceneObject& obj : flatten_objects(scene))
        for (const LodLevel& level : obj.levels) {
            if (!done.insert(level.mesh).second) continue;
            for (const Primitive& prim : scene.meshes[level.mesh].primitives) {
                if (prim.material < 0 || size_t(prim.material) >= scene.materials.size() ||
                    scene.materials[prim.material].lightmap.texture != texture ||
                    prim.uv1.size() != prim.positions.size())
                    continue;
                for (size_t t = 0; t + 2 < prim.indices.size(); t += 3)
                    for (int e = 0; e < 3; ++e) {
                        uint32_t a = prim.indices[t + e], b = prim.indices[t + (e + 1) % 3];
                        if (a >= prim.positions.size() || b >= prim.positions.size()) continue;
                        const glm::vec3 pa(obj.world *
                                           glm::dvec4(glm::dvec3(prim.positions[a]), 1.0));
                        const glm::vec3 pb(obj.world *
                                           glm::dvec4(glm::dvec3(prim.positions[b]), 1.0));
                        auto qa = quant(pa), qb = quant(pb);
                        if (qa == qb) continue;
                        glm::vec2 ua = prim.uv1[a], ub = prim.uv1[b];
                        glm::vec3 na = face_normal(obj.world, prim, t), nb = na;
                        if (prim.normals.size() == prim.positions.size()) {
                            na = world_normal(obj.world, prim.normals[a]);
                            nb = world_normal(obj.world, prim.normals[b]);
                        }
                        if (qb < qa) {
                            std::swap(qa, qb);
                            std::swap(ua, ub);
                            std::swap(na, nb);
                        }
                        edges[{qa[0], qa[1], qa[2], qb[0], qb[1], qb[2]}].push_back(
                            {ua, ub, na, nb});
                    }
            }
        }
    struct Pair {
        Footprint a, b;
    };
    std::vector<Pair> pairs;
    size_t seams = 0;
    const glm::vec2 size(width, height);
    for (const auto& [key, sides] : edges) {
        if (sides.size() != 2) continue;  // open border or non-manifold: nothing to stitch
        const Side &s0 = sides[0], &s1 = sides[1];
        const float split =
            std::max(glm::length((s0.uv0 - s1.uv0) * size), glm::length((s0.uv1 - s1.uv1) * size));
        if (split < 0.01f) continue;  // same chart
        // A crease (different normals on the two sides) is a real change of light, not a seam.
        if (glm::dot(s0.n0, s1.n0) < 0.99f || glm::dot(s0.n1, s1.n1) < 0.99f) continue;
        ++seams;
        const float len =
            std::max(glm::length((s0.uv1 - s0.uv0) * size), glm::length((s1.uv1 - s1.uv0) * size));
        const int n = std::max(2, int(std::ceil(2.0f * len)));
        for (int i = 0; i < n; ++i) {
            const float t = (i + 0.5f) / n;
            pairs.push_back({footprint(glm::mix(s0.uv0, s0.uv1, t), width, height),
                             footprint(glm::mix(s1.uv0, s1.uv1, t), width, height)});
        }
    }
    for (int it = 0; it < iterations; ++it)
        for (const Pair& p : pairs) {
            const glm::vec3 d = 0.5f * (lookup(texels, p.a) - lookup(texels, p.b));
            nudge(texels, p.a, -d);
            nudge(texels, p.b, d);
        }
    for (glm::vec3& v : texels) v = glm::max(v, glm::vec3(0.0f));
    return seams;
}

}  // namespace hmdnode::detail
