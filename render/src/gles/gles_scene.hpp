// A scene resident in the GLES context: the interleaved geometry of scene_geometry.hpp in one
// vertex array object (indices rebased to the whole vertex buffer, so no base-vertex draws are
// needed: OpenGL ES 3.0 has none), every used texture as an sRGB texture (base colour) and/or a
// UNORM one (lightmap), and each material's constants and textures. Built by upload_scene(),
// immutable after; memory: 68 bytes per vertex, 4 per index, 4 per texel per use.
#pragma once

#include <memory>
#include <vector>

#include "gles_context.hpp"
#include "hmdnode/core/scene.hpp"
#include "scene_geometry.hpp"

namespace hmdnode::gles {

struct GlesMaterial {
    gpu::MaterialConstants constants;
    GLuint base_color = 0;  // a texture of GlesScene (or its white fallback)
    GLuint lightmap = 0;
};

struct GlesScene {
    Buffer vertices, indices;
    VertexArray vertex_array;             // empty when the scene has no triangles
    std::vector<Texture> srgb, unorm;     // same indices as Scene::textures; empty where unused
    Texture white;                        // 1x1 white, the fallback
    std::vector<GlesMaterial> materials;  // Scene::materials, then the default material
    std::vector<gpu::PrimitiveRange> primitives;
    std::vector<gpu::MeshRange> meshes;
};

// Validates and uploads the scene (the context must be current). Errors name the mesh, primitive,
// material or texture that is malformed, or the GL failure.
Result<std::unique_ptr<GlesScene>> upload_scene(const Scene& scene);

}  // namespace hmdnode::gles
