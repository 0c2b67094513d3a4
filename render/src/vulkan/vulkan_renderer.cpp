// The Vulkan backend of Renderer: headless device, multiview stereo targets, the lightmapped scene
// pipelines and the frame loop (record, submit, wait, read back). Per frame: one command buffer
// recorded from scratch (O(items * primitives) CPU), no GPU allocation; read-back copies
// 2 * eye_width * eye_height * 4 bytes.
//
// note: Mesa 22.3 lavapipe loses every triangle that needs x/y clipping from view 1 of a multiview
// pass (the right eye misses all geometry crossing the image edges). create() therefore renders a
// probe frame with such a triangle; when the eyes differ, it falls back to per-eye mode: one
// ordinary pass per eye layer, same shaders (view_base push constant). On lavapipe it loses
// little, since llvmpipe repeats the vertex work per view anyway (docs/DESIGN.md §9).
// HMDNODE_VK_MULTIVIEW=1 forces multiview without the probe, =0 forces per-eye passes.
#include <cstddef>
#include <cstdlib>
#include <cstring>
#include <optional>
#include <string>

#include "frame_queue.hpp"
#include "gpu_scene.hpp"
#include "hmdnode/render/renderer.hpp"
#include "scene_pipeline.hpp"
#include "stereo_targets.hpp"
#include "vk_check.hpp"
#include "vk_device.hpp"
#include "vk_memory.hpp"
#include "warp_pass.hpp"

namespace hmdnode {
namespace {

constexpr uint64_t kFenceTimeoutNs = 20'000'000'000;  // a frame that takes 20 s is a hung GPU

using gpu::now_ns;

class VulkanRenderer final : public Renderer {
  public:
    static Result<std::unique_ptr<Renderer>> create(const RendererConfig& config);
    ~VulkanRenderer() override;

    Status upload(const Scene& scene) override;
    Result<RenderStats> render(const StereoViews& views, std::span<const DrawItem> items,
                               StereoImage* out_image) override;
    std::string device_name() const override { return ctx_->name; }
    const char* backend_name() const override { return "vulkan"; }
    int msaa_samples() const override { return config_.msaa_samples; }
    Status begin_frame(const StereoViews& views, std::span<const DrawItem> items) override;
    Result<bool> render_more(uint64_t max_triangles, size_t* items_rendered) override;
    Status set_warp(int panel_width, int panel_height, const DistortionMesh& left,
                    const DistortionMesh& right) override;
    Result<WarpStats> warp(const glm::dquat& delta, StereoImage* out_panel) override;
    Status set_lens_warp(int panel_width, int panel_height, const HeadsetProfile& profile) override;
    const char* lens_pass_name() const override {
        return !warp_ ? "" : warp_->fused ? "fused" : "mesh";
    }
    void set_chromatic_aberration(bool on) override { chromatic_ = on; }
    void set_latency_marker(const LatencyMarkerOverlay* overlay) override {
        marker_ = overlay ? std::optional<LatencyMarkerOverlay>(*overlay) : std::nullopt;
    }
    bool chromatic_aberration() const override { return warp_ && warp_->chromatic && chromatic_; }
    Status set_render_scale(double scale) override {
        if (Status s = gpu::check_render_scale(scale); !s) return s;
        scale_ = scale;
        return Status::success();
    }
    double render_scale() const override { return scale_; }

  private:
    // Checks the panel size and keeps it, then (re)builds the warp pass.
    Status configure_warp(int panel_width, int panel_height);
    // (Re)creates the warp pass over the current targets from the stored meshes.
    Status build_warp_pass();
    // (Re)creates the targets, pipelines and the per-frame descriptor set for one stereo mode.
    Status build_frame_path(bool multiview);
    // Renders a triangle that crosses every edge of both views; false when the eyes differ.
    Result<bool> multiview_clips_correctly();
    // Draws of one pass; view_base is 0 with multiview, else the eye the pass renders.
    void record_draws(std::span<const DrawItem> items, uint32_t view_base);
    // Records one piece of the open frame: items [first, last) into the back slot, clearing when
    // first == 0, with the read-back copy when read_back.
    void record(size_t first, size_t last, bool read_back);
    // Runs the next piece of the open frame (see render_more); on completion the back slot
    // becomes the front one.
    Result<bool> run_piece(uint64_t max_triangles, bool read_back, int64_t* wait_ns,
                           size_t* items_rendered);
    void read_back(StereoImage& out_image) const;
    // Resets `fence` and submits `cmd` with it; a lost device makes the renderer refuse later work.
    Status submit(VkCommandBuffer cmd, VkFence fence, const char* what);
    // Waits for `fence`; on a timeout or lost device the renderer refuses all later work.
    Status wait(VkFence fence, const char* what);

