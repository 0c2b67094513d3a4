// Conservative texel rasterisation (the texel-square vs triangle separating-axis test of
// Akenine-Moeller's triangle/box overlap reduced to 2-D; cf. Hasselgren et al., "Conservative
// Rasterization", GPU Gems 2 ch. 42) with n x n stratified points per texel clipped to the
// triangle, as lightmappers (Bakery, Unity's progressive lightmapper) sample texels.
//
// Departure: points outside the triangle are dropped rather than re-distributed, and a touched
// texel with no inside point gets the closest point of the triangle to its centre (weight = the
// share of one stratum), so thin slivers still reach the texels they cross.
// Cost: O(sum over triangles of bbox texels x n^2) time; O(samples) memory.
#include "hmdnode/bake/texel_raster.hpp"

#include <algorithm>
#include <cmath>
#include <set>
#include <string>

namespace hmdnode {
namespace {

struct Pending {
    uint32_t texel;
    TexelSample s;
};

float cross2(glm::vec2 a, glm::vec2 b) {
    return a.x * b.y - a.y * b.x;
}

glm::vec2 closest_on_segment(glm::vec2 p, glm::vec2 a, glm::vec2 b) {
    glm::vec2 ab = b - a;
    float len2 = glm::dot(ab, ab);
    float t = len2 > 0.0f ? std::clamp(glm::dot(p - a, ab) / len2, 0.0f, 1.0f) : 0.0f;
    return a + t * ab;
}

}  // namespace

Result<std::vector<TexelRaster>> rasterize_texels(const Scene& scene, int strata) {
    strata = std::max(1, strata);
    std::vector<int> raster_of_texture(scene.textures.size(), -1);
    std::vector<TexelRaster> rasters;
    for (size_t m = 0; m < scene.materials.size(); ++m) {
        const int tex = scene.materials[m].lightmap.texture;
        if (tex < 0) continue;
        if (size_t(tex) >= scene.textures.size())
            return make_error("material " + std::to_string(m) + " '" + scene.materials[m].name +
                              "': lightmap texture " + std::to_string(tex) + " does not exist");
        const Texture& t = scene.textures[tex];
        if (t.width <= 0 || t.height <= 0)
            return make_error("lightmap texture " + std::to_string(tex) + " '" + t.name +
                              "' has no size");
        if (raster_of_texture[tex] < 0) {
            raster_of_texture[tex] = int(rasters.size());
            TexelRaster r;
            r.texture = tex;
            r.width = t.width;
            r.height = t.height;
            rasters.push_back(std::move(r));
        }
    }
    std::vector<std::vector<Pending>> pending(rasters.size());
    std::vector<std::vector<float>> texel_size(rasters.size());
    for (size_t i = 0; i < rasters.size(); ++i)
        texel_size[i].assign(size_t(rasters[i].width) * rasters[i].height, 0.0f);

    const float inv_n = 1.0f / float(strata);
    const float stratum_weight = inv_n * inv_n;
    std::set<int> done_meshes;
    for (const SceneObject& obj : flatten_objects(scene)) {
        const glm::dmat3 normal_matrix = glm::transpose(glm::inverse(glm::dmat3(obj.world)));
        for (const LodLevel& level : obj.levels) {
            if (!done_meshes.insert(level.mesh).second) continue;
            const Mesh& mesh = scene.meshes[level.mesh];
            for (size_t pi = 0; pi < mesh.primitives.size(); ++pi) {
                const Primitive& prim = mesh.primitives[pi];
                if (prim.material < 0 || size_t(prim.material) >= scene.materials.size()) continue;
                const Material& mat = scene.materials[prim.material];
                if (mat.lightmap.texture < 0) continue;
                if (prim.uv1.size() != prim.positions.size())
                    return make_error("mesh '" + mesh.name + "' primitive " + std::to_string(pi) +
                                      " uses a lightmap material but has no TEXCOORD_1");
                const int ri = raster_of_texture[mat.lightmap.texture];
                TexelRaster& r = rasters[ri];
                const glm::vec2 size(r.width, r.height);
                const bool has_normals = prim.normals.size() == prim.positions.size();
                for (size_t t = 0; t + 2 < prim.indices.size(); t += 3) {
                    const uint32_t idx[3] = {prim.indices[t], prim.indices[t + 1],
                                             prim.indices[t + 2]};
                    if (idx[0] >= prim.positions.size() || idx[1] >= prim.positions.size() ||
                        idx[2] >= prim.positions.size())
                        continue;
                    glm::vec2 uv[3];
                    glm::vec3 w[3], wn[3];
                    for (int k = 0; k < 3; ++k) {
                        uv[k] = prim.uv1[idx[k]] * size;
                        w[k] = glm::vec3(obj.world *
                                         glm::dvec4(glm::dvec3(prim.positions[idx[k]]), 1.0));
                    }
                    const float area = cross2(uv[1] - uv[0], uv[2] - uv[0]);
                    if (area == 0.0f || !std::isfinite(area)) continue;
                    const glm::vec3 cr = glm::cross(w[1] - w[0], w[2] - w[0]);
                    const float world_area2 = glm::length(cr);
                    if (!(world_area2 > 0.0f) || !std::isfinite(world_area2)) continue;
                    const glm::vec3 face_n = cr / world_area2;
                    for (int k = 0; k < 3; ++k) {
                        wn[k] = face_n;
                        if (has_normals) {
                            glm::vec3 n =
                                glm::vec3(normal_matrix * glm::dvec3(prim.normals[idx[k]]));
                            float len = glm::length(n);
                            if (len > 0.0f && std::isfinite(len)) wn[k] = n / len;
                        }
                    }
                    // World metres per texel edge on this triangle.
                    const float texel_m = std::sqrt(world_area2 / std::abs(area));
                    const float sign = area > 0.0f ? 1.0f : -1.0f;
                    auto bary = [&](glm::vec2 q) {
                        float b0 = cross2(uv[1] - q, uv[2] - q) / area;
                        float b1 = cross2(uv[2] - q, uv[0] - q) / area;
                        return glm::vec3(b0, b1, 1.0f - b0 - b1);
                    };
                    auto make = [&](glm::vec3 b, float weight) {
                        TexelSample s;
                        s.position = b.x * w[0] + b.y * w[1] + b.z * w[2];
                        glm::vec3 n = b.x * wn[0] + b.y * wn[1] + b.z * wn[2];
                        float len = glm::length(n);
                        s.normal = len > 0.0f ? n / len : face_n;
                        s.face_normal = face_n;
                        s.albedo = glm::vec3(mat.base_color_factor);
                        s.weight = weight;
                        return s;
                    };
                    const glm::vec2 lo = glm::min(uv[0], glm::min(uv[1], uv[2]));
                    const glm::vec2 hi = glm::max(uv[0], glm::max(uv[1], uv[2]));
                    const int x0 = std::max(0, int(std::floor(lo.x)));
                    const int x1 = std::min(r.width - 1, int(std::ceil(hi.x)) - 1);
                    const int y0 = std::max(0, int(std::floor(lo.y)));
                    const int y1 = std::min(r.height - 1, int(std::ceil(hi.y)) - 1);
                    for (int y = y0; y <= y1; ++y)
                        for (int x = x0; x <= x1; ++x) {
                            // Separating axes: the three edge normals (the box axes are the
                            // bounding-box loop itself).
                            bool separated = false;
                            for (int e = 0; e < 3 && !separated; ++e) {
                                const glm::vec2 a = uv[e], b = uv[(e + 1) % 3];
                                const glm::vec2 ab = b - a;
                                const float tol = 1e-6f * glm::length(ab);
                                float best = -INFINITY;
                                for (int c = 0; c < 4; ++c) {
                                    glm::vec2 q(x + (c & 1), y + (c >> 1));
                                    best = std::max(best, sign * cross2(ab, q - a));
                                }
                                if (best <= tol) separated = true;
                            }
                            if (separated) continue;
                            const uint32_t texel = uint32_t(y) * r.width + x;
                            bool any = false;
                            for (int sy = 0; sy < strata; ++sy)
                                for (int sx = 0; sx < strata; ++sx) {
                                    glm::vec2 q(x + (sx + 0.5f) * inv_n, y + (sy + 0.5f) * inv_n);
                                    glm::vec3 b = bary(q);
                                    if (b.x < 0.0f || b.y < 0.0f || b.z < 0.0f) continue;
                                    pending[ri].push_back({texel, make(b, stratum_weight)});
                                    any = true;
                                }
                            if (!any) {
                                const glm::vec2 c(x + 0.5f, y + 0.5f);
                                glm::vec2 best = closest_on_segment(c, uv[0], uv[1]);
                                for (int e = 1; e < 3; ++e) {
                                    glm::vec2 q = closest_on_segment(c, uv[e], uv[(e + 1) % 3]);
                                    if (glm::dot(q - c, q - c) < glm::dot(best - c, best - c))
                                        best = q;
                                }
                                glm::vec3 b = glm::clamp(bary(best), 0.0f, 1.0f);
                                b /= (b.x + b.y + b.z);
                                pending[ri].push_back({texel, make(b, stratum_weight)});
                            }
                            texel_size[ri][texel] = std::max(texel_size[ri][texel], texel_m);
                        }
                }
            }
        }
    }
    // Bucket into CSR, keeping rasterisation order within a texel (deterministic).
    for (size_t ri = 0; ri < rasters.size(); ++ri) {
        TexelRaster& r = rasters[ri];
        const size_t n = size_t(r.width) * r.height;
        r.first.assign(n + 1, 0);
        for (const Pending& p : pending[ri]) ++r.first[p.texel + 1];
        for (size_t i = 0; i < n; ++i) r.first[i + 1] += r.first[i];
        std::vector<uint32_t> cursor(r.first.begin(), r.first.end() - 1);
        r.samples.resize(pending[ri].size());
        for (const Pending& p : pending[ri]) r.samples[cursor[p.texel]++] = p.s;
        r.texel_size_m = std::move(texel_size[ri]);
        r.covered = 0;
        for (size_t i = 0; i < n; ++i) r.covered += r.is_covered(i) ? 1 : 0;
    }
    return rasters;
}

}  // namespace hmdnode
