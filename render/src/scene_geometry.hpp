// What every renderer backend uploads of a scene, backend-neutral: the validation of the core
// scene model, every mesh's primitives interleaved into one vertex array and one 32-bit index
// array (grouped by mesh), and the per-material shading constants (docs/formats.md). Used by the
// Vulkan (gpu_scene.cpp) and GLES (gles_scene.cpp) uploads so both draw exactly the same data.
// Cost: O(vertices + indices + materials) CPU work and memory, at upload time only.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

#include "hmdnode/core/result.hpp"
#include "hmdnode/core/scene.hpp"
#include "hmdnode/render/lens.hpp"

namespace hmdnode::gpu {

// Interleaved vertex, 68 bytes. Missing attributes get defaults: normal (0,0,1), uv (0,0),
// colour (1,1,1,1), light 1.
struct Vertex {
    glm::vec3 position;
    glm::vec3 normal;  // not read by the scene shaders today; kept for later lighting passes
    glm::vec2 uv0;
    glm::vec2 uv1;
    glm::vec4 color;
    glm::vec3 light;  // _LIGHT_0 / pi (baked diffuse light), 1 when absent (unlit)
};
static_assert(sizeof(Vertex) == 68);

// Shading constants of one material (std140 layout: the Vulkan uniform block).
struct MaterialConstants {
    glm::vec4 base_color_factor;
    glm::vec4 lightmap;  // x intensity, y uv set (0/1), z 1 when lightmapped, w 1 when RGBM
    glm::vec4 emissive;  // rgb emissiveFactor (linear radiance relative to white), w unused
};
MaterialConstants material_constants(const Material& m);

struct PrimitiveRange {
    uint32_t first_index = 0;
    uint32_t index_count = 0;
    int32_t vertex_offset = 0;
    uint32_t material = 0;  // Scene::materials index; the default material is materials.size()
    bool double_sided = false;
};

struct MeshRange {
    uint32_t first_primitive = 0;
    uint32_t primitive_count = 0;
    uint64_t triangles = 0;
};

struct SceneGeometry {
    std::vector<Vertex> vertices;
    std::vector<uint32_t> indices;
    std::vector<PrimitiveRange>
        primitives;                 // grouped by mesh, primitives without triangles dropped
    std::vector<MeshRange> meshes;  // same indices as Scene::meshes
};

// Errors name the mesh, primitive, material or texture that is malformed (index out of range,
// attribute count, pixel count, a texture beyond max_texture_dim texels per side).
Status validate_scene(const Scene& scene, uint32_t max_texture_dim);

// The interleaved geometry of a validated scene. Errors: more vertices or indices than 32-bit
// offsets address.
Result<SceneGeometry> build_scene_geometry(const Scene& scene);

// Which views each texture needs: [t] = 1 when a material samples texture t as base colour (sRGB)
// or as a lightmap (UNORM).
void texture_uses(const Scene& scene, std::vector<uint8_t>& srgb, std::vector<uint8_t>& unorm);

// The late warp's per-eye matrix: display direction -> rendered head frame (delta) -> the eye
// buffer's clip x, y, w (rows 0, 1 and 3 of the rendered projection; directions have w = 0, so the
// view's translation drops out), in the upper 3x3 of the result.
glm::mat4 warp_reprojection(const glm::mat4& rendered_projection, const glm::dquat& delta);

// Dynamic resolution (Renderer::set_render_scale): the part of a width x height eye buffer a frame
// at `scale` renders into (its top-left corner, whole pixels, at least one), and the warp's
// sample_rect for it (xy: that part's fraction of the buffer, zw: the largest texture
// coordinate, its last texel centre, so bilinear filtering never reads past it).
struct ScaledViewport {
    uint32_t width = 1, height = 1;
    glm::vec4 sample_rect{1.0f};
};
ScaledViewport scaled_viewport(uint32_t width, uint32_t height, double scale);
// Errors: a scale outside (0, 1].
Status check_render_scale(double scale);

// Errors: an empty distortion mesh, an index past its vertices (naming the eye).
Status check_distortion_mesh(const DistortionMesh& mesh, int eye);

// True when every vertex shows one direction for all three colours (no chromatic aberration):
// the warp then samples once per pixel instead of once per channel.
bool channels_agree(const DistortionMesh& mesh);

}  // namespace hmdnode::gpu