    RendererConfig config_;
    std::unique_ptr<vk::DeviceContext> ctx_;  // first: destroyed last
    vk::StereoTargets targets_;
    vk::ScenePipeline pipeline_;
    vk::Buffer frame_constants_;  // FrameConstants, host-visible
    vk::DescriptorPool frame_pool_;
    VkDescriptorSet frame_set_ = VK_NULL_HANDLE;
    VkCommandBuffer cmd_ = VK_NULL_HANDLE;  // freed with the context's pool
    vk::Fence fence_;
    std::unique_ptr<vk::GpuScene> scene_;  // null before the first upload
    // Late warp: its own command buffer and fence, so a re-warp never touches the scene's.
    VkCommandBuffer warp_cmd_ = VK_NULL_HANDLE;
    vk::Fence warp_fence_;
    std::optional<vk::WarpPass> warp_;
    int panel_width_ = 0, panel_height_ = 0;
    DistortionMesh warp_mesh_[2];
    std::optional<gpu::LensPassSetup> lens_setup_;  // the fused pass's, else the meshes' pass
    bool chromatic_ = true;
    std::optional<LatencyMarkerOverlay> marker_;  // drawn by every warp (null: none)
    double scale_ = 1.0;                     // dynamic resolution of the frames begun from now on
    gpu::ScaledViewport frame_viewport_;     // of the open frame
    gpu::ScaledViewport rendered_viewport_;  // of the finished frame
    // The frame being rendered (into slot back_) and the last finished one (slot 1 - back_).
    gpu::FrameQueue frame_;
    int back_ = 0;
    glm::mat4 frame_projection_[2]{};        // of the open frame
    glm::mat4 rendered_projection_[2]{};     // of the finished frame
    bool rendered_ = false;                  // a finished frame exists
    bool eyes_sampled_[2] = {false, false};  // slot in SHADER_READ_ONLY_OPTIMAL
    std::string lost_;                       // why the device is unusable; empty while it works
};

Result<std::unique_ptr<Renderer>> VulkanRenderer::create(const RendererConfig& config) {
    if (config.eye_width < 1 || config.eye_height < 1)
        return make_error("renderer: eye buffer " + std::to_string(config.eye_width) + "x" +
                          std::to_string(config.eye_height) + " is empty");
    auto r = std::unique_ptr<VulkanRenderer>(new VulkanRenderer());
    r->config_ = config;

    // 1. Device, the reusable command buffer and its fence.
    auto ctx = vk::create_device_context(config.validation);
    if (!ctx) return ctx.error();
    r->ctx_ = std::move(*ctx);
    const VkDevice device = r->ctx_->device;
    VkCommandBufferAllocateInfo cmd_info{};
    cmd_info.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
    cmd_info.commandPool = r->ctx_->command_pool;
    cmd_info.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    cmd_info.commandBufferCount = 1;
    HMDNODE_VK_TRY(vkAllocateCommandBuffers(device, &cmd_info, &r->cmd_),
                   "vkAllocateCommandBuffers (frame)");
    HMDNODE_VK_TRY(vkAllocateCommandBuffers(device, &cmd_info, &r->warp_cmd_),
                   "vkAllocateCommandBuffers (warp)");
    VkFenceCreateInfo fence_info{};
    fence_info.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
    VkFence fence = VK_NULL_HANDLE;
    HMDNODE_VK_TRY(vkCreateFence(device, &fence_info, nullptr, &fence), "vkCreateFence (frame)");
    r->fence_ = vk::Fence(device, fence);
    HMDNODE_VK_TRY(vkCreateFence(device, &fence_info, nullptr, &fence), "vkCreateFence (warp)");
    r->warp_fence_ = vk::Fence(device, fence);
    auto frame_constants =
        vk::create_buffer(*r->ctx_, sizeof(vk::FrameConstants), VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT,
                          vk::MemoryUse::Upload, "frame constants");
    if (!frame_constants) return frame_constants.error();
    r->frame_constants_ = std::move(*frame_constants);

    // 2. Targets and pipelines: multiview unless the driver gets it wrong (see the note on top).
    const char* forced = std::getenv("HMDNODE_VK_MULTIVIEW");
    const bool force_per_eye = forced && std::string(forced) == "0";
    const bool force_multiview = forced && std::string(forced) == "1";
    if (Status s = r->build_frame_path(!force_per_eye); !s) return s.error();
    if (!force_per_eye && !force_multiview) {
        auto ok = r->multiview_clips_correctly();
        if (!ok) return ok.error();
        if (!*ok)
            if (Status s = r->build_frame_path(false); !s) return s.error();
    }
    return std::unique_ptr<Renderer>(std::move(r));
}

Status VulkanRenderer::build_frame_path(bool multiview) {
    vk::DeviceContext& ctx = *ctx_;
    vkDeviceWaitIdle(ctx.device);
    frame_pool_.reset();
    frame_set_ = VK_NULL_HANDLE;
    auto targets =
        vk::create_stereo_targets(ctx, uint32_t(config_.eye_width), uint32_t(config_.eye_height),
                                  multiview, config_.msaa_samples);
    if (!targets) return targets.error();
    targets_ = std::move(*targets);
    auto pipeline = vk::create_scene_pipeline(ctx, targets_.render_pass, targets_.samples);
    if (!pipeline) return pipeline.error();
    pipeline_ = std::move(*pipeline);

    const VkDescriptorPoolSize size{VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1};
    VkDescriptorPoolCreateInfo pool_info{};
    pool_info.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO;
    pool_info.maxSets = 1;
    pool_info.poolSizeCount = 1;
    pool_info.pPoolSizes = &size;
    VkDescriptorPool pool = VK_NULL_HANDLE;
    HMDNODE_VK_TRY(vkCreateDescriptorPool(ctx.device, &pool_info, nullptr, &pool),
                   "vkCreateDescriptorPool (frame)");
    frame_pool_ = vk::DescriptorPool(ctx.device, pool);
    const VkDescriptorSetLayout frame_layout = pipeline_.frame_layout;
    VkDescriptorSetAllocateInfo set_info{};
    set_info.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO;
    set_info.descriptorPool = pool;
    set_info.descriptorSetCount = 1;
    set_info.pSetLayouts = &frame_layout;
    HMDNODE_VK_TRY(vkAllocateDescriptorSets(ctx.device, &set_info, &frame_set_),
                   "vkAllocateDescriptorSets (frame)");
    const VkDescriptorBufferInfo buffer_info{frame_constants_.get(), 0, sizeof(vk::FrameConstants)};
    VkWriteDescriptorSet write{};
    write.sType = VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET;
    write.dstSet = frame_set_;
    write.dstBinding = 0;
    write.descriptorCount = 1;
    write.descriptorType = VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
    write.pBufferInfo = &buffer_info;
    vkUpdateDescriptorSets(ctx.device, 1, &write, 0, nullptr);
    rendered_ = false;
    frame_.open = false;
    eyes_sampled_[0] = eyes_sampled_[1] = false;
    return build_warp_pass();
}

Status VulkanRenderer::build_warp_pass() {
    warp_.reset();
    if (panel_width_ <= 0) return Status::success();  // no set_warp() yet
    auto pass = lens_setup_
                    ? vk::create_lens_warp_pass(*ctx_, targets_.color, uint32_t(panel_width_),
                                                uint32_t(panel_height_), *lens_setup_)
                    : vk::create_warp_pass(*ctx_, targets_.color, uint32_t(panel_width_),
                                           uint32_t(panel_height_), warp_mesh_);
    if (!pass) return pass.error();
    warp_ = std::move(*pass);
    return Status::success();
}

Status VulkanRenderer::configure_warp(int panel_width, int panel_height) {
    vkDeviceWaitIdle(ctx_->device);
    panel_width_ = panel_width;
    panel_height_ = panel_height;
    Status s = build_warp_pass();
    if (!s) panel_width_ = panel_height_ = 0;
    return s;
}

Status VulkanRenderer::set_warp(int panel_width, int panel_height, const DistortionMesh& left,
                                const DistortionMesh& right) {
    if (!lost_.empty()) return make_error(lost_);
    if (panel_width < 1 || panel_height < 1)
        return make_error("renderer: panel " + std::to_string(panel_width) + "x" +
                          std::to_string(panel_height) + " is empty");
    warp_mesh_[0] = left;
    warp_mesh_[1] = right;
    lens_setup_.reset();
    chromatic_ = true;
    return configure_warp(panel_width, panel_height);
}

Status VulkanRenderer::set_lens_warp(int panel_width, int panel_height,
                                     const HeadsetProfile& profile) {
    if (!lost_.empty()) return make_error(lost_);
    auto setup = gpu::make_lens_pass_setup(profile, panel_width, panel_height);
    if (!setup) return setup.error();
    lens_setup_ = std::move(*setup);
    warp_mesh_[0] = warp_mesh_[1] = DistortionMesh();
    chromatic_ = true;
    return configure_warp(panel_width, panel_height);
}

Status VulkanRenderer::submit(VkCommandBuffer cmd, VkFence fence, const char* what) {
    const std::string suffix = std::string(" (") + what + ")";
    if (VkResult r = vkResetFences(ctx_->device, 1, &fence); r != VK_SUCCESS)
        return vk::vk_error(("vkResetFences" + suffix).c_str(), r);
    VkSubmitInfo info{};
    info.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
    info.commandBufferCount = 1;
    info.pCommandBuffers = &cmd;
    const VkResult r = vkQueueSubmit(ctx_->queue, 1, &info, fence);
    if (r == VK_SUCCESS) return Status::success();
    if (r == VK_ERROR_DEVICE_LOST) lost_ = vk::vk_error("vkQueueSubmit", r).message;
    return vk::vk_error(("vkQueueSubmit" + suffix).c_str(), r);
}

Status VulkanRenderer::wait(VkFence fence, const char* what) {
    const VkResult r = vkWaitForFences(ctx_->device, 1, &fence, VK_TRUE, kFenceTimeoutNs);
    if (r == VK_SUCCESS) return Status::success();
    // note: a submission still in flight keeps its command buffer and fence busy: no later work
    // can be recorded safely, so the renderer refuses further work.
    lost_ = vk::vk_error(what, r).message;
    return make_error(lost_);
}

Result<WarpStats> VulkanRenderer::warp(const glm::dquat& delta, StereoImage* out_panel) {
    if (!lost_.empty()) return make_error(lost_);
    if (!warp_) return make_error("renderer: warp() before set_warp()");
    if (!rendered_) return make_error("renderer: warp() before any render()");
    WarpStats stats;
    const int64_t t0 = now_ns();
    glm::mat4 reproject[2];
    for (int e = 0; e < 2; ++e)
        reproject[e] = gpu::warp_reprojection(rendered_projection_[e], delta);
    vkResetCommandBuffer(warp_cmd_, 0);
    VkCommandBufferBeginInfo begin{};
    begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
    begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    vkBeginCommandBuffer(warp_cmd_, &begin);
    const int front = 1 - back_;
    if (!eyes_sampled_[front]) {
        VkImageMemoryBarrier barrier{};
        barrier.sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER;
        barrier.srcAccessMask = VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT;
        barrier.dstAccessMask = VK_ACCESS_SHADER_READ_BIT;
        barrier.oldLayout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
        barrier.newLayout = VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL;
        barrier.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
        barrier.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
        barrier.image = targets_.color[front].get();
        barrier.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 2};
        vkCmdPipelineBarrier(
            warp_cmd_,
            VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT,
            VK_PIPELINE_STAGE_FRAGMENT_SHADER_BIT, 0, 0, nullptr, 0, nullptr, 1, &barrier);
    }
    vk::record_warp(warp_cmd_, *warp_, front, reproject, out_panel != nullptr,
                    rendered_viewport_.sample_rect, chromatic_, marker_ ? &*marker_ : nullptr);
    vkEndCommandBuffer(warp_cmd_);
    const VkFence fence = warp_fence_;
    if (Status st = submit(warp_cmd_, fence, "warp"); !st) return st.error();
    const int64_t t1 = now_ns();
    if (Status s = wait(fence, "vkWaitForFences (warp)"); !s) return s.error();
    eyes_sampled_[front] = true;
    const int64_t t2 = now_ns();
    if (out_panel) {
        if (Status s = warp_->readback.invalidate(); !s) return s.error();
        const size_t eye_bytes = size_t(warp_->width) * warp_->height * 4;
        const auto* src = static_cast<const uint8_t*>(warp_->readback.mapped());
        for (int e = 0; e < 2; ++e) {
            ImageRGBA8& eye = out_panel->eye[e];
            eye.width = int(warp_->width);
            eye.height = int(warp_->height);
            eye.pixels.resize(eye_bytes);  // allocates only when the size changes
            std::memcpy(eye.pixels.data(), src + size_t(e) * eye_bytes, eye_bytes);
        }
    }
    const int64_t t3 = now_ns();
    stats.cpu_record_ns = t1 - t0;
    stats.gpu_wait_ns = t2 - t1;
    stats.readback_ns = out_panel ? t3 - t2 : 0;
    return stats;
}

Result<bool> VulkanRenderer::multiview_clips_correctly() {
    // A triangle far larger than the view, in a colour unlike the clear colour, seen by both eyes
    // through the same matrices: the eyes must come out identical.
    Scene probe;
    Material m;
    const glm::vec4& clear = config_.clear_color;
    m.base_color_factor = glm::vec4(clear.r > 0.5f ? 0.0f : 1.0f, 0.5f, 0.5f, 1.0f);
    probe.materials.push_back(m);
    Primitive tri;
    tri.positions = {{-8.0f, -8.0f, -1.0f}, {8.0f, -8.0f, -1.0f}, {0.0f, 8.0f, -1.0f}};
    tri.indices = {0, 1, 2};
    tri.material = 0;
    probe.meshes.push_back(Mesh{"probe", {tri}});
    if (Status s = upload(probe); !s) return s.error();
    StereoViews views;
    const float n = 0.1f, f = 10.0f;  // symmetric 90-degree frustum, Vulkan clip space
    const glm::mat4 projection(glm::vec4(1, 0, 0, 0), glm::vec4(0, -1, 0, 0),
                               glm::vec4(0, 0, f / (n - f), -1),
                               glm::vec4(0, 0, n * f / (n - f), 0));
    for (int e = 0; e < 2; ++e) {
        views.view[e] = glm::mat4(1.0f);
        views.projection[e] = projection;
    }
    const DrawItem item{0, glm::mat4(1.0f)};
    StereoImage image;
    auto stats = render(views, {&item, 1}, &image);
    scene_.reset();
    if (!stats) return stats.error();
    const int cx = config_.eye_width / 2, cy = config_.eye_height / 2;
    return std::memcmp(image.eye[0].at(cx, cy), image.eye[1].at(cx, cy), 4) == 0;
}

VulkanRenderer::~VulkanRenderer() {
    // note: members destroy their objects after this body; the GPU must be done with them.
    if (ctx_ && ctx_->device) vkDeviceWaitIdle(ctx_->device);
}

Status VulkanRenderer::upload(const Scene& scene) {
    if (!lost_.empty()) return make_error(lost_);
    // The old scene stays usable until the new one is complete; no frame is in flight here
    // (render() waits for its fence), so the old one can go at once.
    auto gpu = vk::upload_scene(*ctx_, scene, pipeline_.material_layout);
    if (!gpu) return gpu.error();
    scene_ = std::move(*gpu);
    return Status::success();
}

void VulkanRenderer::record_draws(std::span<const DrawItem> items, uint32_t view_base) {
    vkCmdPushConstants(cmd_, pipeline_.layout, VK_SHADER_STAGE_VERTEX_BIT,
                       offsetof(vk::DrawConstants, view_base), sizeof(uint32_t), &view_base);
    if (items.empty() || !scene_ || !scene_->vertices.get()) return;
    const VkViewport viewport{
        0.0f, 0.0f, float(frame_viewport_.width), float(frame_viewport_.height), 0.0f, 1.0f};
    const VkRect2D scissor{{0, 0}, {frame_viewport_.width, frame_viewport_.height}};
    vkCmdSetViewport(cmd_, 0, 1, &viewport);
    vkCmdSetScissor(cmd_, 0, 1, &scissor);
    vkCmdBindDescriptorSets(cmd_, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline_.layout, 0, 1,
                            &frame_set_, 0, nullptr);
    const VkBuffer vertex_buffer = scene_->vertices.get();
    const VkDeviceSize zero = 0;
    vkCmdBindVertexBuffers(cmd_, 0, 1, &vertex_buffer, &zero);
    vkCmdBindIndexBuffer(cmd_, scene_->indices.get(), 0, VK_INDEX_TYPE_UINT32);

    VkPipeline bound_pipeline = VK_NULL_HANDLE;
    uint32_t bound_material = UINT32_MAX;
    for (const DrawItem& item : items) {
        const vk::GpuMesh& mesh = scene_->meshes[size_t(item.mesh)];
        if (mesh.primitive_count == 0) continue;
        vkCmdPushConstants(cmd_, pipeline_.layout, VK_SHADER_STAGE_VERTEX_BIT, 0, sizeof(glm::mat4),
                           &item.world);
        const bool dithered = item.dither != 0;
        if (dithered)
            vkCmdPushConstants(cmd_, pipeline_.layout, VK_SHADER_STAGE_FRAGMENT_BIT,
                               offsetof(vk::DrawConstants, dither), sizeof(int32_t), &item.dither);
        for (uint32_t p = 0; p < mesh.primitive_count; ++p) {
            const vk::GpuPrimitive& prim = scene_->primitives[mesh.first_primitive + p];
            const VkPipeline pipeline =
                prim.double_sided
                    ? (dithered ? pipeline_.double_sided_dithered : pipeline_.double_sided).get()
                    : (dithered ? pipeline_.single_sided_dithered : pipeline_.single_sided).get();
            if (pipeline != bound_pipeline) {
                vkCmdBindPipeline(cmd_, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline);
                bound_pipeline = pipeline;
            }
            if (prim.material != bound_material) {
                vkCmdBindDescriptorSets(cmd_, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline_.layout, 1,
                                        1, &scene_->material_sets[prim.material], 0, nullptr);
                bound_material = prim.material;
            }
            vkCmdDrawIndexed(cmd_, prim.index_count, 1, prim.first_index, prim.vertex_offset, 0);
        }
    }
}

void VulkanRenderer::record(size_t first, size_t last, bool read_back) {
    VkCommandBufferBeginInfo begin{};
    begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
    begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    vkBeginCommandBuffer(cmd_, &begin);

    VkClearValue clears[2]{};
    const glm::vec4& c = config_.clear_color;
    clears[0].color = {{c.r, c.g, c.b, c.a}};
    clears[1].depthStencil = {1.0f, 0};
    const std::span<const DrawItem> items(frame_.items.data() + first, last - first);
    for (int p = 0; p < targets_.pass_count(); ++p) {
        VkRenderPassBeginInfo pass{};
        pass.sType = VK_STRUCTURE_TYPE_RENDER_PASS_BEGIN_INFO;
        pass.renderPass = first == 0 ? targets_.render_pass : targets_.render_pass_load;
        pass.framebuffer = targets_.framebuffer[back_][p];
        // (Dynamic resolution: only the part the frame renders into is cleared and drawn.)
        pass.renderArea = {{0, 0}, {frame_viewport_.width, frame_viewport_.height}};
        pass.clearValueCount = first == 0 ? 2 : 0;
        pass.pClearValues = first == 0 ? clears : nullptr;
        vkCmdBeginRenderPass(cmd_, &pass, VK_SUBPASS_CONTENTS_INLINE);
        record_draws(items, uint32_t(p));
        vkCmdEndRenderPass(cmd_);
    }

    // MSAA: the finished frame's samples resolved into the slot before anything reads it.
    if (last == frame_.items.size()) vk::record_resolve(cmd_, targets_, back_);
    // Both layers: the buffer holds layer 0 (left) then layer 1 (right).
    if (read_back)
        vk::record_copy_to_host(cmd_, targets_.color[back_].get(), targets_.width, targets_.height,
                                2, targets_.readback);
    vkEndCommandBuffer(cmd_);
}

Status VulkanRenderer::begin_frame(const StereoViews& views, std::span<const DrawItem> items) {
    if (!lost_.empty()) return make_error(lost_);
    if (Status s = frame_.begin(items, scene_ ? std::span<const gpu::MeshRange>(scene_->meshes)
                                              : std::span<const gpu::MeshRange>());
        !s)
        return s;
    vk::FrameConstants frame;
    for (int e = 0; e < 2; ++e) {
        frame.view_projection[e] = views.projection[e] * views.view[e];
        frame_projection_[e] = views.projection[e];
    }
    frame_viewport_ = gpu::scaled_viewport(targets_.width, targets_.height, scale_);
    std::memcpy(frame_constants_.mapped(), &frame, sizeof(frame));
    return frame_constants_.flush();
}

Result<bool> VulkanRenderer::run_piece(uint64_t max_triangles, bool read_back, int64_t* wait_ns,
                                       size_t* items_rendered) {
    if (!lost_.empty()) return make_error(lost_);
    if (!frame_.open) return make_error("renderer: render_more() without begin_frame()");
    const size_t last = frame_.piece_end(max_triangles);
    const bool done = last == frame_.items.size();
    record(frame_.cursor, last, read_back && done);
    const VkFence fence = fence_;
    if (Status st = submit(cmd_, fence, "frame"); !st) return st.error();
    const int64_t t0 = now_ns();
    if (Status s = wait(fence, "vkWaitForFences (frame)"); !s) return s.error();
    if (wait_ns) *wait_ns = now_ns() - t0;
    if (items_rendered) *items_rendered = last - frame_.cursor;
    frame_.cursor = last;
    if (!done) return false;
    // The frame is complete: it becomes the one warp() reads, in TRANSFER_SRC_OPTIMAL.
    frame_.open = false;
    rendered_ = true;
    eyes_sampled_[back_] = false;
    for (int e = 0; e < 2; ++e) rendered_projection_[e] = frame_projection_[e];
    rendered_viewport_ = frame_viewport_;
    back_ = 1 - back_;
    return true;
}

Result<bool> VulkanRenderer::render_more(uint64_t max_triangles, size_t* items_rendered) {
    return run_piece(max_triangles, false, nullptr, items_rendered);
}

void VulkanRenderer::read_back(StereoImage& out_image) const {
    const size_t eye_bytes = size_t(targets_.width) * targets_.height * 4;
    const auto* src = static_cast<const uint8_t*>(targets_.readback.mapped());
    for (int e = 0; e < 2; ++e) {
        ImageRGBA8& eye = out_image.eye[e];
        eye.width = int(targets_.width);
        eye.height = int(targets_.height);
        eye.pixels.resize(eye_bytes);  // allocates only when the size changes
        std::memcpy(eye.pixels.data(), src + size_t(e) * eye_bytes, eye_bytes);
    }
}

Result<RenderStats> VulkanRenderer::render(const StereoViews& views,
                                           std::span<const DrawItem> items,
                                           StereoImage* out_image) {
    RenderStats stats;
    const int64_t t0 = now_ns();
    if (Status s = begin_frame(views, items); !s) return s.error();
    stats.triangles = frame_.total_triangles();
    int64_t wait_ns = 0;
    // The whole frame in one piece.
    auto done = run_piece(UINT64_MAX, out_image != nullptr, &wait_ns, nullptr);
    if (!done) return done.error();
    const int64_t t2 = now_ns();
    if (out_image) {
        if (Status s = targets_.readback.invalidate(); !s) return s.error();
        read_back(*out_image);
    }
    const int64_t t3 = now_ns();
    stats.gpu_wait_ns = wait_ns;
    stats.cpu_record_ns = t2 - t0 - wait_ns;
    stats.readback_ns = out_image ? t3 - t2 : 0;
    stats.passes = targets_.pass_count();
    return stats;
}

}  // namespace

Result<std::unique_ptr<Renderer>> create_vulkan_renderer(const RendererConfig& config) {
    return VulkanRenderer::create(config);
}

}  // namespace hmdnode
