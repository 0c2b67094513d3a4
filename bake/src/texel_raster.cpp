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

// Step 1: one raster per lightmap texture a material names (raster_of_texture[texture] is its
// index, -1 for a texture no material lightmaps).
Result<std::vector<TexelRaster>> make_rasters(const Scene& scene,
                                              std::vector<int>& raster_of_texture) {
    raster_of_texture.assign(scene.textures.size(), -1);
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
    return rasters;
}

// One triangle in its raster's texel space, with what its samples interpolate.
struct UvTriangle {
    glm::vec2 uv[3];        // texel coordinates of the corners
    glm::vec3 w[3], wn[3];  // world positions and unit normals of the corners
    glm::vec3 face_n;       // world, unit
    glm::vec3 albedo;
    float area = 0.0f;     // signed, twice the texel-space area
    float sign = 1.0f;     // of area
    float texel_m = 0.0f;  // world metres per texel edge on this triangle

    glm::vec3 bary(glm::vec2 q) const {
        float b0 = cross2(uv[1] - q, uv[2] - q) / area;
        float b1 = cross2(uv[2] - q, uv[0] - q) / area;
        return glm::vec3(b0, b1, 1.0f - b0 - b1);
    }
    TexelSample make(glm::vec3 b, float weight) const {
        TexelSample s;
        s.position = b.x * w[0] + b.y * w[1] + b.z * w[2];
        glm::vec3 n = b.x * wn[0] + b.y * wn[1] + b.z * wn[2];
        float len = glm::length(n);
        s.normal = len > 0.0f ? n / len : face_n;
        s.face_normal = face_n;
        s.albedo = albedo;
        s.weight = weight;
        return s;
    }
};

// Step 2: corners idx of `prim` into texel space (`size` texels) and world space; false for a
// triangle without area in either (it gets no samples).
bool setup_triangle(const Primitive& prim, const uint32_t idx[3], const SceneObject& obj,
                    const glm::dmat3& normal_matrix, glm::vec2 size, UvTriangle& tri) {
    for (int k = 0; k < 3; ++k) {
        tri.uv[k] = prim.uv1[idx[k]] * size;
        tri.w[k] = glm::vec3(obj.world * glm::dvec4(glm::dvec3(prim.positions[idx[k]]), 1.0));
    }
    tri.area = cross2(tri.uv[1] - tri.uv[0], tri.uv[2] - tri.uv[0]);
    if (tri.area == 0.0f || !std::isfinite(tri.area)) return false;
    const glm::vec3 cr = glm::cross(tri.w[1] - tri.w[0], tri.w[2] - tri.w[0]);
    const float world_area2 = glm::length(cr);
    if (!(world_area2 > 0.0f) || !std::isfinite(world_area2)) return false;
    tri.face_n = cr / world_area2;
    const bool has_normals = prim.normals.size() == prim.positions.size();
    for (int k = 0; k < 3; ++k) {
        tri.wn[k] = tri.face_n;
        if (has_normals) {
            glm::vec3 n = glm::vec3(normal_matrix * glm::dvec3(prim.normals[idx[k]]));
            float len = glm::length(n);
            if (len > 0.0f && std::isfinite(len)) tri.wn[k] = n / len;
        }
    }
    tri.texel_m = std::sqrt(world_area2 / std::abs(tri.area));
    tri.sign = tri.area > 0.0f ? 1.0f : -1.0f;
    return true;
}

// Step 3: whether the square of texel (x, y) and the triangle are apart. Separating axes: the
// three edge normals (the box axes are the bounding-box loop of rasterize_triangle itself).
bool separated(const UvTriangle& tri, int x, int y) {
    for (int e = 0; e < 3; ++e) {
        const glm::vec2 a = tri.uv[e], b = tri.uv[(e + 1) % 3];
        const glm::vec2 ab = b - a;
        const float tol = 1e-6f * glm::length(ab);
        float best = -INFINITY;
        for (int c = 0; c < 4; ++c) {
            glm::vec2 q(x + (c & 1), y + (c >> 1));
            best = std::max(best, tri.sign * cross2(ab, q - a));
        }
        if (best <= tol) return true;
    }
    return false;
}

