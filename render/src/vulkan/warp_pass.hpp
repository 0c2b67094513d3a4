// The late-warp + lens-distortion pass (render/shaders/warp.vert, warp.frag): resamples the
// rendered eye buffers through one distortion mesh per eye into the panel image, rotating every
// view direction from the displayed head pose into the rendered one (rotational reprojection,
// J.M.P. van Waveren, "The asynchronous time warp for virtual reality on consumer hardware",
// VRST 2016; mesh-based distortion and chromatic aberration as in Monado's compositor). One pass
// per eye into a 2-layer panel image, then a read-back copy. Cost per frame: (cols+1)(rows+1)
// vertices and panel_width * panel_height fragments (3 bilinear samples each) per eye, plus the
// copy of 2 * panel_width * panel_height * 4 bytes.
//
// The fused pass (create_lens_warp_pass; render/shaders/lens_warp.*, lens_pass.hpp) draws one
// full-screen triangle per eye instead and evaluates the lens model per fragment: no mesh, the
// same panel image, read-back and descriptor slots. Cost: 3 vertices and panel_width *
// panel_height fragments (3 samples each, 1 with chromatic aberration off) per eye.
#pragma once

#include <glm/glm.hpp>

#include "hmdnode/render/lens.hpp"
#include "hmdnode/render/renderer.hpp"
#include "lens_pass.hpp"
#include "vk_memory.hpp"

namespace hmdnode::vk {

// Push constants of the warp shaders.
struct WarpConstants {
    glm::mat4 reproject;  // upper 3x3: eye-frame direction -> (clip.x, clip.y, clip.w)
    float layer;
    float pad[3];           // std430: the vec4 below starts at byte 80
    glm::vec4 sample_rect;  // xy: the rendered fraction of the eye buffer, zw: the largest
                            // texture coordinate sampled (its last texel centre)
};
static_assert(sizeof(WarpConstants) == 96, "push-constant layout of the warp shaders");

struct WarpPass {
    uint32_t width = 0, height = 0;  // panel pixels per eye
    Image panel;                     // 2 layers, sRGB
    ImageView panel_view[2];
    RenderPass render_pass;
    Framebuffer framebuffer[2];
    Sampler sampler;  // bilinear, black border
    // [slot][eye]: one 2D view per eye layer (llvmpipe's fast 8-bit filtering path takes 2D
    // textures, not arrays).
    ImageView eyes_view[2][2];
    DescriptorSetLayout set_layout;
    DescriptorPool pool;
    VkDescriptorSet set[2][2] = {};  // [slot][eye]
    PipelineLayout layout;
    Pipeline pipeline;
    Pipeline mono_pipeline;  // the mesh pass with chromatic aberration: its one-sample variant
    bool mono = false;       // the meshes have no chromatic aberration: one sample per pixel
    // The fused pass (no meshes): a pipeline per eye and per variant ([eye][0] three samples,
    // [eye][1] one), the lens uniforms per eye, the eye-to-head rotation folded into the
    // reprojection.
    bool fused = false;
    bool chromatic = false;  // the profile has chromatic aberration to correct
    Pipeline fused_pipeline[2][2];
    Buffer lens_uniforms[2];
    gpu::LensPassEye lens[2];
    Buffer vertices[2], indices[2];
    uint32_t index_count[2] = {0, 0};
    Buffer readback;  // width * height * 4 bytes per eye, left first
};

// `eyes` are the two slots of the stereo colour target (2 layers each, sampled usage).
Result<WarpPass> create_warp_pass(DeviceContext& ctx, const Image eyes[2], uint32_t width,
                                  uint32_t height, const DistortionMesh mesh[2]);

// The fused pass over the same eye buffers, from the lens set-up.
Result<WarpPass> create_lens_warp_pass(DeviceContext& ctx, const Image eyes[2], uint32_t width,
                                       uint32_t height, const gpu::LensPassSetup& lens);

// Records both eyes' passes reading slot `slot` and the read-back copy (when read_back).
// reproject[e] maps eye e's head-aligned display directions into its eye buffer's clip space;
// sample_rect as in WarpConstants; chromatic: the fused pass samples each channel through its
// own lens (ignored by the mesh pass); marker: the latency marker cleared into each eye's panel
// after its pass (latency_overlay.hpp), or null. The slot's eye buffers must be in
// SHADER_READ_ONLY_OPTIMAL.
void record_warp(VkCommandBuffer cmd, const WarpPass& pass, int slot, const glm::mat4 reproject[2],
                 bool read_back, const glm::vec4& sample_rect, bool chromatic,
                 const LatencyMarkerOverlay* marker);

}  // namespace hmdnode::vk
