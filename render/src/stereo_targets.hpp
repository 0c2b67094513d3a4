// The offscreen stereo targets: two 2-layer sRGB colour images (slots: the frame being rendered
// and the last finished one, which the warp pass reads meanwhile) and a 2-layer depth image
// (layer 0 = left eye), the render passes that draw them (clearing, for a frame's first piece, and
// loading, for its later pieces) and the host-visible buffer both eyes are copied into. Normally
// one multiview pass draws both layers at once (view mask 0b11); in per-eye mode (a driver whose
// multiview is broken, see vulkan_renderer.cpp) a plain pass runs once per layer. Created once per
// renderer; memory: eye_width * eye_height * 2 * (8 colour + 4 depth + 4 read-back) bytes.
#pragma once

#include "vk_memory.hpp"

namespace hmdnode::vk {

constexpr VkFormat kColorFormat = VK_FORMAT_R8G8B8A8_SRGB;

struct StereoTargets {
    uint32_t width = 0, height = 0;
    VkFormat depth_format = VK_FORMAT_UNDEFINED;
    bool multiview = true;
    Image color[2], depth;  // colour per slot
    // [slot][pass]: multiview: [slot][0] spans both layers; else one per eye.
    ImageView color_view[2][2], depth_view[2];
    RenderPass render_pass;       // clears colour and depth
    RenderPass render_pass_load;  // keeps them (a frame's later pieces); compatible with the above
    Framebuffer framebuffer[2][2];  // [slot][pass]
    Buffer readback;  // width * height * 4 bytes per eye, left eye first, rows top to bottom

    int pass_count() const { return multiview ? 1 : 2; }
};

// The render passes leave colour in TRANSFER_SRC_OPTIMAL for the read-back copy (the loading one
// also starts from it) and store depth; the colour images are also sampled by the warp pass
// (warp_pass.hpp).
Result<StereoTargets> create_stereo_targets(const DeviceContext& ctx, uint32_t width,
                                            uint32_t height, bool multiview);

}  // namespace hmdnode::vk
