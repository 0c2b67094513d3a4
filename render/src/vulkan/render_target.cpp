// The shared pieces of the Vulkan backend's offscreen render targets (render_target.hpp). Cost:
// one object created per call.
#include "render_target.hpp"

#include <cassert>

#include "vk_check.hpp"

namespace hmdnode::vk {

VkAttachmentDescription stored_attachment(VkFormat format, VkSampleCountFlagBits samples,
                                          VkAttachmentLoadOp load_op, VkImageLayout initial_layout,
                                          VkImageLayout final_layout) {
    VkAttachmentDescription a{};
    a.format = format;
    a.samples = samples;
    a.loadOp = load_op;
    a.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
    a.stencilLoadOp = VK_ATTACHMENT_LOAD_OP_DONT_CARE;
    a.stencilStoreOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;
    a.initialLayout = initial_layout;
    a.finalLayout = final_layout;
    return a;
}

Result<RenderPass> create_render_pass(const DeviceContext& ctx, const RenderPassDesc& desc) {
    assert(desc.attachments.size() == 1 || desc.attachments.size() == 2);
    const bool depth = desc.attachments.size() == 2;
    VkAttachmentReference color_ref{0, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL};
    VkAttachmentReference depth_ref{1, VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL};
    VkSubpassDescription subpass{};
    subpass.pipelineBindPoint = VK_PIPELINE_BIND_POINT_GRAPHICS;
    subpass.colorAttachmentCount = 1;
    subpass.pColorAttachments = &color_ref;
    subpass.pDepthStencilAttachment = depth ? &depth_ref : nullptr;

    VkSubpassDependency deps[2]{};
    deps[0] = desc.before;
    deps[0].srcSubpass = VK_SUBPASS_EXTERNAL;
    deps[0].dstSubpass = 0;
    // note: this pass's colour writes must finish before its own read-back copy reads them.
    deps[1].srcSubpass = 0;
    deps[1].dstSubpass = VK_SUBPASS_EXTERNAL;
    deps[1].srcStageMask = VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT;
    deps[1].dstStageMask = VK_PIPELINE_STAGE_TRANSFER_BIT;
    deps[1].srcAccessMask = VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT;
    deps[1].dstAccessMask = VK_ACCESS_TRANSFER_READ_BIT;

    VkRenderPassCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_RENDER_PASS_CREATE_INFO;
    info.pNext = desc.next;
    info.attachmentCount = uint32_t(desc.attachments.size());
    info.pAttachments = desc.attachments.data();
    info.subpassCount = 1;
    info.pSubpasses = &subpass;
    info.dependencyCount = 2;
    info.pDependencies = deps;
    VkRenderPass pass = VK_NULL_HANDLE;
    HMDNODE_VK_TRY(vkCreateRenderPass(ctx.device, &info, nullptr, &pass), desc.what);
    return RenderPass(ctx.device, pass);
}

Result<Framebuffer> create_framebuffer(const DeviceContext& ctx, VkRenderPass render_pass,
                                       std::span<const VkImageView> attachments, uint32_t width,
                                       uint32_t height, const char* what) {
    VkFramebufferCreateInfo fb{};
    fb.sType = VK_STRUCTURE_TYPE_FRAMEBUFFER_CREATE_INFO;
    fb.renderPass = render_pass;
    fb.attachmentCount = uint32_t(attachments.size());
    fb.pAttachments = attachments.data();
    fb.width = width;
    fb.height = height;
    fb.layers = 1;
    VkFramebuffer framebuffer = VK_NULL_HANDLE;
    HMDNODE_VK_TRY(vkCreateFramebuffer(ctx.device, &fb, nullptr, &framebuffer), what);
    return Framebuffer(ctx.device, framebuffer);
}

Result<Buffer> create_readback(const DeviceContext& ctx, uint32_t width, uint32_t height,
                               const char* what) {
    return create_buffer(ctx, VkDeviceSize(width) * height * 4 * 2,
                         VK_BUFFER_USAGE_TRANSFER_DST_BIT, MemoryUse::Readback, what);
}

}  // namespace hmdnode::vk
