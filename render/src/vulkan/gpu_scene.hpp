// A scene resident on the device: every mesh's primitives in one interleaved vertex buffer and
// one 32-bit index buffer, every used texture as an image (sRGB view for base colour, UNORM view
// for lightmaps), and one descriptor set per material. Built by upload_scene(), immutable after;
// memory: 56 bytes per vertex, 4 per index, 4 per texel, 256 or less per material.
#pragma once

#include <memory>
#include <vector>

#include "hmdnode/core/scene.hpp"
#include "scene_geometry.hpp"
#include "vk_memory.hpp"

namespace hmdnode::vk {

using GpuPrimitive = gpu::PrimitiveRange;
using GpuMesh = gpu::MeshRange;

struct GpuTexture {
    Image image;           // empty when no material uses the texture
    ImageView srgb_view;   // base colour
    ImageView unorm_view;  // lightmap
};

struct GpuScene {
    Buffer vertices;  // empty when the scene has no triangles
    Buffer indices;
    Buffer material_constants;  // one MaterialConstants per material, at material_stride
    VkDeviceSize material_stride = 0;
    std::vector<GpuTexture> textures;  // same indices as Scene::textures
    GpuTexture white;                  // 1x1 white (1.0 through either view), the fallback
    Sampler base_color_sampler;        // linear, repeat
    Sampler lightmap_sampler;          // linear, clamp to edge
    DescriptorPool descriptor_pool;
    std::vector<VkDescriptorSet> material_sets;  // Scene::materials, then the default material
    std::vector<GpuPrimitive> primitives;  // grouped by mesh, primitives without triangles dropped
    std::vector<GpuMesh> meshes;           // same indices as Scene::meshes
};

// Validates and uploads the scene; waits for the copies to finish. Errors name the mesh,
// primitive, material or texture that is malformed (index out of range, attribute count, pixel
// count), or the Vulkan call that failed.
Result<std::unique_ptr<GpuScene>> upload_scene(DeviceContext& ctx, const Scene& scene,
                                               VkDescriptorSetLayout material_layout);

}  // namespace hmdnode::vk
