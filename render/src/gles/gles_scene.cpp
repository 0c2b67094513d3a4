// Scene upload for the GLES backend (see gles_scene.hpp). Cost: O(vertices + indices + texels) CPU
// work and one copy of each into the driver, at upload time only.
#include "gles_scene.hpp"

#include <cstddef>

#include "gles_shaders.hpp"

namespace hmdnode::gles {
namespace {

// Linear filtering of the base level only (the Vulkan samplers' maxLod 0).
Texture make_texture(GLenum internal_format, int width, int height, const uint8_t* rgba8,
                     GLenum wrap) {
    Texture t = make<Texture>(glGenTextures);
    glBindTexture(GL_TEXTURE_2D, t);
    glTexStorage2D(GL_TEXTURE_2D, 1, internal_format, width, height);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
    glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, width, height, GL_RGBA, GL_UNSIGNED_BYTE, rgba8);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, wrap);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, wrap);
    return t;
}

void set_attribute(GLuint location, int components, size_t offset) {
    glEnableVertexAttribArray(location);
    glVertexAttribPointer(location, components, GL_FLOAT, GL_FALSE, sizeof(gpu::Vertex),
                          reinterpret_cast<const void*>(offset));
}

}  // namespace

Result<std::unique_ptr<GlesScene>> upload_scene(const Scene& scene) {
    GLint max_dim = 0;
    glGetIntegerv(GL_MAX_TEXTURE_SIZE, &max_dim);
    if (Status s = gpu::validate_scene(scene, uint32_t(max_dim)); !s) return s.error();
    auto geometry = gpu::build_scene_geometry(scene);
    if (!geometry) return geometry.error();
    auto out = std::make_unique<GlesScene>();

    // 1. Geometry: indices rebased by their primitive's vertex offset.
    out->primitives = std::move(geometry->primitives);
    out->meshes = std::move(geometry->meshes);
    for (const gpu::PrimitiveRange& p : out->primitives)
        for (uint32_t i = 0; i < p.index_count; ++i)
            geometry->indices[p.first_index + i] += uint32_t(p.vertex_offset);
    if (!geometry->vertices.empty()) {
        out->vertex_array = make<VertexArray>(glGenVertexArrays);
        glBindVertexArray(out->vertex_array);
        out->vertices = make<Buffer>(glGenBuffers);
        glBindBuffer(GL_ARRAY_BUFFER, out->vertices);
        glBufferData(GL_ARRAY_BUFFER, GLsizeiptr(geometry->vertices.size() * sizeof(gpu::Vertex)),
                     geometry->vertices.data(), GL_STATIC_DRAW);
        out->indices = make<Buffer>(glGenBuffers);
        glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, out->indices);  // recorded in the vertex array
        glBufferData(GL_ELEMENT_ARRAY_BUFFER, GLsizeiptr(geometry->indices.size() * 4),
                     geometry->indices.data(), GL_STATIC_DRAW);
        set_attribute(kPosition, 3, offsetof(gpu::Vertex, position));
        set_attribute(kUv0, 2, offsetof(gpu::Vertex, uv0));
        set_attribute(kUv1, 2, offsetof(gpu::Vertex, uv1));
        set_attribute(kColor, 4, offsetof(gpu::Vertex, color));
        set_attribute(kLight, 3, offsetof(gpu::Vertex, light));
        glBindVertexArray(0);
    }

    // 2. Textures, in the views their materials need.
    std::vector<uint8_t> srgb, unorm;
    gpu::texture_uses(scene, srgb, unorm);
    const uint8_t white_texel[4] = {255, 255, 255, 255};
    out->white = make_texture(GL_RGBA8, 1, 1, white_texel, GL_CLAMP_TO_EDGE);
    out->srgb.resize(scene.textures.size());
    out->unorm.resize(scene.textures.size());
    for (size_t t = 0; t < scene.textures.size(); ++t) {
        const hmdnode::Texture& tex = scene.textures[t];
        if (srgb[t])
            out->srgb[t] =
                make_texture(GL_SRGB8_ALPHA8, tex.width, tex.height, tex.rgba8.data(), GL_REPEAT);
        if (unorm[t])
            out->unorm[t] =
                make_texture(GL_RGBA8, tex.width, tex.height, tex.rgba8.data(), GL_CLAMP_TO_EDGE);
    }
    glBindTexture(GL_TEXTURE_2D, 0);

    // 3. Materials (the default one last).
    for (size_t i = 0; i <= scene.materials.size(); ++i) {
        const Material fallback;
        const Material& m = i < scene.materials.size() ? scene.materials[i] : fallback;
        GlesMaterial gm;
        gm.constants = gpu::material_constants(m);
        gm.base_color =
            m.base_color_texture >= 0 ? out->srgb[size_t(m.base_color_texture)].get() : out->white;
        gm.lightmap =
            m.lightmap.texture >= 0 ? out->unorm[size_t(m.lightmap.texture)].get() : out->white;
        out->materials.push_back(gm);
    }
    if (Status s = check_gl("scene upload"); !s) return s.error();
    return out;
}

}  // namespace hmdnode::gles
