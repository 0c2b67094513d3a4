// Scene upload: validation, vertex interleaving, texture staging and material descriptor sets.
// Cost: O(vertices + indices + texels) CPU work and one staging copy of the textures, at upload
// time only; temporary memory: the interleaved vertices and the staged texels.
#include "gpu_scene.hpp"

#include <algorithm>
#include <cstring>
#include <numbers>
#include <string>

#include "scene_pipeline.hpp"
#include "vk_check.hpp"

namespace hmdnode::vk {
namespace {

std::string where(size_t mesh, size_t prim) {
    return "mesh " + std::to_string(mesh) + " primitive " + std::to_string(prim);
}

Status validate(const Scene& scene, uint32_t max_dim) {
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

Result<Sampler> create_sampler(const DeviceContext& ctx, VkSamplerAddressMode address) {
    VkSamplerCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO;
    info.magFilter = VK_FILTER_LINEAR;
    info.minFilter = VK_FILTER_LINEAR;
    info.mipmapMode = VK_SAMPLER_MIPMAP_MODE_NEAREST;
    info.addressModeU = address;
    info.addressModeV = address;
    info.addressModeW = address;
    info.maxLod = 0.0f;
    VkSampler sampler = VK_NULL_HANDLE;
    HMDNODE_VK_TRY(vkCreateSampler(ctx.device, &info, nullptr, &sampler), "vkCreateSampler");
    return Sampler(ctx.device, sampler);
}

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
    std::vector<uint8_t> srgb(n, 0), unorm(n, 0);
    for (const Material& m : scene.materials) {
        if (m.base_color_texture >= 0) srgb[m.base_color_texture] = 1;
        if (m.lightmap.texture >= 0) unorm[m.lightmap.texture] = 1;
    }

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
        std::memcpy(dst + copies[c++].offset, scene.textures[t].rgba8.data(),
                    scene.textures[t].rgba8.size());
    }
    if (Status s = staging->flush(); !s) return s;
    return ctx.submit_and_wait(
        [&](VkCommandBuffer cmd) { record_texture_copies(cmd, staging->get(), copies); });
}

Status upload_geometry(DeviceContext& ctx, const Scene& scene, GpuScene& out) {
    size_t vertex_count = 0, index_count = 0;
    for (const Mesh& mesh : scene.meshes)
        for (const Primitive& p : mesh.primitives)
            if (!p.indices.empty()) {
                vertex_count += p.positions.size();
                index_count += p.indices.size();
            }
    if (vertex_count > size_t(INT32_MAX) || index_count > size_t(UINT32_MAX))
        return make_error("scene: too many vertices or indices for 32-bit offsets");

    std::vector<Vertex> vertices;
    std::vector<uint32_t> indices;
    vertices.reserve(vertex_count);
    indices.reserve(index_count);
    const uint32_t default_material = uint32_t(scene.materials.size());
    for (const Mesh& mesh : scene.meshes) {
        GpuMesh gm;
        gm.first_primitive = uint32_t(out.primitives.size());
        for (const Primitive& p : mesh.primitives) {
            if (p.indices.empty()) continue;
            GpuPrimitive gp;
            gp.first_index = uint32_t(indices.size());
            gp.index_count = uint32_t(p.indices.size());
            gp.vertex_offset = int32_t(vertices.size());
            gp.material = p.material >= 0 ? uint32_t(p.material) : default_material;
            gp.double_sided = p.material >= 0 && scene.materials[p.material].double_sided;
            for (size_t v = 0; v < p.positions.size(); ++v) {
                Vertex& out_v = vertices.emplace_back();
                out_v.position = p.positions[v];
                out_v.normal = p.normals.empty() ? glm::vec3(0, 0, 1) : p.normals[v];
                out_v.uv0 = p.uv0.empty() ? glm::vec2(0) : p.uv0[v];
                out_v.uv1 = p.uv1.empty() ? glm::vec2(0) : p.uv1[v];
                out_v.color = p.colors.empty() ? glm::vec4(1) : p.colors[v];
                out_v.light =
                    p.light.empty() ? glm::vec3(1) : p.light[v] / std::numbers::pi_v<float>;
            }
            indices.insert(indices.end(), p.indices.begin(), p.indices.end());
            gm.triangles += p.triangle_count();
            out.primitives.push_back(gp);
        }
        gm.primitive_count = uint32_t(out.primitives.size()) - gm.first_primitive;
        out.meshes.push_back(gm);
    }
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
        MaterialConstants c;
        c.base_color_factor = m.base_color_factor;
        c.lightmap = glm::vec4(m.lightmap.intensity, m.lightmap.tex_coord == 1 ? 1.0f : 0.0f,
                               m.lightmap.texture >= 0 ? 1.0f : 0.0f,
                               m.lightmap.encoding == LightmapEncoding::Rgbm ? 1.0f : 0.0f);
        c.emissive = glm::vec4(m.emissive_factor, 0.0f);
        std::memcpy(constants.data() + i * out.material_stride, &c, sizeof(c));
    }
    auto buffer = create_buffer_with_data(ctx, constants, VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT,
                                          "material constants");
    if (!buffer) return buffer.error();
    out.material_constants = std::move(*buffer);

    // 2. Samplers and descriptor sets.
    auto base_sampler = create_sampler(ctx, VK_SAMPLER_ADDRESS_MODE_REPEAT);
    if (!base_sampler) return base_sampler.error();
    out.base_color_sampler = std::move(*base_sampler);
    auto lightmap_sampler = create_sampler(ctx, VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE);
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
    if (Status s = validate(scene, ctx.properties.limits.maxImageDimension2D); !s) return s.error();
    auto out = std::make_unique<GpuScene>();
    if (Status s = upload_geometry(ctx, scene, *out); !s) return s.error();
    if (Status s = upload_textures(ctx, scene, *out); !s) return s.error();
    if (Status s = create_materials(ctx, scene, material_layout, *out); !s) return s.error();
    return out;
}

}  // namespace hmdnode::vk
