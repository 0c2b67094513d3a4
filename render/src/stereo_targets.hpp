// The offscreen stereo targets: a 2-layer sRGB colour image and a 2-layer depth image (layer 0 =
// left eye), the render pass that draws them and the host-visible buffer both eyes are copied
// into. Normally one multiview pass draws both layers at once (view mask 0b11); in per-eye mode
// (a driver whose multiview is broken, see vulkan_renderer.cpp) a plain pass runs once per layer.
// Created once per renderer; memory: eye_width * eye_height * 2 * (4 colour + 4 depth + 4
// read-back) bytes.
#pragma once

#include "vk_memory.hpp"

namespace hmdnode::vk {

constexpr VkFormat kColorFormat = VK_FORMAT_R8G8B8A8_SRGB;

struct StereoTargets {
    uint32_t width = 0, height = 0;
    VkFormat depth_format = VK_FORMAT_UNDEFINED;
    bool multiview = true;
    Image color, depth;
    ImageView color_view[2], depth_view[2];  // multiview: [0] spans both layers; else one per eye
    RenderPass render_pass;
    Framebuffer framebuffer[2];  // multiview: [0] only; else one per eye
    Buffer readback;  // width * height * 4 bytes per eye, left eye first, rows top to bottom

    int pass_count() const { return multiview ? 1 : 2; }
};

// The render pass clears colour and depth (1.0) and leaves colour in TRANSFER_SRC_OPTIMAL for the
// read-back copy; the colour image is also sampled by the warp pass (warp_pass.hpp).
Result<StereoTargets> create_stereo_targets(const DeviceContext& ctx, uint32_t width,
                                            uint32_t height, bool multiview);

}  // namespace hmdnode::vk
