// The pieces of an offscreen render target that the stereo targets (stereo_targets.cpp) and the
// warp pass's panel (warp_pass.cpp) both create, written once: a stored attachment, a render pass
// of one subpass whose colour a read-back copy reads next, a one-layer framebuffer, and the
// host-visible buffer the two layers of an RGBA8 image are copied into (record_copy_to_host).
// Each call creates one Vulkan object with what its caller passes; nothing here runs per frame.
#pragma once

#include <span>

#include "vk_memory.hpp"

namespace hmdnode::vk {

// An attachment the pass stores at its end, without stencil (stencil load and store DONT_CARE).
VkAttachmentDescription stored_attachment(VkFormat format, VkSampleCountFlagBits samples,
                                          VkAttachmentLoadOp load_op, VkImageLayout initial_layout,
                                          VkImageLayout final_layout);

struct RenderPassDesc {
    // [0] colour (used as COLOR_ATTACHMENT_OPTIMAL), [1] depth when there are two
    // (DEPTH_STENCIL_ATTACHMENT_OPTIMAL).
    std::span<const VkAttachmentDescription> attachments;
    // What must finish before the subpass: its stage and access masks (the subpasses are set
    // here: from VK_SUBPASS_EXTERNAL into subpass 0).
    VkSubpassDependency before{};
    const void* next = nullptr;               // pNext of the create info (the multiview info)
    const char* what = "vkCreateRenderPass";  // the call, as errors name it
};

// One graphics subpass over desc.attachments, with two dependencies: desc.before, then the
// subpass's colour writes before the transfer (the read-back copy) that reads them.
Result<RenderPass> create_render_pass(const DeviceContext& ctx, const RenderPassDesc& desc);

// A framebuffer of one layer for `render_pass`; `what` names the call in errors.
Result<Framebuffer> create_framebuffer(const DeviceContext& ctx, VkRenderPass render_pass,
                                       std::span<const VkImageView> attachments, uint32_t width,
                                       uint32_t height, const char* what);

// The read-back buffer of a 2-layer width x height RGBA8 image: width * height * 4 bytes per
// layer, host-visible (MemoryUse::Readback), a transfer destination.
Result<Buffer> create_readback(const DeviceContext& ctx, uint32_t width, uint32_t height,
                               const char* what);

}  // namespace hmdnode::vk
