// Direct-light baking: point/spot/directional lights with shadow rays through a TriangleBvh, plus
// a constant ambient term (formula in direct_bake.hpp).
//
// Lightmaps: each triangle is rasterised in uv1 texel space by barycentric edge tests at texel
// centres; then `dilation_texels` passes fill empty texels next to filled ones with the mean of
// their filled 8-neighbours, so bilinear filtering at chart borders never reads the black gutter.
//
// Cost: one shadow ray per light per covered texel / vertex, O(log T) each; memory one vec3 and
// one state byte per texel of the map being baked.
#include "hmdnode/bake/direct_bake.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <set>
#include <string>

#include <glm/gtc/quaternion.hpp>

namespace hmdnode {
namespace {

constexpr float kPi = std::numbers::pi_v<float>;

glm::vec3 transform_point(const glm::dmat4& m, const glm::vec3& p) {
    return glm::vec3(m * glm::dvec4(glm::dvec3(p), 1.0));
}

// Area-weighted vertex normals of an indexed triangle list (used when a primitive has none).
std::vector<glm::vec3> face_weighted_normals(const Primitive& prim) {
    std::vector<glm::vec3> n(prim.positions.size(), glm::vec3(0.0f));
    for (size_t t = 0; t + 2 < prim.indices.size(); t += 3) {
        const glm::vec3& a = prim.positions[prim.indices[t]];
        glm::vec3 fn = glm::cross(prim.positions[prim.indices[t + 1]] - a,
                                  prim.positions[prim.indices[t + 2]] - a);
        for (int k = 0; k < 3; ++k) n[prim.indices[t + k]] += fn;
    }
    for (glm::vec3& v : n) {
        float len = glm::length(v);
        v = len > 0.0f ? v / len : glm::vec3(0.0f, 1.0f, 0.0f);
    }
    return n;
}

bool has_lightmap(const Scene& scene, const Primitive& prim) {
    return prim.material >= 0 && size_t(prim.material) < scene.materials.size() &&
           scene.materials[prim.material].lightmap.texture >= 0;
}

}  // namespace

std::vector<glm::dmat4> node_world_matrices(const Scene& scene) {
    const size_t n = scene.nodes.size();
    std::vector<int> parent(n, -1);
    for (size_t i = 0; i < n; ++i)
        for (int c : scene.nodes[i].children)
            if (c >= 0 && size_t(c) < n && parent[c] < 0 && size_t(c) != i) parent[c] = int(i);
    std::vector<glm::dmat4> world(n, glm::dmat4(1.0));
    std::vector<char> state(n, 0);  // 0 todo, 1 in progress, 2 done
    for (size_t i = 0; i < n; ++i) {
        // Walk up to the first finished ancestor (or a root), then come back down.
        std::vector<int> chain;
        int k = int(i);
        while (k >= 0 && state[k] == 0) {
            state[k] = 1;
            chain.push_back(k);
            k = parent[k];
        }
        glm::dmat4 m =
            (k >= 0 && state[k] == 2) ? world[k] : glm::dmat4(1.0);  // in progress: a cycle
        for (auto it = chain.rbegin(); it != chain.rend(); ++it) {
            m = m * scene.nodes[*it].local_matrix();
            world[*it] = m;
            state[*it] = 2;
        }
    }
    return world;
}

std::vector<WorldLight> world_lights(const Scene& scene) {
    const std::vector<glm::dmat4> world = node_world_matrices(scene);
    std::vector<WorldLight> lights;
    lights.reserve(scene.lights.size());
    for (const Light& l : scene.lights) {
        WorldLight w;
        w.type = l.type;
        glm::dmat4 m =
            (l.node >= 0 && size_t(l.node) < world.size()) ? world[l.node] : glm::dmat4(1.0);
        w.position = glm::vec3(m[3]);
        glm::vec3 fwd = -glm::vec3(m[2]);
        float len = glm::length(fwd);
        w.direction = len > 0.0f ? fwd / len : glm::vec3(0.0f, 0.0f, -1.0f);
        w.intensity_rgb = l.color * l.intensity;
        w.range = l.range;
        if (l.type == Light::Type::Spot) {
            // KHR_lights_punctual's reference cone falloff.
            float cos_outer = std::cos(l.outer_cone_rad);
            float cos_inner = std::cos(l.inner_cone_rad);
            w.cone_scale = 1.0f / std::max(1e-4f, cos_inner - cos_outer);
            w.cone_offset = -cos_outer * w.cone_scale;
        }
        lights.push_back(w);
    }
    return lights;
}

DirectLighting::DirectLighting(const Scene& scene, const DirectBakeOptions& options)
    : options_(options), lights_(world_lights(scene)) {
    std::vector<glm::vec3> corners;
    for (const SceneObject& obj : flatten_objects(scene)) {
        const Mesh& mesh = scene.meshes[obj.levels[0].mesh];
        for (const Primitive& prim : mesh.primitives)
            for (uint32_t i : prim.indices)
                if (i < prim.positions.size())
                    corners.push_back(transform_point(obj.world, prim.positions[i]));
        corners.resize(corners.size() / 3 * 3);
    }
    bvh_ = TriangleBvh(std::move(corners));
}

glm::vec3 DirectLighting::irradiance(const glm::vec3& p, const glm::vec3& n, float skip_m) const {
    glm::vec3 e = kPi * options_.ambient_radiance;
    const glm::vec3 origin = p + n * options_.normal_offset_m;
    for (const WorldLight& l : lights_) {
        glm::vec3 to_light;
        float dist, falloff;
        if (l.type == Light::Type::Directional) {
            to_light = -l.direction;
            dist = std::numeric_limits<float>::infinity();
            falloff = 1.0f;
        } else {
            glm::vec3 d = l.position - p;
            dist = glm::length(d);
            if (dist <= 0.0f) continue;
            to_light = d / dist;
            falloff = 1.0f / (dist * dist);
            if (l.range > 0.0f) {
                float q = dist / l.range;
                falloff *= std::clamp(1.0f - q * q * q * q, 0.0f, 1.0f);
            }
            if (l.type == Light::Type::Spot) {
                float a = std::clamp(
                    glm::dot(l.direction, -to_light) * l.cone_scale + l.cone_offset, 0.0f, 1.0f);
                falloff *= a * a;
            }
        }
        float cos_theta = glm::dot(n, to_light);
        if (cos_theta <= 0.0f || falloff <= 0.0f) continue;
        if (options_.shadows) {
            // The ray leaves from the lifted origin; its length to the light is measured from
            // there.
            glm::vec3 dir = to_light;
            float t_max = std::numeric_limits<float>::max();
            if (l.type != Light::Type::Directional) {
                glm::vec3 d = l.position - origin;
                float len = glm::length(d);
                if (len <= 0.0f) continue;
                dir = d / len;
                t_max = len;
            }
            if (bvh_.occluded(origin, dir, skip_m, t_max)) continue;
        }
        e += l.intensity_rgb * (cos_theta * falloff);
    }
    return e;
}

Result<std::vector<LightmapBake>> bake_lightmaps(Scene& scene, const DirectLighting& lighting,
                                                 const DirectBakeOptions& options) {
    // Which textures are lightmaps, and validation.
    std::vector<int> map_of_texture(scene.textures.size(), -1);
    std::vector<LightmapBake> maps;
    for (size_t m = 0; m < scene.materials.size(); ++m) {
        int tex = scene.materials[m].lightmap.texture;
        if (tex < 0) continue;
        if (size_t(tex) >= scene.textures.size())
            return make_error("material " + std::to_string(m) + " '" + scene.materials[m].name +
                              "': lightmap texture " + std::to_string(tex) + " does not exist");
        const Texture& t = scene.textures[tex];
        if (t.width <= 0 || t.height <= 0)
            return make_error("lightmap texture " + std::to_string(tex) + " '" + t.name +
                              "' has no size");
        if (map_of_texture[tex] < 0) {
            map_of_texture[tex] = int(maps.size());
            LightmapBake b;
            b.texture = tex;
            b.width = t.width;
            b.height = t.height;
            b.irradiance.assign(size_t(t.width) * t.height, glm::vec3(0.0f));
            maps.push_back(std::move(b));
        }
    }
    std::vector<std::vector<uint8_t>> state(maps.size());  // 0 empty, 1 covered, 2 dilated
    for (size_t i = 0; i < maps.size(); ++i) state[i].assign(maps[i].irradiance.size(), 0);

    // Rasterise.
    const int samples = std::max(1, options.texel_samples);
    std::set<int> done_meshes;
    for (const SceneObject& obj : flatten_objects(scene)) {
        const glm::dmat3 normal_matrix = glm::transpose(glm::inverse(glm::dmat3(obj.world)));
        for (const LodLevel& level : obj.levels) {
            if (!done_meshes.insert(level.mesh).second) continue;
            const Mesh& mesh = scene.meshes[level.mesh];
            for (size_t pi = 0; pi < mesh.primitives.size(); ++pi) {
                const Primitive& prim = mesh.primitives[pi];
                if (!has_lightmap(scene, prim)) continue;
                if (prim.uv1.size() != prim.positions.size())
                    return make_error("mesh '" + mesh.name + "' primitive " + std::to_string(pi) +
                                      " uses a lightmap material but has no TEXCOORD_1");
                const int mi = map_of_texture[scene.materials[prim.material].lightmap.texture];
                LightmapBake& map = maps[mi];
                std::vector<uint8_t>& st = state[mi];
                const glm::vec2 size(map.width, map.height);
                for (size_t t = 0; t + 2 < prim.indices.size(); t += 3) {
                    uint32_t ia = prim.indices[t], ib = prim.indices[t + 1],
                             ic = prim.indices[t + 2];
                    if (ia >= prim.positions.size() || ib >= prim.positions.size() ||
                        ic >= prim.positions.size())
                        continue;
                    glm::vec2 a = prim.uv1[ia] * size, b = prim.uv1[ib] * size,
                              c = prim.uv1[ic] * size;
                    float area = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
                    if (area == 0.0f || !std::isfinite(area)) continue;
                    glm::vec3 wa = transform_point(obj.world, prim.positions[ia]);
                    glm::vec3 wb = transform_point(obj.world, prim.positions[ib]);
                    glm::vec3 wc = transform_point(obj.world, prim.positions[ic]);
                    glm::vec3 face_n = glm::normalize(glm::cross(wb - wa, wc - wa));
                    glm::vec2 lo = glm::min(a, glm::min(b, c)), hi = glm::max(a, glm::max(b, c));
                    int x0 = std::max(0, int(std::floor(lo.x - 0.5f))),
                        x1 = std::min(map.width - 1, int(std::ceil(hi.x - 0.5f)));
                    int y0 = std::max(0, int(std::floor(lo.y - 0.5f))),
                        y1 = std::min(map.height - 1, int(std::ceil(hi.y - 0.5f)));
                    // note: a tiny tolerance keeps texel centres on shared edges from falling
                    // through the crack between two triangles.
                    const float eps = -1e-5f;
                    for (int y = y0; y <= y1; ++y)
                        for (int x = x0; x <= x1; ++x) {
                            size_t idx = size_t(y) * map.width + x;
                            if (st[idx]) continue;
                            glm::vec2 p(x + 0.5f, y + 0.5f);
                            float w0 =
                                ((b.x - p.x) * (c.y - p.y) - (b.y - p.y) * (c.x - p.x)) / area;
                            float w1 =
                                ((c.x - p.x) * (a.y - p.y) - (c.y - p.y) * (a.x - p.x)) / area;
                            float w2 = 1.0f - w0 - w1;
                            if (w0 < eps || w1 < eps || w2 < eps) continue;
                            auto sample = [&](float b0, float b1, float b2) {
                                glm::vec3 wp = b0 * wa + b1 * wb + b2 * wc;
                                glm::vec3 n = face_n;
                                if (prim.normals.size() == prim.positions.size()) {
                                    glm::vec3 ln = b0 * prim.normals[ia] + b1 * prim.normals[ib] +
                                                   b2 * prim.normals[ic];
                                    glm::vec3 wn = glm::vec3(normal_matrix * glm::dvec3(ln));
                                    float len = glm::length(wn);
                                    if (len > 0.0f) n = wn / len;
                                }
                                return lighting.irradiance(wp, n);
                            };
                            if (samples <= 1) {
                                map.irradiance[idx] = sample(w0, w1, w2);
                            } else {
                                glm::vec3 sum(0.0f);
                                for (int sy = 0; sy < samples; ++sy)
                                    for (int sx = 0; sx < samples; ++sx) {
                                        glm::vec2 q(x + (sx + 0.5f) / samples,
                                                    y + (sy + 0.5f) / samples);
                                        float s0 = std::max(0.0f, ((b.x - q.x) * (c.y - q.y) -
                                                                   (b.y - q.y) * (c.x - q.x)) /
                                                                      area);
                                        float s1 = std::max(0.0f, ((c.x - q.x) * (a.y - q.y) -
                                                                   (c.y - q.y) * (a.x - q.x)) /
                                                                      area);
                                        float s2 = std::max(0.0f, ((a.x - q.x) * (b.y - q.y) -
                                                                   (a.y - q.y) * (b.x - q.x)) /
                                                                      area);
                                        float total =
                                            s0 + s1 + s2;  // > 0: clamped onto the triangle
                                        sum += sample(s0 / total, s1 / total, s2 / total);
                                    }
                                map.irradiance[idx] = sum / float(samples * samples);
                            }
                            st[idx] = 1;
                            ++map.covered_texels;
                        }
                }
            }
        }
    }

    // Dilate, encode, and write the intensities.
    for (size_t mi = 0; mi < maps.size(); ++mi) {
        LightmapBake& map = maps[mi];
        std::vector<uint8_t>& st = state[mi];
        const int w = map.width, h = map.height;
        for (int pass = 0; pass < options.dilation_texels; ++pass) {
            std::vector<uint8_t> before = st;
            for (int y = 0; y < h; ++y)
                for (int x = 0; x < w; ++x) {
                    size_t idx = size_t(y) * w + x;
                    if (before[idx]) continue;
                    glm::vec3 sum(0.0f);
                    int count = 0;
                    for (int dy = -1; dy <= 1; ++dy)
                        for (int dx = -1; dx <= 1; ++dx) {
                            int nx = x + dx, ny = y + dy;
                            if ((dx == 0 && dy == 0) || nx < 0 || ny < 0 || nx >= w || ny >= h)
                                continue;
                            size_t nidx = size_t(ny) * w + nx;
                            if (!before[nidx]) continue;
                            sum += map.irradiance[nidx];
                            ++count;
                        }
                    if (count == 0) continue;
                    map.irradiance[idx] = sum / float(count);
                    st[idx] = 2;
                    ++map.dilated_texels;
                }
        }
        float max_e = 0.0f;
        for (const glm::vec3& e : map.irradiance) max_e = std::max({max_e, e.r, e.g, e.b});
        map.intensity = max_e > 0.0f ? max_e : 1.0f;
        Texture& tex = scene.textures[map.texture];
        tex.rgba8.assign(size_t(w) * h * 4, 0);
        for (size_t i = 0; i < map.irradiance.size(); ++i) {
            for (int c = 0; c < 3; ++c)
                tex.rgba8[4 * i + c] = uint8_t(std::lround(
                    std::clamp(map.irradiance[i][c] / map.intensity, 0.0f, 1.0f) * 255.0f));
            tex.rgba8[4 * i + 3] = 255;
        }
        for (Material& m : scene.materials)
            if (m.lightmap.texture == map.texture) m.lightmap.intensity = map.intensity;
    }
    return maps;
}

size_t bake_vertex_colors(Scene& scene, const DirectLighting& lighting) {
    size_t baked = 0;
    std::set<int> done_meshes;
    for (const SceneObject& obj : flatten_objects(scene)) {
        const glm::dmat3 normal_matrix = glm::transpose(glm::inverse(glm::dmat3(obj.world)));
        for (size_t li = 0; li < obj.levels.size(); ++li) {
            const LodLevel& level = obj.levels[li];
            if (!done_meshes.insert(level.mesh).second) continue;
            const float skip_m = li == 0 ? 0.0f : float(2.0 * level.geometric_error_m);
            for (Primitive& prim : scene.meshes[level.mesh].primitives) {
                if (has_lightmap(scene, prim) && prim.uv1.size() == prim.positions.size()) continue;
                std::vector<glm::vec3> computed;
                const std::vector<glm::vec3>* normals = &prim.normals;
                if (prim.normals.size() != prim.positions.size()) {
                    computed = face_weighted_normals(prim);
                    normals = &computed;
                }
                prim.colors.resize(prim.positions.size());
                for (size_t i = 0; i < prim.positions.size(); ++i) {
                    glm::vec3 p = transform_point(obj.world, prim.positions[i]);
                    glm::vec3 n = glm::vec3(normal_matrix * glm::dvec3((*normals)[i]));
                    float len = glm::length(n);
                    n = len > 0.0f ? n / len : glm::vec3(0.0f, 1.0f, 0.0f);
                    prim.colors[i] = glm::vec4(lighting.irradiance(p, n, skip_m) / kPi, 1.0f);
                }
                baked += prim.positions.size();
            }
        }
    }
    return baked;
}

}  // namespace hmdnode