// Step 4: the samples of a touched texel (x, y): the stratum centres inside the triangle, or
// without one the triangle's point closest to the texel centre, each of one stratum's weight.
void sample_texel(const UvTriangle& tri, int x, int y, uint32_t texel, int strata,
                  std::vector<Pending>& pending) {
    const float inv_n = 1.0f / float(strata);
    const float stratum_weight = inv_n * inv_n;
    bool any = false;
    for (int sy = 0; sy < strata; ++sy)
        for (int sx = 0; sx < strata; ++sx) {
            glm::vec2 q(x + (sx + 0.5f) * inv_n, y + (sy + 0.5f) * inv_n);
            glm::vec3 b = tri.bary(q);
            if (b.x < 0.0f || b.y < 0.0f || b.z < 0.0f) continue;
            pending.push_back({texel, tri.make(b, stratum_weight)});
            any = true;
        }
    if (any) return;
    const glm::vec2 c(x + 0.5f, y + 0.5f);
    glm::vec2 best = closest_on_segment(c, tri.uv[0], tri.uv[1]);
    for (int e = 1; e < 3; ++e) {
        glm::vec2 q = closest_on_segment(c, tri.uv[e], tri.uv[(e + 1) % 3]);
        if (glm::dot(q - c, q - c) < glm::dot(best - c, best - c)) best = q;
    }
    glm::vec3 b = glm::clamp(tri.bary(best), 0.0f, 1.0f);
    b /= (b.x + b.y + b.z);
    pending.push_back({texel, tri.make(b, stratum_weight)});
}

// Steps 3 and 4 over the texels of the triangle's bounding box in raster r.
void rasterize_triangle(const UvTriangle& tri, const TexelRaster& r, int strata,
                        std::vector<Pending>& pending, std::vector<float>& texel_size) {
    const glm::vec2 lo = glm::min(tri.uv[0], glm::min(tri.uv[1], tri.uv[2]));
    const glm::vec2 hi = glm::max(tri.uv[0], glm::max(tri.uv[1], tri.uv[2]));
    const int x0 = std::max(0, int(std::floor(lo.x)));
    const int x1 = std::min(r.width - 1, int(std::ceil(hi.x)) - 1);
    const int y0 = std::max(0, int(std::floor(lo.y)));
    const int y1 = std::min(r.height - 1, int(std::ceil(hi.y)) - 1);
    for (int y = y0; y <= y1; ++y)
        for (int x = x0; x <= x1; ++x) {
            if (separated(tri, x, y)) continue;
            const uint32_t texel = uint32_t(y) * r.width + x;
            sample_texel(tri, x, y, texel, strata, pending);
            texel_size[texel] = std::max(texel_size[texel], tri.texel_m);
        }
}

// Steps 2 to 4 over the triangles of one lightmapped primitive (uv1 present) of `obj`.
void rasterize_primitive(const Primitive& prim, const Material& mat, const SceneObject& obj,
                         const glm::dmat3& normal_matrix, const TexelRaster& r, int strata,
                         std::vector<Pending>& pending, std::vector<float>& texel_size) {
    const glm::vec2 size(r.width, r.height);
    UvTriangle tri;
    tri.albedo = glm::vec3(mat.base_color_factor);
    for (size_t t = 0; t + 2 < prim.indices.size(); t += 3) {
        const uint32_t idx[3] = {prim.indices[t], prim.indices[t + 1], prim.indices[t + 2]};
        if (idx[0] >= prim.positions.size() || idx[1] >= prim.positions.size() ||
            idx[2] >= prim.positions.size())
            continue;
        if (!setup_triangle(prim, idx, obj, normal_matrix, size, tri)) continue;
        rasterize_triangle(tri, r, strata, pending, texel_size);
    }
}

// Step 5: the pending samples bucketed into r's CSR, keeping rasterisation order within a texel
// (deterministic), and the coverage counted.
void bucket_samples(TexelRaster& r, const std::vector<Pending>& pending,
                    std::vector<float>&& texel_size) {
    const size_t n = size_t(r.width) * r.height;
    r.first.assign(n + 1, 0);
    for (const Pending& p : pending) ++r.first[p.texel + 1];
    for (size_t i = 0; i < n; ++i) r.first[i + 1] += r.first[i];
    std::vector<uint32_t> cursor(r.first.begin(), r.first.end() - 1);
    r.samples.resize(pending.size());
    for (const Pending& p : pending) r.samples[cursor[p.texel]++] = p.s;
    r.texel_size_m = std::move(texel_size);
    r.covered = 0;
    for (size_t i = 0; i < n; ++i) r.covered += r.is_covered(i) ? 1 : 0;
}

}  // namespace

Result<std::vector<TexelRaster>> rasterize_texels(const Scene& scene, int strata) {
    strata = std::max(1, strata);
    std::vector<int> raster_of_texture;
    auto made = make_rasters(scene, raster_of_texture);
    if (!made) return made.error();
    std::vector<TexelRaster> rasters = std::move(*made);
    std::vector<std::vector<Pending>> pending(rasters.size());
    std::vector<std::vector<float>> texel_size(rasters.size());
    for (size_t i = 0; i < rasters.size(); ++i)
        texel_size[i].assign(size_t(rasters[i].width) * rasters[i].height, 0.0f);

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
                rasterize_primitive(prim, mat, obj, normal_matrix, rasters[ri], strata, pending[ri],
                                    texel_size[ri]);
            }
        }
    }
    for (size_t ri = 0; ri < rasters.size(); ++ri)
        bucket_samples(rasters[ri], pending[ri], std::move(texel_size[ri]));
    return rasters;
}

}  // namespace hmdnode
