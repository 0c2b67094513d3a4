// Offscreen multiview targets and render pass. Cost: two image allocations and one read-back
// buffer at creation; nothing per frame.
#include "stereo_targets.hpp"

#include <string>

#include "render_target.hpp"

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
Result<RenderPass> create_stereo_pass(const DeviceContext& ctx, VkFormat depth_format,
                                      bool multiview, bool load, VkSampleCountFlagBits samples) {
    const VkAttachmentLoadOp load_op =
        load ? VK_ATTACHMENT_LOAD_OP_LOAD : VK_ATTACHMENT_LOAD_OP_CLEAR;
    const VkAttachmentDescription attachments[2] = {
        stored_attachment(kColorFormat, samples, load_op,
                          load ? VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL : VK_IMAGE_LAYOUT_UNDEFINED,
                          VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL),
        // Depth stored: a later piece of the frame loads it.
        stored_attachment(
            depth_format, samples, load_op,
            load ? VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL : VK_IMAGE_LAYOUT_UNDEFINED,
            VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL)};

    RenderPassDesc desc;
    desc.attachments = attachments;
    // note: the previous frame's (or piece's) read-back copy, colour and depth writes and the warp
    // pass's reads must finish before this pass writes the attachments.
    desc.before.srcStageMask =
        VK_PIPELINE_STAGE_TRANSFER_BIT | VK_PIPELINE_STAGE_LATE_FRAGMENT_TESTS_BIT |
        VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT | VK_PIPELINE_STAGE_FRAGMENT_SHADER_BIT;
    desc.before.dstStageMask =
        VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT | VK_PIPELINE_STAGE_EARLY_FRAGMENT_TESTS_BIT;
    desc.before.srcAccessMask =
        VK_ACCESS_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT | VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT;
    desc.before.dstAccessMask =
        VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT | VK_ACCESS_COLOR_ATTACHMENT_READ_BIT |
        VK_ACCESS_DEPTH_STENCIL_ATTACHMENT_READ_BIT | VK_ACCESS_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT;

    VkRenderPassMultiviewCreateInfo multiview_info{};
    multiview_info.sType = VK_STRUCTURE_TYPE_RENDER_PASS_MULTIVIEW_CREATE_INFO;
    multiview_info.subpassCount = 1;
    multiview_info.pViewMasks = &kViewMask;
    multiview_info.correlationMaskCount = 1;
    multiview_info.pCorrelationMasks = &kCorrelationMask;
    desc.next = multiview ? &multiview_info : nullptr;
    desc.what = "vkCreateRenderPass";
    return create_render_pass(ctx, desc);
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
    auto pass = create_stereo_pass(ctx, t.depth_format, multiview, false, t.samples);
    if (!pass) return pass.error();
    t.render_pass = std::move(*pass);
    auto load_pass = create_stereo_pass(ctx, t.depth_format, multiview, true, t.samples);
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
            auto framebuffer = create_framebuffer(ctx, t.render_pass, views, width, height,
                                                  "vkCreateFramebuffer (stereo)");
            if (!framebuffer) return framebuffer.error();
            t.framebuffer[slot][v] = std::move(*framebuffer);
        }
    }

    auto readback = create_readback(ctx, width, height, "stereo read-back");
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
