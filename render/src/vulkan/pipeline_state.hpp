// The fixed-function state the Vulkan backend's graphics pipelines share (the scene pipeline,
// scene_pipeline.cpp; the warp and lens passes, warp_pass.cpp), written once: triangle lists, one
// viewport and one scissor, both dynamic, filled polygons with counter-clockwise front faces
// (eye_projection() flips y for Vulkan's y-down clip space, so a triangle counter-clockwise in
// the eye's view stays so in framebuffer coordinates), no culling, one sample, no depth test, one
// colour attachment written on all four channels without blending.
//
// A pipeline sets what differs on the members (vertex input, culling, samples, depth) before
// create_info(); the create info points into this object, so it lives while the pipelines are
// created (not copyable for that reason).
#pragma once

#include <vulkan/vulkan.h>

#include <cstdint>

namespace hmdnode::vk {

struct GraphicsPipelineState {
    GraphicsPipelineState();
    GraphicsPipelineState(const GraphicsPipelineState&) = delete;
    GraphicsPipelineState& operator=(const GraphicsPipelineState&) = delete;

    // The create info for `stages` (vertex and fragment) over this state; pDepthStencilState only
    // when `depth_test` is set.
    VkGraphicsPipelineCreateInfo create_info(const VkPipelineShaderStageCreateInfo stages[2],
                                             VkPipelineLayout layout,
                                             VkRenderPass render_pass) const;

    VkPipelineVertexInputStateCreateInfo vertex_input{};
    VkPipelineInputAssemblyStateCreateInfo assembly{};
    VkPipelineViewportStateCreateInfo viewport{};
    VkPipelineRasterizationStateCreateInfo raster{};
    VkPipelineMultisampleStateCreateInfo multisample{};
    bool depth_test = false;  // with `depth` (depth test and write, less)
    VkPipelineDepthStencilStateCreateInfo depth{};
    VkPipelineColorBlendAttachmentState blend_attachment{};
    VkPipelineColorBlendStateCreateInfo blend{};
    VkDynamicState dynamic_states[2] = {VK_DYNAMIC_STATE_VIEWPORT, VK_DYNAMIC_STATE_SCISSOR};
    VkPipelineDynamicStateCreateInfo dynamic{};
};

}  // namespace hmdnode::vk
