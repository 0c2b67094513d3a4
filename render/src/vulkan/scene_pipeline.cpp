// Scene pipelines: shader modules from the embedded SPIR-V, layouts and the two cull modes.
// Cost: pipeline compilation at creation (docs/DESIGN.md §9 has its figure on lavapipe); nothing
// per frame.
#include "scene_pipeline.hpp"

#include <cstddef>

#include "pipeline_state.hpp"
#include "vk_check.hpp"
#include "vk_shader.hpp"

namespace hmdnode::vk {
namespace {

const uint32_t kSceneVert[] =
#include "scene.vert.spv.h"
    ;
const uint32_t kSceneFrag[] =
#include "scene.frag.spv.h"
    ;

}  // namespace

Result<ScenePipeline> create_scene_pipeline(const DeviceContext& ctx, VkRenderPass render_pass,
                                            VkSampleCountFlagBits samples) {
    ScenePipeline p;

    // 1. Layouts.
    const VkDescriptorSetLayoutBinding frame_bindings[] = {
        {0, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1, VK_SHADER_STAGE_VERTEX_BIT, nullptr}};
    auto frame_layout = create_set_layout(ctx, frame_bindings);
    if (!frame_layout) return frame_layout.error();
    p.frame_layout = std::move(*frame_layout);
    const VkDescriptorSetLayoutBinding material_bindings[] = {
        {0, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, VK_SHADER_STAGE_FRAGMENT_BIT, nullptr},
        {1, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, VK_SHADER_STAGE_FRAGMENT_BIT, nullptr},
        {2, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1, VK_SHADER_STAGE_FRAGMENT_BIT, nullptr}};
    auto material_layout = create_set_layout(ctx, material_bindings);
    if (!material_layout) return material_layout.error();
    p.material_layout = std::move(*material_layout);

    const VkDescriptorSetLayout sets[2] = {p.frame_layout, p.material_layout};
    const VkPushConstantRange push[2] = {
        {VK_SHADER_STAGE_VERTEX_BIT, 0, kVertexPushBytes},
        {VK_SHADER_STAGE_FRAGMENT_BIT, offsetof(DrawConstants, dither), sizeof(int32_t)}};
    VkPipelineLayoutCreateInfo layout_info{};
    layout_info.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO;
    layout_info.setLayoutCount = 2;
    layout_info.pSetLayouts = sets;
    layout_info.pushConstantRangeCount = 2;
    layout_info.pPushConstantRanges = push;
    VkPipelineLayout layout = VK_NULL_HANDLE;
    HMDNODE_VK_TRY(vkCreatePipelineLayout(ctx.device, &layout_info, nullptr, &layout),
                   "vkCreatePipelineLayout");
    p.layout = PipelineLayout(ctx.device, layout);

    // 2. Shaders.
    auto vert = create_module(ctx, kSceneVert, sizeof(kSceneVert), "vkCreateShaderModule (vert)");
    if (!vert) return vert.error();
    auto frag = create_module(ctx, kSceneFrag, sizeof(kSceneFrag), "vkCreateShaderModule (frag)");
    if (!frag) return frag.error();
    VkPipelineShaderStageCreateInfo stages[2]{};
    stages[0].sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
    stages[0].stage = VK_SHADER_STAGE_VERTEX_BIT;
    stages[0].module = *vert;
    stages[0].pName = "main";
    stages[1].sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
    stages[1].stage = VK_SHADER_STAGE_FRAGMENT_BIT;
    stages[1].module = *frag;
    stages[1].pName = "main";

    // 3. Fixed function.
    const VkVertexInputBindingDescription binding{0, sizeof(Vertex), VK_VERTEX_INPUT_RATE_VERTEX};
    const VkVertexInputAttributeDescription attributes[] = {
        {0, 0, VK_FORMAT_R32G32B32_SFLOAT, uint32_t(offsetof(Vertex, position))},
        {2, 0, VK_FORMAT_R32G32_SFLOAT, uint32_t(offsetof(Vertex, uv0))},
        {3, 0, VK_FORMAT_R32G32_SFLOAT, uint32_t(offsetof(Vertex, uv1))},
        {4, 0, VK_FORMAT_R32G32B32A32_SFLOAT, uint32_t(offsetof(Vertex, color))},
        {5, 0, VK_FORMAT_R32G32B32_SFLOAT, uint32_t(offsetof(Vertex, light))}};
    GraphicsPipelineState state;  // pipeline_state.hpp: the rest of the fixed function
    state.vertex_input.vertexBindingDescriptionCount = 1;
    state.vertex_input.pVertexBindingDescriptions = &binding;
    state.vertex_input.vertexAttributeDescriptionCount = uint32_t(std::size(attributes));
    state.vertex_input.pVertexAttributeDescriptions = attributes;
    state.multisample.rasterizationSamples = samples;
    state.depth_test = true;
    const VkGraphicsPipelineCreateInfo info = state.create_info(stages, p.layout, render_pass);

    // The fragment shader's kDithered (constant_id 0, a 32-bit bool).
    const VkSpecializationMapEntry dithered_entry{0, 0, sizeof(VkBool32)};
    VkBool32 dithered = VK_FALSE;
    VkSpecializationInfo specialization{1, &dithered_entry, sizeof(VkBool32), &dithered};
    stages[1].pSpecializationInfo = &specialization;

    VkPipeline pipeline = VK_NULL_HANDLE;
    for (VkBool32 d : {VK_FALSE, VK_TRUE}) {
        dithered = d;
        state.raster.cullMode = VK_CULL_MODE_BACK_BIT;
        HMDNODE_VK_TRY(
            vkCreateGraphicsPipelines(ctx.device, VK_NULL_HANDLE, 1, &info, nullptr, &pipeline),
            "vkCreateGraphicsPipelines (single-sided)");
        (d ? p.single_sided_dithered : p.single_sided) = Pipeline(ctx.device, pipeline);
        state.raster.cullMode = VK_CULL_MODE_NONE;
        HMDNODE_VK_TRY(
            vkCreateGraphicsPipelines(ctx.device, VK_NULL_HANDLE, 1, &info, nullptr, &pipeline),
            "vkCreateGraphicsPipelines (double-sided)");
        (d ? p.double_sided_dithered : p.double_sided) = Pipeline(ctx.device, pipeline);
    }
    return p;
}

}  // namespace hmdnode::vk
