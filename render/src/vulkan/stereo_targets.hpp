// The offscreen stereo targets: two 2-layer sRGB colour images (slots: the frame being rendered
// and the last finished one, which the warp pass reads meanwhile) and a 2-layer depth image
// (layer 0 = left eye), the render passes that draw them (clearing, for a frame's first piece, and
// loading, for its later pieces) and the host-visible buffer both eyes are copied into. Normally
// one multiview pass draws both layers at once (view mask 0b11); in per-eye mode (a driver whose
// multiview is broken, see vulkan_renderer.cpp) a plain pass runs once per layer.
//
// MSAA (samples 4): the passes draw into one multisampled 2-layer colour image (left in
// TRANSFER_SRC_OPTIMAL like the single-sampled one) and a multisampled depth image; the frame's
// last piece resolves it (vkCmdResolveImage, both layers, record_resolve) into the slot's colour
// image, so the warp and the read-back only ever see resolved pixels. The multisampled images are
// shared by both slots: only the frame being rendered uses them.
// note: not resolve attachments: Mesa 22.3 lavapipe resolves a per-eye pass's layer-1 view into
// garbage (tests/render/renderer_test.cpp caught it), and a frame in pieces needs one resolve,
// not one per piece.
// Created once per renderer; memory: eye_width * eye_height * 2 * (8 colour + 4 read-back +
// 4 * samples depth + 4 * samples multisampled colour when samples > 1) bytes.
#pragma once

#include "vk_memory.hpp"

namespace hmdnode::vk {

constexpr VkFormat kColorFormat = VK_FORMAT_R8G8B8A8_SRGB;

struct StereoTargets {
    uint32_t width = 0, height = 0;
    VkFormat depth_format = VK_FORMAT_UNDEFINED;
    bool multiview = true;
    VkSampleCountFlagBits samples = VK_SAMPLE_COUNT_1_BIT;
    Image color[2], depth;         // colour per slot (resolved), depth with `samples`
    Image color_msaa;              // samples > 1 only
    ImageView color_msaa_view[2];  // [pass]
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
// samples: 1 or 4; an error names what the device supports when it cannot.
Result<StereoTargets> create_stereo_targets(const DeviceContext& ctx, uint32_t width,
                                            uint32_t height, bool multiview, int samples);

// With samples > 1: records the resolve of both layers of the multisampled image (after the
// frame's last pass) into color[slot], which ends in TRANSFER_SRC_OPTIMAL like a single-sampled
// frame. Nothing otherwise.
void record_resolve(VkCommandBuffer cmd, const StereoTargets& t, int slot);

}  // namespace hmdnode::vk
