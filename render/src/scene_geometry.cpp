// Scene validation, vertex interleaving and material constants shared by the renderer backends
// (see scene_geometry.hpp). Cost: O(vertices + indices + texels) checks, one copy of the geometry.
#include "scene_geometry.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>

#include <numbers>
#include <string>

namespace hmdnode::gpu {
namespace {

std::string where(size_t mesh, size_t prim) {
    return "mesh " + std::to_string(mesh) + " primitive " + std::to_string(prim);
}

}  // namespace

MaterialConstants material_constants(const Material& m) {
    MaterialConstants c;
    c.base_color_factor = m.base_color_factor;
    c.lightmap = glm::vec4(m.lightmap.intensity, m.lightmap.tex_coord == 1 ? 1.0f : 0.0f,
                           m.lightmap.texture >= 0 ? 1.0f : 0.0f,
                           m.lightmap.encoding == LightmapEncoding::Rgbm ? 1.0f : 0.0f);
    c.emissive = glm::vec4(m.emissive_factor, 0.0f);
    return c;
}

Status validate_scene(const Scene& scene, uint32_t max_dim) {
    const auto bad_texture = [&](int t) { return t < -1 || t >= int(scene.textures.size()); };
    for (size_t m = 0; m < scene.materials.size(); ++m) {
        const Material& mat = scene.materials[m];
        if (bad_texture(mat.base_color_texture) || bad_texture(mat.lightmap.texture))
            return make_error("scene: material " + std::to_string(m) + " (" + mat.name +
                              ") refers to a texture that does not exist");
    }
    for (size_t t = 0; t < scene.textures.size(); ++t) {
        const Texture& tex = scene.textures[t];
        if (tex.width < 1 || tex.height < 1 ||
            tex.rgba8.size() != size_t(tex.width) * size_t(tex.height) * 4)
            return make_error("scene: texture " + std::to_string(t) + " (" + tex.name + ") is " +
                              std::to_string(tex.width) + "x" + std::to_string(tex.height) +
                              " but holds " + std::to_string(tex.rgba8.size()) + " bytes");
        if (uint32_t(tex.width) > max_dim || uint32_t(tex.height) > max_dim)
            return make_error("scene: texture " + std::to_string(t) + " (" + tex.name +
                              ") exceeds the device's limit of " + std::to_string(max_dim) +
                              " texels per side");
    }
    for (size_t m = 0; m < scene.meshes.size(); ++m) {
        for (size_t p = 0; p < scene.meshes[m].primitives.size(); ++p) {
            const Primitive& prim = scene.meshes[m].primitives[p];
            const size_t n = prim.positions.size();
            const auto bad_size = [n](size_t s) { return s != 0 && s != n; };
            if (bad_size(prim.normals.size()) || bad_size(prim.uv0.size()) ||
                bad_size(prim.uv1.size()) || bad_size(prim.colors.size()) ||
                bad_size(prim.light.size()))
                return make_error("scene: " + where(m, p) +
                                  ": an attribute count differs from the position count");
            if (prim.indices.size() % 3 != 0)
                return make_error("scene: " + where(m, p) + ": index count is not a multiple of 3");
            for (uint32_t i : prim.indices)
                if (i >= n)
                    return make_error("scene: " + where(m, p) + ": index " + std::to_string(i) +
                                      " out of range (" + std::to_string(n) + " vertices)");
            if (prim.material < -1 || prim.material >= int(scene.materials.size()))
                return make_error("scene: " + where(m, p) + ": material " +
                                  std::to_string(prim.material) + " does not exist");
        }
    }
    return Status::success();
}

Result<SceneGeometry> build_scene_geometry(const Scene& scene) {
    SceneGeometry out;
    size_t vertex_count = 0, index_count = 0;
    for (const Mesh& mesh : scene.meshes)
        for (const Primitive& p : mesh.primitives)
            if (!p.indices.empty()) {
                vertex_count += p.positions.size();
                index_count += p.indices.size();
            }
    if (vertex_count > size_t(INT32_MAX) || index_count > size_t(UINT32_MAX))
        return make_error("scene: too many vertices or indices for 32-bit offsets");

    out.vertices.reserve(vertex_count);
    out.indices.reserve(index_count);
    const uint32_t default_material = uint32_t(scene.materials.size());
    for (const Mesh& mesh : scene.meshes) {
        MeshRange gm;
        gm.first_primitive = uint32_t(out.primitives.size());
        for (const Primitive& p : mesh.primitives) {
            if (p.indices.empty()) continue;
            // A validated scene (validate_scene): attributes empty or one per vertex, whole
            // triangles, a material that exists.
            assert(p.normals.empty() || p.normals.size() == p.positions.size());
            assert(p.uv0.empty() || p.uv0.size() == p.positions.size());
            assert(p.uv1.empty() || p.uv1.size() == p.positions.size());
            assert(p.colors.empty() || p.colors.size() == p.positions.size());
            assert(p.light.empty() || p.light.size() == p.positions.size());
            assert(p.indices.size() % 3 == 0 && p.material < int(scene.materials.size()));
            PrimitiveRange gp;
            gp.first_index = uint32_t(out.indices.size());
            gp.index_count = uint32_t(p.indices.size());
            gp.vertex_offset = int32_t(out.vertices.size());
            gp.material = p.material >= 0 ? uint32_t(p.material) : default_material;
            gp.double_sided = p.material >= 0 && scene.materials[p.material].double_sided;
            for (size_t v = 0; v < p.positions.size(); ++v) {
                Vertex& out_v = out.vertices.emplace_back();
                out_v.position = p.positions[v];
                out_v.normal = p.normals.empty() ? glm::vec3(0, 0, 1) : p.normals[v];
                out_v.uv0 = p.uv0.empty() ? glm::vec2(0) : p.uv0[v];
                out_v.uv1 = p.uv1.empty() ? glm::vec2(0) : p.uv1[v];
                out_v.color = p.colors.empty() ? glm::vec4(1) : p.colors[v];
                out_v.light =
                    p.light.empty() ? glm::vec3(1) : p.light[v] / std::numbers::pi_v<float>;
            }
            out.indices.insert(out.indices.end(), p.indices.begin(), p.indices.end());
            gm.triangles += p.triangle_count();
            out.primitives.push_back(gp);
        }
        gm.primitive_count = uint32_t(out.primitives.size()) - gm.first_primitive;
        out.meshes.push_back(gm);
    }
    // Exactly what the first loop counted, one range per mesh.
    assert(out.vertices.size() == vertex_count && out.indices.size() == index_count);
    assert(out.meshes.size() == scene.meshes.size());
    return out;
}

void texture_uses(const Scene& scene, std::vector<uint8_t>& srgb, std::vector<uint8_t>& unorm) {
    srgb.assign(scene.textures.size(), 0);
    unorm.assign(scene.textures.size(), 0);
    for (const Material& m : scene.materials) {
        assert(m.base_color_texture < int(srgb.size()) && m.lightmap.texture < int(unorm.size()));
        if (m.base_color_texture >= 0) srgb[size_t(m.base_color_texture)] = 1;
        if (m.lightmap.texture >= 0) unorm[size_t(m.lightmap.texture)] = 1;
    }
}

glm::mat4 warp_reprojection(const glm::mat4& p, const glm::dquat& delta) {
    const glm::mat3 rotation = glm::mat3_cast(glm::quat(delta));
    glm::mat3 p3;
    for (int col = 0; col < 3; ++col) p3[col] = glm::vec3(p[col][0], p[col][1], p[col][3]);
    return glm::mat4(p3 * rotation);
}

ScaledViewport scaled_viewport(uint32_t width, uint32_t height, double scale) {
    // check_render_scale() accepted the scale; an eye buffer has a pixel at least.
    assert(width >= 1 && height >= 1 && scale > 0.0 && scale <= 1.0);
    ScaledViewport v;
    v.width = std::clamp(uint32_t(std::lround(double(width) * scale)), 1u, width);
    v.height = std::clamp(uint32_t(std::lround(double(height) * scale)), 1u, height);
    if (v.width == width && v.height == height) return v;  // (1, 1, 1, 1): no change at all
    assert(v.width >= 1 && v.width <= width && v.height >= 1 && v.height <= height);
    v.sample_rect =
        glm::vec4(float(v.width) / float(width), float(v.height) / float(height),
                  (float(v.width) - 0.5f) / float(width), (float(v.height) - 0.5f) / float(height));
    return v;
}

Status check_render_scale(double scale) {
    if (!(scale > 0.0 && scale <= 1.0))
        return make_error("renderer: render scale " + std::to_string(scale) + " is outside (0, 1]");
    return Status::success();
}

Status check_distortion_mesh(const DistortionMesh& m, int eye) {
    if (m.vertices.empty() || m.indices.empty())
        return make_error("warp: the distortion mesh of eye " + std::to_string(eye) + " is empty");
    for (uint32_t i : m.indices)
        if (i >= m.vertices.size())
            return make_error("warp: the distortion mesh of eye " + std::to_string(eye) +
                              " has an index past its vertices");
    return Status::success();
}

bool channels_agree(const DistortionMesh& m) {
    for (const DistortionVertex& v : m.vertices)
        if (v.tangent[0] != v.tangent[1] || v.tangent[2] != v.tangent[1]) return false;
    return true;
}

}  // namespace hmdnode::gpu
