// The scene model: what the glTF loader produces, the renderer uploads, the baker and the LOD
// generator transform and the writer stores. Plain data; indices refer into Scene's vectors and
// -1 means "none".
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

namespace hmdnode {

struct Texture {
    std::string name;
    int width = 0;
    int height = 0;
    std::vector<uint8_t> rgba8;  // decoded RGBA8, rows top to bottom (glTF uv (0,0) = top-left)
};

// How a lightmap's RGBA8 texels hold irradiance (MOZ_lightmap.extras.encoding, docs/formats.md):
// Linear: E = rgb * intensity (rgb in [0, 1], alpha unused; files without the field);
// Rgbm: E = rgb * a * intensity (a shared multiplier in alpha: 8-bit HDR that keeps <= 0.8 %
// relative error down to 1e-3 of intensity).
enum class LightmapEncoding { Linear, Rgbm };

// MOZ_lightmap {index, texCoord, intensity}: texels hold linear irradiance E scaled into [0,1]
// (as `encoding` says); the renderer's diffuse light is albedo * E / pi (see docs/formats.md).
struct Lightmap {
    int texture = -1;
    int tex_coord = 1;
    float intensity = 1.0f;
    LightmapEncoding encoding = LightmapEncoding::Linear;
};

struct Material {
    std::string name;
    glm::vec4 base_color_factor{1.0f};
    int base_color_texture = -1;  // texture index; sampled with TEXCOORD_0, sRGB
    Lightmap lightmap;            // lightmap.texture == -1: no lightmap
    bool double_sided = false;
    glm::vec3 emissive_factor{0.0f};  // emissiveFactor: linear emitted radiance (baker light)
};

// One indexed triangle list. Attribute arrays are either empty or have positions.size() entries.
struct Primitive {
    std::vector<glm::vec3> positions;
    std::vector<glm::vec3> normals;
    std::vector<glm::vec2> uv0;     // TEXCOORD_0
    std::vector<glm::vec2> uv1;     // TEXCOORD_1 (lightmap)
    std::vector<glm::vec4> colors;  // COLOR_0: linear vertex colour in [0, 1], multiplies albedo
    // _LIGHT_0 (float VEC3): baked irradiance E per vertex (linear, lux, may exceed 1); the
    // renderer's diffuse is albedo * E / pi where the material has no lightmap (docs/formats.md).
    std::vector<glm::vec3> light;
    std::vector<uint32_t> indices;  // triangles, 3 per face
    int material = -1;

    size_t triangle_count() const { return indices.size() / 3; }
};

// Sets p.normals to area-weighted vertex normals (the unnormalised face normals summed at each
// corner, then normalised); a vertex of no area (or a non-finite sum) gets `no_area`.
void compute_vertex_normals(Primitive& p, glm::vec3 no_area = glm::vec3(0.0f, 1.0f, 0.0f));

struct Mesh {
    std::string name;
    std::vector<Primitive> primitives;

    size_t triangle_count() const;
};

struct Node {
    std::string name;
    glm::dvec3 translation{0.0};
    glm::dquat rotation{1.0, 0.0, 0.0, 0.0};
    glm::dvec3 scale{1.0};
    int mesh = -1;
    std::vector<int> children;
    // MSFT_lod on this node: ids of the nodes holding the coarser levels (level 1, 2, ...); this
    // node itself is level 0. screen_coverage is extras.MSFT_screencoverage (may be empty).
    std::vector<int> lod_ids;
    std::vector<double> screen_coverage;
    // extras.geometric_error: the geometric error of this node's mesh as a level of detail,
    // in metres of the mesh's own space (0 for an original mesh); negative when absent.
    double geometric_error_m = -1.0;

    glm::dmat4 local_matrix() const;
};

// A light for the baker (KHR_lights_punctual).
struct Light {
    enum class Type { Point, Spot, Directional };
    std::string name;
    Type type = Type::Point;
    glm::vec3 color{1.0f};
    float intensity = 1.0f;  // candela (point/spot), lux (directional)
    float range = 0.0f;      // 0 = infinite
    float inner_cone_rad = 0.0f, outer_cone_rad = 0.785398f;
    int node = -1;  // node that places the light
};

struct Scene {
    std::vector<Node> nodes;
    std::vector<int> roots;  // nodes of the default scene
    std::vector<Mesh> meshes;
    std::vector<Material> materials;
    std::vector<Texture> textures;
    std::vector<Light> lights;
};

// A drawable object of the flattened scene: a node with a mesh (not itself an MSFT_lod alternate)
// and its chain of levels, level 0 finest.
struct LodLevel {
    int mesh = -1;
    double geometric_error_m = 0.0;  // in world metres (scaled by the node's world scale)
    size_t triangles = 0;
};
struct SceneObject {
    std::string name;
    int node = -1;
    glm::dmat4 world{1.0};
    glm::dvec3 bounds_center{0.0};  // world-space bounding sphere of level 0
    double bounds_radius = 0.0;
    std::vector<LodLevel> levels;  // size >= 1
};

// Flattens the node hierarchy of the default scene into objects with world transforms and LOD
// chains. Nodes referenced by some MSFT_lod are levels of that chain, never objects of their own.
std::vector<SceneObject> flatten_objects(const Scene& scene);

}  // namespace hmdnode
