// Offscreen multiview targets and render pass. Cost: two image allocations and one read-back
// buffer at creation; nothing per frame.
#include "stereo_targets.hpp"

#include <string>

#include "vk_check.hpp"

namespace hmdnode::vk {
namespace {

constexpr uint32_t kViewMask = 0b11;         // both eyes in one pass
constexpr uint32_t kCorrelationMask = 0b11;  // the eyes see nearly the same thing

bool supports(const DeviceContext& ctx, VkFormat format, VkFormatFeatureFlags features) {
    VkFormatProperties props;
    vkGetPhysicalDeviceFormatProperties(ctx.physical, format, &props);
    return (props.optimalTilingFeatures & features) == features;
}

// Attachments: 0 colour (with samples > 1 the multisampled image), 1 depth.
Result<RenderPass> create_render_pass(const DeviceContext& ctx, VkFormat depth_format,
                                      bool multiview, bool load, VkSampleCountFlagBits samples) {
    VkAttachmentDescription attachments[2]{};
    attachments[0].format = kColorFormat;
    attachments[0].samples = samples;
    attachments[0].loadOp = load ? VK_ATTACHMENT_LOAD_OP_LOAD : VK_ATTACHMENT_LOAD_OP_CLEAR;
    attachments[0].storeOp = VK_ATTACHMENT_STORE_OP_STORE;
    attachments[0].stencilLoadOp = VK_ATTACHMENT_LOAD_OP_DONT_CARE;
    attachments[0].stencilStoreOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;
    attachments[0].initialLayout =
        load ? VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL : VK_IMAGE_LAYOUT_UNDEFINED;
    attachments[0].finalLayout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
    attachments[1].format = depth_format;
    attachments[1].samples = samples;
    attachments[1].loadOp = load ? VK_ATTACHMENT_LOAD_OP_LOAD : VK_ATTACHMENT_LOAD_OP_CLEAR;
    attachments[1].storeOp = VK_ATTACHMENT_STORE_OP_STORE;  // a later piece of the frame loads it
    attachments[1].stencilLoadOp = VK_ATTACHMENT_LOAD_OP_DONT_CARE;
    attachments[1].stencilStoreOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;
    attachments[1].initialLayout =
        load ? VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL : VK_IMAGE_LAYOUT_UNDEFINED;
    attachments[1].finalLayout = VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL;

    VkAttachmentReference color_ref{0, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL};
    VkAttachmentReference depth_ref{1, VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL};
    VkSubpassDescription subpass{};
    subpass.pipelineBindPoint = VK_PIPELINE_BIND_POINT_GRAPHICS;
    subpass.colorAttachmentCount = 1;
    subpass.pColorAttachments = &color_ref;
    subpass.pDepthStencilAttachment = &depth_ref;

    // note: the previous frame's (or piece's) read-back copy, colour and depth writes and the warp
    // pass's reads must finish before this pass writes the attachments; this pass's colour writes
    // must finish before its own copy reads them.
    VkSubpassDependency deps[2]{};
    deps[0].srcSubpass = VK_SUBPASS_EXTERNAL;
    deps[0].dstSubpass = 0;
    deps[0].srcStageMask =
        VK_PIPELINE_STAGE_TRANSFER_BIT | VK_PIPELINE_STAGE_LATE_FRAGMENT_TESTS_BIT |
        VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT | VK_PIPELINE_STAGE_FRAGMENT_SHADER_BIT;
    deps[0].dstStageMask =
        VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT | VK_PIPELINE_STAGE_EARLY_FRAGMENT_TESTS_BIT;
    deps[0].srcAccessMask =
        VK_ACCESS_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT | VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT;
    deps[0].dstAccessMask =
        VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT | VK_ACCESS_COLOR_ATTACHMENT_READ_BIT |
        VK_ACCESS_DEPTH_STENCIL_ATTACHMENT_READ_BIT | VK_ACCESS_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT;
    deps[1].srcSubpass = 0;
    deps[1].dstSubpass = VK_SUBPASS_EXTERNAL;
    deps[1].srcStageMask = VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT;
    deps[1].dstStageMask = VK_PIPELINE_STAGE_TRANSFER_BIT;
    deps[1].srcAccessMask = VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT;
    deps[1].dstAccessMask = VK_ACCESS_TRANSFER_READ_BIT;

    VkRenderPassMultiviewCreateInfo multiview_info{};
    multiview_info.sType = VK_STRUCTURE_TYPE_RENDER_PASS_MULTIVIEW_CREATE_INFO;
    multiview_info.subpassCount = 1;
    multiview_info.pViewMasks = &kViewMask;
    multiview_info.correlationMaskCount = 1;
    multiview_info.pCorrelationMasks = &kCorrelationMask;

    VkRenderPassCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_RENDER_PASS_CREATE_INFO;
    info.pNext = multiview ? &multiview_info : nullptr;
    info.attachmentCount = 2;
    info.pAttachments = attachments;
    info.subpassCount = 1;
    info.pSubpasses = &subpass;
    info.dependencyCount = 2;
    info.pDependencies = deps;
    VkRenderPass pass = VK_NULL_HANDLE;
    HMDNODE_VK_TRY(vkCreateRenderPass(ctx.device, &info, nullptr, &pass), "vkCreateRenderPass");
    return RenderPass(ctx.device, pass);
}

}  // namespace

Result<StereoTargets> create_stereo_targets(const DeviceContext& ctx, uint32_t width,
                                            uint32_t height, bool multiview, int samples) {
    assert(width >= 1 && height >= 1);
    const VkPhysicalDeviceLimits& limits = ctx.properties.limits;
    if (width > limits.maxFramebufferWidth || height > limits.maxFramebufferHeight)
        return make_error("Vulkan: eye buffer " + std::to_string(width) + "x" +
                          std::to_string(height) + " exceeds the device's framebuffer limit " +
                          std::to_string(limits.maxFramebufferWidth) + "x" +
                          std::to_string(limits.maxFramebufferHeight));
    if (samples != 1 && samples != 4)
        return make_error("Vulkan: MSAA sample count " + std::to_string(samples) +
                          " is not 1 or 4");
    StereoTargets t;
    t.width = width;
    t.height = height;
    t.multiview = multiview;
    t.samples = samples == 4 ? VK_SAMPLE_COUNT_4_BIT : VK_SAMPLE_COUNT_1_BIT;
    const bool msaa = samples > 1;
    if (msaa && !(limits.framebufferColorSampleCounts & limits.framebufferDepthSampleCounts &
                  VK_SAMPLE_COUNT_4_BIT))
        return make_error("Vulkan: " + ctx.name +
                          " cannot render 4x MSAA colour and depth (use --msaa 1)");

    if (!supports(ctx, kColorFormat,
                  VK_FORMAT_FEATURE_COLOR_ATTACHMENT_BIT | VK_FORMAT_FEATURE_TRANSFER_SRC_BIT))
        return make_error("Vulkan: R8G8B8A8_SRGB is not renderable on " + ctx.name);
    for (VkFormat f : {VK_FORMAT_D32_SFLOAT, VK_FORMAT_X8_D24_UNORM_PACK32, VK_FORMAT_D16_UNORM}) {
        if (supports(ctx, f, VK_FORMAT_FEATURE_DEPTH_STENCIL_ATTACHMENT_BIT)) {
            t.depth_format = f;
            break;
        }
    }
    if (t.depth_format == VK_FORMAT_UNDEFINED)
        return make_error("Vulkan: no depth format is renderable on " + ctx.name);

    for (int slot = 0; slot < 2; ++slot) {
        auto color =
            create_image(ctx,
                         {width, height, 2, kColorFormat,
                          VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT |
                              VK_IMAGE_USAGE_TRANSFER_DST_BIT | VK_IMAGE_USAGE_SAMPLED_BIT,
                          VK_IMAGE_CREATE_MUTABLE_FORMAT_BIT},
                         "stereo colour target");
        if (!color) return color.error();
        t.color[slot] = std::move(*color);
    }
    auto depth = create_image(ctx,
                              {width, height, 2, t.depth_format,
                               VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT, 0, t.samples},
                              "stereo depth target");
    if (!depth) return depth.error();
    t.depth = std::move(*depth);
    if (msaa) {
        auto color = create_image(
            ctx,
            {width, height, 2, kColorFormat,
             VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT, 0, t.samples},
            "stereo multisampled colour target");
        if (!color) return color.error();
        t.color_msaa = std::move(*color);
    }
    auto pass = create_render_pass(ctx, t.depth_format, multiview, false, t.samples);
    if (!pass) return pass.error();
    t.render_pass = std::move(*pass);
    auto load_pass = create_render_pass(ctx, t.depth_format, multiview, true, t.samples);
    if (!load_pass) return load_pass.error();
    t.render_pass_load = std::move(*load_pass);

    // note: with multiview the framebuffer has one layer; the view mask addresses the image layers.
    for (int v = 0; v < t.pass_count(); ++v) {
        const uint32_t base = multiview ? 0 : uint32_t(v), count = multiview ? 2 : 1;
        auto depth_view = create_view(ctx, t.depth, t.depth_format, VK_IMAGE_ASPECT_DEPTH_BIT,
                                      "stereo depth target", base, count);
        if (!depth_view) return depth_view.error();
        t.depth_view[v] = std::move(*depth_view);
        if (msaa) {
            auto view = create_view(ctx, t.color_msaa, kColorFormat, VK_IMAGE_ASPECT_COLOR_BIT,
                                    "stereo multisampled colour target", base, count);
            if (!view) return view.error();
            t.color_msaa_view[v] = std::move(*view);
        }
        for (int slot = 0; slot < 2; ++slot) {
            auto color_view =
                create_view(ctx, t.color[slot], kColorFormat, VK_IMAGE_ASPECT_COLOR_BIT,
                            "stereo colour target", base, count);
            if (!color_view) return color_view.error();
            t.color_view[slot][v] = std::move(*color_view);
            const VkImageView views[2] = {msaa ? t.color_msaa_view[v] : t.color_view[slot][v],
                                          t.depth_view[v]};
            VkFramebufferCreateInfo fb{};
            fb.sType = VK_STRUCTURE_TYPE_FRAMEBUFFER_CREATE_INFO;
            fb.renderPass = t.render_pass;
            fb.attachmentCount = 2;
            fb.pAttachments = views;
            fb.width = width;
            fb.height = height;
            fb.layers = 1;
            VkFramebuffer framebuffer = VK_NULL_HANDLE;
            HMDNODE_VK_TRY(vkCreateFramebuffer(ctx.device, &fb, nullptr, &framebuffer),
                           "vkCreateFramebuffer (stereo)");
            t.framebuffer[slot][v] = Framebuffer(ctx.device, framebuffer);
        }
    }

    auto readback =
        create_buffer(ctx, VkDeviceSize(width) * height * 4 * 2, VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                      MemoryUse::Readback, "stereo read-back");
    if (!readback) return readback.error();
    t.readback = std::move(*readback);
    return t;
}

void record_resolve(VkCommandBuffer cmd, const StereoTargets& t, int slot) {
    if (t.samples == VK_SAMPLE_COUNT_1_BIT) return;
    const VkImageSubresourceRange range{VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 2};
    VkImageMemoryBarrier barrier{};
    barrier.sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER;
    barrier.srcAccessMask = VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_TRANSFER_READ_BIT;
    barrier.dstAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
    barrier.oldLayout = VK_IMAGE_LAYOUT_UNDEFINED;  // overwritten whole
    barrier.newLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
    barrier.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    barrier.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    barrier.image = t.color[slot].get();
    barrier.subresourceRange = range;
    vkCmdPipelineBarrier(cmd,
                         VK_PIPELINE_STAGE_FRAGMENT_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT,
                         VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 0, nullptr, 0, nullptr, 1, &barrier);
    VkImageResolve region{};
    region.srcSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 2};
    region.dstSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 2};
    region.extent = {t.width, t.height, 1};
    vkCmdResolveImage(cmd, t.color_msaa.get(), VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                      t.color[slot].get(), VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);
    // The read-back copy and the warp's sampling (after its own layout change) read it next.
    barrier.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
    barrier.dstAccessMask = VK_ACCESS_TRANSFER_READ_BIT | VK_ACCESS_SHADER_READ_BIT;
    barrier.oldLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
    barrier.newLayout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
    vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT,
                         VK_PIPELINE_STAGE_TRANSFER_BIT | VK_PIPELINE_STAGE_FRAGMENT_SHADER_BIT, 0,
                         0, nullptr, 0, nullptr, 1, &barrier);
}

}  // namespace hmdnode::vk
