// Scene upload: validation, vertex interleaving, texture staging and material descriptor sets.
// Cost: O(vertices + indices + texels) CPU work and one staging copy of the textures, at upload
// time only; temporary memory: the interleaved vertices and the staged texels.
#include "gpu_scene.hpp"

#include <algorithm>
#include <cassert>
#include <cstring>
#include <string>

#include "scene_pipeline.hpp"
#include "vk_check.hpp"

namespace hmdnode::vk {
namespace {

// One texture to copy from the staging buffer.
struct TextureCopy {
    VkImage image;
    uint32_t width, height;
    VkDeviceSize offset;
};

// Creates the image and the views the materials need (sRGB, UNORM or both through a
// mutable-format image).
Result<GpuTexture> create_texture(const DeviceContext& ctx, uint32_t width, uint32_t height,
                                  bool srgb, bool unorm) {
    GpuTexture t;
    ImageDesc desc{width,
                   height,
                   1,
                   srgb && !unorm ? VK_FORMAT_R8G8B8A8_SRGB : VK_FORMAT_R8G8B8A8_UNORM,
                   VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT,
                   srgb && unorm ? VkImageCreateFlags(VK_IMAGE_CREATE_MUTABLE_FORMAT_BIT) : 0};
    auto image = create_image(ctx, desc, "texture");
    if (!image) return image.error();
    t.image = std::move(*image);
    if (srgb) {
        auto view = create_view(ctx, t.image, VK_FORMAT_R8G8B8A8_SRGB, VK_IMAGE_ASPECT_COLOR_BIT,
                                "texture (sRGB)");
        if (!view) return view.error();
        t.srgb_view = std::move(*view);
    }
    if (unorm) {
        auto view = create_view(ctx, t.image, VK_FORMAT_R8G8B8A8_UNORM, VK_IMAGE_ASPECT_COLOR_BIT,
                                "texture (UNORM)");
        if (!view) return view.error();
        t.unorm_view = std::move(*view);
    }
    return t;
}

void record_texture_copies(VkCommandBuffer cmd, VkBuffer staging,
                           const std::vector<TextureCopy>& copies) {
    const VkImageSubresourceRange range{VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    std::vector<VkImageMemoryBarrier> barriers(copies.size());
    for (size_t i = 0; i < copies.size(); ++i) {
        VkImageMemoryBarrier& b = barriers[i];
        b.sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER;
        b.srcAccessMask = 0;
        b.dstAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
        b.oldLayout = VK_IMAGE_LAYOUT_UNDEFINED;
        b.newLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
        b.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
        b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
        b.image = copies[i].image;
        b.subresourceRange = range;
    }
    vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, 0,
                         0, nullptr, 0, nullptr, uint32_t(barriers.size()), barriers.data());
    for (const TextureCopy& c : copies) {
        VkBufferImageCopy region{};
        region.bufferOffset = c.offset;
        region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
        region.imageExtent = {c.width, c.height, 1};
        vkCmdCopyBufferToImage(cmd, staging, c.image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1,
                               &region);
    }
    for (VkImageMemoryBarrier& b : barriers) {
        b.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
        b.dstAccessMask = VK_ACCESS_SHADER_READ_BIT;
        b.oldLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
        b.newLayout = VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL;
    }
    vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_FRAGMENT_SHADER_BIT,
                         0, 0, nullptr, 0, nullptr, uint32_t(barriers.size()), barriers.data());
}

Status upload_textures(DeviceContext& ctx, const Scene& scene, GpuScene& out) {
    // 1. Which views each texture needs.
    const size_t n = scene.textures.size();
    std::vector<uint8_t> srgb, unorm;
    gpu::texture_uses(scene, srgb, unorm);

    // 2. Images, and their place in one staging buffer (the white fallback first).
    const uint8_t white_texel[4] = {255, 255, 255, 255};
    auto white = create_texture(ctx, 1, 1, false, true);
    if (!white) return white.error();
    out.white = std::move(*white);
    std::vector<TextureCopy> copies{{out.white.image.get(), 1, 1, 0}};
    VkDeviceSize staging_size = 4;
    out.textures.resize(n);
    for (size_t t = 0; t < n; ++t) {
        if (!srgb[t] && !unorm[t]) continue;
        const Texture& tex = scene.textures[t];
        // validate_scene(): a sized texture holding its RGBA8 texels.
        assert(tex.width >= 1 && tex.height >= 1 &&
               tex.rgba8.size() == size_t(tex.width) * size_t(tex.height) * 4);
        auto gpu =
            create_texture(ctx, uint32_t(tex.width), uint32_t(tex.height), srgb[t], unorm[t]);
        if (!gpu) return gpu.error();
        out.textures[t] = std::move(*gpu);
        copies.push_back(
            {out.textures[t].image.get(), uint32_t(tex.width), uint32_t(tex.height), staging_size});
        staging_size += tex.rgba8.size();  // multiple of 4: offsets stay texel-aligned
    }

    // 3. Stage and copy.
    auto staging = create_buffer(ctx, staging_size, VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                                 MemoryUse::Upload, "texture staging");
    if (!staging) return staging.error();
    auto* dst = static_cast<uint8_t*>(staging->mapped());
    std::memcpy(dst, white_texel, 4);
    for (size_t t = 0, c = 1; t < n; ++t) {
        if (!srgb[t] && !unorm[t]) continue;
        // Each texture at its own offset, in the order the copies were planned.
        assert(c < copies.size() &&
               copies[c].offset + scene.textures[t].rgba8.size() <= staging_size);
        std::memcpy(dst + copies[c++].offset, scene.textures[t].rgba8.data(),
                    scene.textures[t].rgba8.size());
    }
    if (Status s = staging->flush(); !s) return s;
    return ctx.submit_and_wait(
        [&](VkCommandBuffer cmd) { record_texture_copies(cmd, staging->get(), copies); });
}

Status upload_geometry(DeviceContext& ctx, const Scene& scene, GpuScene& out) {
    auto geometry = gpu::build_scene_geometry(scene);
    if (!geometry) return geometry.error();
    const std::vector<gpu::Vertex>& vertices = geometry->vertices;
    const std::vector<uint32_t>& indices = geometry->indices;
    out.primitives = std::move(geometry->primitives);
    out.meshes = std::move(geometry->meshes);
    if (vertices.empty()) return Status::success();

    auto vb = create_buffer_with_data(ctx, std::as_bytes(std::span(vertices)),
                                      VK_BUFFER_USAGE_VERTEX_BUFFER_BIT, "vertex buffer");
    if (!vb) return vb.error();
    out.vertices = std::move(*vb);
    auto ib = create_buffer_with_data(ctx, std::as_bytes(std::span(indices)),
                                      VK_BUFFER_USAGE_INDEX_BUFFER_BIT, "index buffer");
    if (!ib) return ib.error();
    out.indices = std::move(*ib);
    return Status::success();
}

Status create_materials(DeviceContext& ctx, const Scene& scene, VkDescriptorSetLayout layout,
                        GpuScene& out) {
    const uint32_t count = uint32_t(scene.materials.size()) + 1;  // + the default material

    // 1. Constants, one aligned slot per material.
    const VkDeviceSize align =
        std::max<VkDeviceSize>(ctx.properties.limits.minUniformBufferOffsetAlignment, 1);
    out.material_stride = (sizeof(MaterialConstants) + align - 1) / align * align;
    std::vector<std::byte> constants(out.material_stride * count);
    for (uint32_t i = 0; i < count; ++i) {
        const Material fallback;
        const Material& m = i < scene.materials.size() ? scene.materials[i] : fallback;
        const MaterialConstants c = gpu::material_constants(m);
        std::memcpy(constants.data() + i * out.material_stride, &c, sizeof(c));
    }
    auto buffer = create_buffer_with_data(ctx, constants, VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT,
                                          "material constants");
    if (!buffer) return buffer.error();
    out.material_constants = std::move(*buffer);

    // 2. Samplers and descriptor sets.
    auto base_sampler = create_sampler(ctx, VK_SAMPLER_ADDRESS_MODE_REPEAT, "vkCreateSampler");
    if (!base_sampler) return base_sampler.error();
    out.base_color_sampler = std::move(*base_sampler);
    auto lightmap_sampler =
        create_sampler(ctx, VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE, "vkCreateSampler");
    if (!lightmap_sampler) return lightmap_sampler.error();
    out.lightmap_sampler = std::move(*lightmap_sampler);

    const VkDescriptorPoolSize sizes[] = {{VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 2 * count},
                                          {VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, count}};
    VkDescriptorPoolCreateInfo pool_info{};
    pool_info.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO;
    pool_info.maxSets = count;
    pool_info.poolSizeCount = 2;
    pool_info.pPoolSizes = sizes;
    VkDescriptorPool pool = VK_NULL_HANDLE;
    HMDNODE_VK_TRY(vkCreateDescriptorPool(ctx.device, &pool_info, nullptr, &pool),
                   "vkCreateDescriptorPool (materials)");
    out.descriptor_pool = DescriptorPool(ctx.device, pool);

    std::vector<VkDescriptorSetLayout> layouts(count, layout);
    out.material_sets.resize(count);
    VkDescriptorSetAllocateInfo alloc{};
    alloc.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO;
    alloc.descriptorPool = pool;
    alloc.descriptorSetCount = count;
    alloc.pSetLayouts = layouts.data();
    HMDNODE_VK_TRY(vkAllocateDescriptorSets(ctx.device, &alloc, out.material_sets.data()),
                   "vkAllocateDescriptorSets (materials)");

    for (uint32_t i = 0; i < count; ++i) {
        const Material fallback;
        const Material& m = i < scene.materials.size() ? scene.materials[i] : fallback;
        // Every texture a material samples was uploaded (texture_uses marked it).
        assert(m.base_color_texture < 0 ||
               out.textures[size_t(m.base_color_texture)].srgb_view.get() != VK_NULL_HANDLE);
        assert(m.lightmap.texture < 0 ||
               out.textures[size_t(m.lightmap.texture)].unorm_view.get() != VK_NULL_HANDLE);
        const VkImageView base = m.base_color_texture >= 0
                                     ? out.textures[m.base_color_texture].srgb_view.get()
                                     : out.white.unorm_view.get();
        const VkImageView lightmap = m.lightmap.texture >= 0
                                         ? out.textures[m.lightmap.texture].unorm_view.get()
                                         : out.white.unorm_view.get();
        const VkDescriptorImageInfo images[2] = {
            {out.base_color_sampler, base, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL},
            {out.lightmap_sampler, lightmap, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL}};
        const VkDescriptorBufferInfo constants_info{
            out.material_constants.get(), i * out.material_stride, sizeof(MaterialConstants)};
        VkWriteDescriptorSet writes[2]{};
        writes[0].sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
        writes[0].dstSet = out.material_sets[i];
        writes[0].dstBinding = 0;
        writes[0].descriptorCount = 2;  // bindings 0 and 1, consecutive
        writes[0].descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
        writes[0].pImageInfo = images;
        writes[1].sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
        writes[1].dstSet = out.material_sets[i];
        writes[1].dstBinding = 2;
        writes[1].descriptorCount = 1;
        writes[1].descriptorType = VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
        writes[1].pBufferInfo = &constants_info;
        vkUpdateDescriptorSets(ctx.device, 2, writes, 0, nullptr);
    }
    return Status::success();
}

}  // namespace

Result<std::unique_ptr<GpuScene>> upload_scene(DeviceContext& ctx, const Scene& scene,
                                               VkDescriptorSetLayout material_layout) {
    if (Status s = gpu::validate_scene(scene, ctx.properties.limits.maxImageDimension2D); !s)
        return s.error();
    auto out = std::make_unique<GpuScene>();
    if (Status s = upload_geometry(ctx, scene, *out); !s) return s.error();
    if (Status s = upload_textures(ctx, scene, *out); !s) return s.error();
    if (Status s = create_materials(ctx, scene, material_layout, *out); !s) return s.error();
    return out;
}

}  // namespace hmdnode::vk
