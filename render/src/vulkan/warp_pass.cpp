// The late-warp + lens-distortion pass (see warp_pass.hpp). Creation allocates the panel image,
// the meshes and the pipeline; record_warp() allocates nothing.
#include "warp_pass.hpp"

#include <cstddef>
#include <cstring>
#include <span>
#include <string>

#include "latency_overlay.hpp"
#include "pipeline_state.hpp"
#include "render_target.hpp"
#include "scene_geometry.hpp"
#include "vk_check.hpp"
#include "vk_shader.hpp"

namespace hmdnode::vk {
namespace {

const uint32_t kWarpVert[] =
#include "warp.vert.spv.h"
    ;
const uint32_t kWarpFrag[] =
#include "warp.frag.spv.h"
    ;
const uint32_t kWarpMonoFrag[] =
#include "warp_mono.frag.spv.h"
    ;
const uint32_t kLensWarpVert[] =
#include "lens_warp.vert.spv.h"
    ;
const uint32_t kLensWarpFrag[] =
#include "lens_warp.frag.spv.h"
    ;

// note: the pass reads the sRGB eye buffers through UNORM views and writes a UNORM panel, so it
// filters the encoded values and neither decodes nor encodes sRGB: on llvmpipe the per-texel sRGB
// decode of 12 texels and the encode of each pixel outweighed the rest of the pass (docs/DESIGN.md
// §9 has the figure). The bytes are the same sRGB-encoded pixels; only the bilinear weights act
// on encoded values.
constexpr VkFormat kPanelFormat = VK_FORMAT_R8G8B8A8_UNORM;
constexpr VkFormat kEyeSampleFormat = VK_FORMAT_R8G8B8A8_UNORM;

Result<RenderPass> create_panel_render_pass(const DeviceContext& ctx) {
    // Loaded DONT_CARE: the mesh covers the whole panel.
    const VkAttachmentDescription color =
        stored_attachment(kPanelFormat, VK_SAMPLE_COUNT_1_BIT, VK_ATTACHMENT_LOAD_OP_DONT_CARE,
                          VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL);
    RenderPassDesc desc;
    desc.attachments = {&color, 1};
    // note: the previous warp's read-back copy must finish before this pass writes the panel.
    desc.before.srcStageMask = VK_PIPELINE_STAGE_TRANSFER_BIT;
    desc.before.dstStageMask = VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT;
    desc.before.srcAccessMask = 0;
    desc.before.dstAccessMask = VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT;
    desc.what = "vkCreateRenderPass (warp)";
    return create_render_pass(ctx, desc);
}

// The shaders of one warp pipeline: the mesh pass (vertex input from the distortion mesh) or the
// fused pass (no vertex input; the fragment stage specialised on the lens model and MONO).
struct WarpShaders {
    std::span<const uint32_t> vert, frag;
    bool mesh_input = true;
    const VkSpecializationInfo* frag_specialization = nullptr;
};

Result<Pipeline> create_warp_pipeline(const DeviceContext& ctx, VkPipelineLayout layout,
                                      VkRenderPass render_pass, const WarpShaders& shaders) {
    auto vert = create_module(ctx, shaders.vert.data(), shaders.vert.size_bytes(),
                              "vkCreateShaderModule (warp)");
    if (!vert) return vert.error();
    auto frag = create_module(ctx, shaders.frag.data(), shaders.frag.size_bytes(),
                              "vkCreateShaderModule (warp)");
    if (!frag) return frag.error();
    VkPipelineShaderStageCreateInfo stages[2]{};
    for (int i = 0; i < 2; ++i) {
        stages[i].sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
        stages[i].stage = i == 0 ? VK_SHADER_STAGE_VERTEX_BIT : VK_SHADER_STAGE_FRAGMENT_BIT;
        stages[i].module = i == 0 ? vert->get() : frag->get();
        stages[i].pName = "main";
    }
    stages[1].pSpecializationInfo = shaders.frag_specialization;
    const VkVertexInputBindingDescription binding{0, sizeof(DistortionVertex),
                                                  VK_VERTEX_INPUT_RATE_VERTEX};
    VkVertexInputAttributeDescription attributes[4];
    attributes[0] = {0, 0, VK_FORMAT_R32G32_SFLOAT, uint32_t(offsetof(DistortionVertex, ndc))};
    for (uint32_t c = 0; c < 3; ++c)
        attributes[c + 1] = {c + 1, 0, VK_FORMAT_R32G32_SFLOAT,
                             uint32_t(offsetof(DistortionVertex, tangent) + c * sizeof(glm::vec2))};
    GraphicsPipelineState state;  // pipeline_state.hpp: the rest of the fixed function
    if (shaders.mesh_input) {
        state.vertex_input.vertexBindingDescriptionCount = 1;
        state.vertex_input.pVertexBindingDescriptions = &binding;
        state.vertex_input.vertexAttributeDescriptionCount = 4;
        state.vertex_input.pVertexAttributeDescriptions = attributes;
    }
    const VkGraphicsPipelineCreateInfo info = state.create_info(stages, layout, render_pass);
    VkPipeline pipeline = VK_NULL_HANDLE;
    HMDNODE_VK_TRY(
        vkCreateGraphicsPipelines(ctx.device, VK_NULL_HANDLE, 1, &info, nullptr, &pipeline),
        "vkCreateGraphicsPipelines (warp)");
    return Pipeline(ctx.device, pipeline);
}

// Everything both passes share: the panel image (one layer per eye), its pass and framebuffers,
// the read-back buffer, the eye buffers' sampled views behind a bilinear sampler, the descriptor
// sets [slot][eye] (binding 0 the eye buffer; binding 1 the eye's lens uniforms when `lens_ubo`)
// and the pipeline layout.
Status create_common(DeviceContext& ctx, const Image eyes[2], uint32_t width, uint32_t height,
                     const Buffer* lens_ubo, WarpPass& w) {
    const VkPhysicalDeviceLimits& limits = ctx.properties.limits;
    if (width < 1 || height < 1 || width > limits.maxFramebufferWidth ||
        height > limits.maxFramebufferHeight)
        return make_error("Vulkan: panel " + std::to_string(width) + "x" + std::to_string(height) +
                          " is empty or exceeds the device's framebuffer limit");
    w.width = width;
    w.height = height;

    // 1. The panel image (one layer per eye), its pass and framebuffers, the read-back buffer.
    auto panel =
        create_image(ctx,
                     {width, height, 2, kPanelFormat,
                      VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT, 0},
                     "panel image");
    if (!panel) return panel.error();
    w.panel = std::move(*panel);
    auto pass = create_panel_render_pass(ctx);
    if (!pass) return pass.error();
    w.render_pass = std::move(*pass);
    for (uint32_t e = 0; e < 2; ++e) {
        auto view =
            create_view(ctx, w.panel, kPanelFormat, VK_IMAGE_ASPECT_COLOR_BIT, "panel", e, 1);
        if (!view) return view.error();
        w.panel_view[e] = std::move(*view);
        const VkImageView attachment = w.panel_view[e];
        auto framebuffer = create_framebuffer(ctx, w.render_pass, {&attachment, 1}, width, height,
                                              "vkCreateFramebuffer (panel)");
        if (!framebuffer) return framebuffer.error();
        w.framebuffer[e] = std::move(*framebuffer);
    }
    auto readback = create_readback(ctx, width, height, "panel read-back");
    if (!readback) return readback.error();
    w.readback = std::move(*readback);

    // 2. The eye buffers as a sampled array, behind a bilinear sampler that is black outside.
    // note: clamp to edge, with the outside blacked out by the shader: llvmpipe's fast 8-bit
    // filtering path does not take a border colour.
    auto sampler =
        create_sampler(ctx, VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE, "vkCreateSampler (warp)");
    if (!sampler) return sampler.error();
    w.sampler = std::move(*sampler);
    for (int slot = 0; slot < 2; ++slot)
        for (uint32_t e = 0; e < 2; ++e) {
            auto eyes_view = create_view(ctx, eyes[slot], kEyeSampleFormat,
                                         VK_IMAGE_ASPECT_COLOR_BIT, "eye buffer (sampled)", e, 1);
            if (!eyes_view) return eyes_view.error();
            w.eyes_view[slot][e] = std::move(*eyes_view);
        }

    const VkDescriptorSetLayoutBinding bindings[2] = {
        {0, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, VK_SHADER_STAGE_FRAGMENT_BIT, nullptr},
        {1, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1, VK_SHADER_STAGE_FRAGMENT_BIT, nullptr}};
    auto set_layout = create_set_layout(ctx, {bindings, size_t(lens_ubo ? 2 : 1)});
    if (!set_layout) return set_layout.error();
    w.set_layout = std::move(*set_layout);
    const VkDescriptorPoolSize sizes[2] = {{VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 4},
                                           {VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 4}};
    VkDescriptorPoolCreateInfo pool_info{};
    pool_info.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO;
    pool_info.maxSets = 4;
    pool_info.poolSizeCount = lens_ubo ? 2 : 1;
    pool_info.pPoolSizes = sizes;
    VkDescriptorPool pool = VK_NULL_HANDLE;
    HMDNODE_VK_TRY(vkCreateDescriptorPool(ctx.device, &pool_info, nullptr, &pool),
                   "vkCreateDescriptorPool (warp)");
    w.pool = DescriptorPool(ctx.device, pool);
    const VkDescriptorSetLayout set_layout_handle = w.set_layout;
    const VkDescriptorSetLayout set_layouts[4] = {w.set_layout, w.set_layout, w.set_layout,
                                                  w.set_layout};
    VkDescriptorSetAllocateInfo set_info{};
    set_info.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO;
    set_info.descriptorPool = pool;
    set_info.descriptorSetCount = 4;
    set_info.pSetLayouts = set_layouts;
    HMDNODE_VK_TRY(vkAllocateDescriptorSets(ctx.device, &set_info, &w.set[0][0]),
                   "vkAllocateDescriptorSets (warp)");
    for (int i = 0; i < 4; ++i) {
        const int slot = i / 2, e = i % 2;
        const VkDescriptorImageInfo image_info{w.sampler, w.eyes_view[slot][e],
                                               VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
        VkWriteDescriptorSet writes[2]{};
        writes[0].sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
        writes[0].dstSet = w.set[slot][e];
        writes[0].dstBinding = 0;
        writes[0].descriptorCount = 1;
        writes[0].descriptorType = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
        writes[0].pImageInfo = &image_info;
        VkDescriptorBufferInfo buffer_info{};
        if (lens_ubo) {
            buffer_info = {lens_ubo[e].get(), 0, sizeof(gpu::LensUniforms)};
            writes[1].sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
            writes[1].dstSet = w.set[slot][e];
            writes[1].dstBinding = 1;
            writes[1].descriptorCount = 1;
            writes[1].descriptorType = VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
            writes[1].pBufferInfo = &buffer_info;
        }
        vkUpdateDescriptorSets(ctx.device, lens_ubo ? 2 : 1, writes, 0, nullptr);
    }

    // 3. The pipeline layout.
    const VkPushConstantRange push{VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, 0,
                                   sizeof(WarpConstants)};
    VkPipelineLayoutCreateInfo layout_info{};
    layout_info.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO;
    layout_info.setLayoutCount = 1;
    layout_info.pSetLayouts = &set_layout_handle;
    layout_info.pushConstantRangeCount = 1;
    layout_info.pPushConstantRanges = &push;
    VkPipelineLayout layout = VK_NULL_HANDLE;
    HMDNODE_VK_TRY(vkCreatePipelineLayout(ctx.device, &layout_info, nullptr, &layout),
                   "vkCreatePipelineLayout (warp)");
    w.layout = PipelineLayout(ctx.device, layout);
    return Status::success();
}

}  // namespace

Result<WarpPass> create_warp_pass(DeviceContext& ctx, const Image eyes[2], uint32_t width,
                                  uint32_t height, const DistortionMesh mesh[2]) {
    WarpPass w;
    for (int e = 0; e < 2; ++e)
        if (Status s = gpu::check_distortion_mesh(mesh[e], e); !s) return s.error();
    if (Status s = create_common(ctx, eyes, width, height, nullptr, w); !s) return s.error();
    w.mono = gpu::channels_agree(mesh[0]) && gpu::channels_agree(mesh[1]);
    WarpShaders shaders;
    shaders.vert = kWarpVert;
    shaders.frag =
        w.mono ? std::span<const uint32_t>(kWarpMonoFrag) : std::span<const uint32_t>(kWarpFrag);
    auto pipeline = create_warp_pipeline(ctx, w.layout, w.render_pass, shaders);
    if (!pipeline) return pipeline.error();
    w.pipeline = std::move(*pipeline);
    w.chromatic = !w.mono;
    if (!w.mono) {  // chromatic-aberration correction off: the green channel's tangents alone
        shaders.frag = kWarpMonoFrag;
        auto mono = create_warp_pipeline(ctx, w.layout, w.render_pass, shaders);
        if (!mono) return mono.error();
        w.mono_pipeline = std::move(*mono);
    }

    // The meshes.
    for (int e = 0; e < 2; ++e) {
        const DistortionMesh& m = mesh[e];
        auto vb = create_buffer_with_data(ctx, std::as_bytes(std::span(m.vertices)),
                                          VK_BUFFER_USAGE_VERTEX_BUFFER_BIT, "distortion mesh");
        if (!vb) return vb.error();
        w.vertices[e] = std::move(*vb);
        auto ib = create_buffer_with_data(ctx, std::as_bytes(std::span(m.indices)),
                                          VK_BUFFER_USAGE_INDEX_BUFFER_BIT, "distortion mesh");
        if (!ib) return ib.error();
        w.indices[e] = std::move(*ib);
        w.index_count[e] = uint32_t(m.indices.size());
    }
    return w;
}

Result<WarpPass> create_lens_warp_pass(DeviceContext& ctx, const Image eyes[2], uint32_t width,
                                       uint32_t height, const gpu::LensPassSetup& lens) {
    WarpPass w;
    w.fused = true;
    w.chromatic = lens.chromatic;
    w.mono = !lens.chromatic;
    for (int e = 0; e < 2; ++e) {
        auto ubo = create_buffer_with_data(ctx, std::as_bytes(std::span(&lens.eye[e].uniforms, 1)),
                                           VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT, "lens uniforms");
        if (!ubo) return ubo.error();
        w.lens_uniforms[e] = std::move(*ubo);
        w.lens[e] = lens.eye[e];
    }
    if (Status s = create_common(ctx, eyes, width, height, w.lens_uniforms, w); !s)
        return s.error();
    // One pipeline per eye and variant, the lens model and MONO as specialisation constants, so
    // the compiler drops the other models' code and the per-channel loop of MONO.
    struct Spec {
        int32_t model;
        VkBool32 mono, shared, clamp;
    };
    const VkSpecializationMapEntry entries[4] = {{0, offsetof(Spec, model), sizeof(int32_t)},
                                                 {1, offsetof(Spec, mono), sizeof(VkBool32)},
                                                 {2, offsetof(Spec, shared), sizeof(VkBool32)},
                                                 {3, offsetof(Spec, clamp), sizeof(VkBool32)}};
    for (int e = 0; e < 2; ++e)
        for (int mono = 0; mono < 2; ++mono) {
            if (!mono && !lens.chromatic) continue;
            const Spec spec{int32_t(lens.eye[e].model), VkBool32(mono),
                            VkBool32(lens.eye[e].shared), VkBool32(lens.eye[e].clamped)};
            const VkSpecializationInfo info{4, entries, sizeof(spec), &spec};
            WarpShaders shaders;
            shaders.vert = kLensWarpVert;
            shaders.frag = kLensWarpFrag;
            shaders.mesh_input = false;
            shaders.frag_specialization = &info;
            auto pipeline = create_warp_pipeline(ctx, w.layout, w.render_pass, shaders);
            if (!pipeline) return pipeline.error();
            w.fused_pipeline[e][mono] = std::move(*pipeline);
        }
    return w;
}

void record_warp(VkCommandBuffer cmd, const WarpPass& w, int slot, const glm::mat4 reproject[2],
                 bool read_back, const glm::vec4& sample_rect, bool chromatic,
                 const LatencyMarkerOverlay* marker) {
    const VkViewport viewport{0.0f, 0.0f, float(w.width), float(w.height), 0.0f, 1.0f};
    const VkRect2D area{{0, 0}, {w.width, w.height}};
    // The marker's rects, black ones then white ones (each colour one clear; clears are ordered
    // like draws within the pass).
    VkClearRect clear_rects[2][kLatencyMarkerMaxRects];
    uint32_t clear_count[2] = {0, 0};
    if (marker) {
        LatencyMarkerRect rects[kLatencyMarkerMaxRects];
        const size_t n = gpu::latency_overlay_rects(*marker, int(w.width), int(w.height), rects);
        for (size_t i = 0; i < n; ++i) {
            const LatencyMarkerRect& r = rects[i];
            clear_rects[r.white ? 1 : 0][clear_count[r.white ? 1 : 0]++] = {
                {{r.x, r.y}, {uint32_t(r.width), uint32_t(r.height)}}, 0, 1};
        }
    }
    for (int e = 0; e < 2; ++e) {
        VkRenderPassBeginInfo begin{};
        begin.sType = VK_STRUCTURE_TYPE_RENDER_PASS_BEGIN_INFO;
        begin.renderPass = w.render_pass;
        begin.framebuffer = w.framebuffer[e];
        begin.renderArea = area;
        vkCmdBeginRenderPass(cmd, &begin, VK_SUBPASS_CONTENTS_INLINE);
        const VkPipeline pipeline =
            w.fused               ? w.fused_pipeline[e][w.chromatic && chromatic ? 0 : 1].get()
            : w.mono || chromatic ? w.pipeline.get()
                                  : w.mono_pipeline.get();
        vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline);
        vkCmdSetViewport(cmd, 0, 1, &viewport);
        vkCmdSetScissor(cmd, 0, 1, &area);
        vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, w.layout, 0, 1,
                                &w.set[slot][e], 0, nullptr);
        WarpConstants constants{};
        constants.reproject =
            w.fused ? gpu::lens_pass_reprojection(reproject[e], w.lens[e]) : reproject[e];
        constants.layer = float(e);
        constants.sample_rect = sample_rect;
        vkCmdPushConstants(cmd, w.layout, VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT,
                           0, sizeof(constants), &constants);
        if (w.fused) {
            vkCmdDraw(cmd, 3, 1, 0, 0);
        } else {
            const VkBuffer vb = w.vertices[e].get();
            const VkDeviceSize zero = 0;
            vkCmdBindVertexBuffers(cmd, 0, 1, &vb, &zero);
            vkCmdBindIndexBuffer(cmd, w.indices[e].get(), 0, VK_INDEX_TYPE_UINT32);
            vkCmdDrawIndexed(cmd, w.index_count[e], 1, 0, 0, 0);
        }
        for (int white = 0; white < 2; ++white) {
            if (clear_count[white] == 0) continue;
            VkClearAttachment clear{};
            clear.aspectMask = VK_IMAGE_ASPECT_COLOR_BIT;
            clear.colorAttachment = 0;
            const float v = white ? 1.0f : 0.0f;
            clear.clearValue.color = {{v, v, v, 1.0f}};
            vkCmdClearAttachments(cmd, 1, &clear, clear_count[white], clear_rects[white]);
        }
        vkCmdEndRenderPass(cmd);
    }
    if (read_back) record_copy_to_host(cmd, w.panel.get(), w.width, w.height, 2, w.readback);
}

}  // namespace hmdnode::vk
