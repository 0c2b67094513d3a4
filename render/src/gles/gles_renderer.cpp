// The OpenGL ES 3 backend of Renderer, on an off-screen EGL context (gles_context.hpp): two slots
// of per-eye sRGB colour textures with per-eye depth renderbuffers, one framebuffer object per eye
// and slot, the scene program (gles_shaders.cpp, the Vulkan shaders' maths) drawn once per eye,
// the late-warp + lens-distortion pass into two UNORM panel textures, and glReadPixels read-back.
// Per frame: O(items * primitives) GL calls, no allocation; read-back copies
// 2 * eye_width * eye_height * 4 bytes. Mirrors vulkan_renderer.cpp; the differences:
//  - one pass per eye (RenderStats::passes = 2): no multiview (OVR_multiview is optional in GLES,
//    and llvmpipe repeats the vertex work per view anyway, docs/DESIGN.md section 9);
//  - the Vulkan projections are used unchanged. Vulkan's y-down clip space puts NDC y = -1 on the
//    first framebuffer row; GL puts it on window row 0, which is also the first row glReadPixels
//    returns, so the read-back rows come out top to bottom with no flip. Vulkan computes a
//    triangle's facing with the opposite sign of GL's (its y axis points down), so glTF's
//    counter-clockwise front faces are GL_CW here. GL_EXT_clip_control (where offered) gives
//    Vulkan's [0, 1] depth range, so near-plane clipping and depth values match too;
//  - the warp samples the sRGB eye textures with their decode skipped (GL_EXT_texture_sRGB_decode),
//    as the Vulkan pass reads them through UNORM views;
//  - zero-copy scan-out (RendererConfig::scanout, gles_scanout.hpp): the warp draws both eyes side
//    by side straight into a GBM buffer object of the KMS display's ring instead of the panel
//    textures, and a read-back reads that buffer object.
#include <EGL/egl.h>

#include <algorithm>
#include <cstddef>
#include <cstring>
#include <optional>
#include <string>
#include <vector>

#include "frame_queue.hpp"
#include "gles_context.hpp"
#include "gles_scanout.hpp"
#include "gles_scene.hpp"
#include "gles_shaders.hpp"
#include "hmdnode/render/renderer.hpp"
#include "latency_overlay.hpp"
#include "lens_pass.hpp"
#include "scene_geometry.hpp"

namespace hmdnode {
namespace {

// GL_EXT_texture_sRGB_decode and GL_EXT_clip_control tokens (not in GLES3/gl3.h).
constexpr GLenum kTextureSrgbDecode = 0x8A48;
constexpr GLenum kSkipDecode = 0x8A4A;
constexpr GLenum kLowerLeft = 0x8CA1;
constexpr GLenum kZeroToOne = 0x935F;
using ClipControlFn = void (*)(GLenum origin, GLenum depth);

using gpu::now_ns;

class GlesRenderer final : public Renderer {
  public:
    static Result<std::unique_ptr<Renderer>> create(const RendererConfig& config);
    ~GlesRenderer() override;

    Status upload(const Scene& scene) override;
    Result<RenderStats> render(const StereoViews& views, std::span<const DrawItem> items,
                               StereoImage* out_image) override;
    std::string device_name() const override { return ctx_->renderer; }
    const char* backend_name() const override { return "gles"; }
    int msaa_samples() const override { return config_.msaa_samples; }
    Status begin_frame(const StereoViews& views, std::span<const DrawItem> items) override;
    Result<bool> render_more(uint64_t max_triangles, size_t* items_rendered) override;
    Status set_warp(int panel_width, int panel_height, const DistortionMesh& left,
                    const DistortionMesh& right) override;
    Result<WarpStats> warp(const glm::dquat& delta, StereoImage* out_panel) override;
    Status set_lens_warp(int panel_width, int panel_height, const HeadsetProfile& profile) override;
    const char* lens_pass_name() const override {
        return panel_width_ <= 0 ? "" : fused_ ? "fused" : "mesh";
    }
    void set_chromatic_aberration(bool on) override { chromatic_ = on; }
    void set_latency_marker(const LatencyMarkerOverlay* overlay) override {
        marker_ = overlay ? std::optional<LatencyMarkerOverlay>(*overlay) : std::nullopt;
    }
    bool chromatic_aberration() const override {
        return panel_width_ > 0 && chromatic_ && (fused_ ? lens_chromatic_ : !mesh_mono_);
    }
    Status set_render_scale(double scale) override {
        if (Status s = gpu::check_render_scale(scale); !s) return s;
        scale_ = scale;
        return Status::success();
    }
    double render_scale() const override { return scale_; }
    const std::vector<ScanoutBuffer>& scanout_buffers() const override {
        return scanout_ ? scanout_->buffers() : Renderer::scanout_buffers();
    }
    int scanout_drawn() const override { return scanout_ ? scanout_->ring.drawn() : -1; }
    void scanout_committed(int buffer) override {
        if (scanout_) scanout_->ring.commit(buffer);
    }
    std::string scanout_describe() const override { return scanout_ ? scanout_->describe() : ""; }

  private:
    Status create_targets();
    Status create_scene_program();
    // Draws items [first, last) of the open frame into both eyes of the back slot, clearing when
    // first == 0.
    void draw_piece(size_t first, size_t last);
    Result<bool> run_piece(uint64_t max_triangles, int64_t* wait_ns, size_t* items_rendered);
    // Reads both eyes of framebuffers fb[0], fb[1] (width x height, eye e from x = x0[e]) into
    // out.
    static void read_back(const GLuint fb[2], const int x0[2], int width, int height,
                          StereoImage& out);

    RendererConfig config_;
    std::unique_ptr<gles::EglContext> ctx_;       // first: destroyed last
    std::unique_ptr<gles::GlesScanout> scanout_;  // zero-copy scan-out's ring (null: none)
    // The scene's program and its uniforms: [0] plain, [1] with the cross-fade's dither test.
    struct SceneProgram {
        gles::Program program;
        GLint view_projection = -1, world = -1, base_color_factor = -1, lightmap = -1,
              emissive = -1, dither = -1;
    } scene_program_[2];
    gles::Texture color_[2][2];  // [slot][eye], sRGB
    gles::Renderbuffer depth_[2];
    gles::Framebuffer framebuffer_[2][2];  // [slot][eye]
    // 4x MSAA: the frame is drawn into these (colour and depth per eye) and resolved into the
    // slot's colour texture by a blit after its last piece.
    gles::Renderbuffer msaa_color_[2], msaa_depth_[2];
    gles::Framebuffer msaa_framebuffer_[2];
    std::unique_ptr<gles::GlesScene> scene_;  // null before the first upload
    // Late warp: the mesh pass, or the fused pass (a program per eye and variant, [eye][mono]).
    // Checks the panel against the driver and the scan-out buffers; creates the panel textures
    // and their framebuffers.
    Status create_panel(int panel_width, int panel_height);
    gles::Program warp_program_;
    GLint u_reproject_ = -1, u_sample_rect_ = -1;
    // The mesh pass's one-sample program for chromatic-aberration correction off (a mesh with
    // aberration only).
    gles::Program warp_mono_program_;
    GLint u_mono_reproject_ = -1, u_mono_sample_rect_ = -1;
    bool mesh_mono_ = false;
    bool fused_ = false, lens_chromatic_ = false, chromatic_ = true;
    std::optional<LatencyMarkerOverlay> marker_;  // drawn by every warp (null: none)
    // Clears the marker's rects into the bound panel framebuffer of an eye whose panel starts at
    // x0 (latency_overlay.hpp; GL row 0 is the panel's top row, see read_back).
    void draw_marker(int x0) const;
    struct FusedProgram {
        gles::Program program;
        GLint reproject = -1, sample_rect = -1, origin = -1;
    };
    FusedProgram fused_program_[2][2];
    gpu::LensPassEye lens_[2];
    double scale_ = 1.0;
    gpu::ScaledViewport frame_viewport_, rendered_viewport_;
    int panel_width_ = 0, panel_height_ = 0;  // 0: no set_warp() yet
    gles::Texture panel_[2];
    gles::Framebuffer panel_framebuffer_[2];
    gles::Buffer warp_vertices_[2], warp_indices_[2];
    gles::VertexArray warp_vertex_array_[2];
    GLsizei warp_index_count_[2] = {0, 0};
    // The frame being rendered (into slot back_) and the last finished one (slot 1 - back_).
    gpu::FrameQueue frame_;
    int back_ = 0;
    glm::mat4 frame_view_projection_[2]{};
    glm::mat4 frame_projection_[2]{};     // of the open frame
    glm::mat4 rendered_projection_[2]{};  // of the finished frame
    bool rendered_ = false;
};

Result<std::unique_ptr<Renderer>> GlesRenderer::create(const RendererConfig& config) {
    if (config.eye_width < 1 || config.eye_height < 1)
        return make_error("renderer: eye buffer " + std::to_string(config.eye_width) + "x" +
                          std::to_string(config.eye_height) + " is empty");
    if (config.msaa_samples != 1 && config.msaa_samples != 4)
        return make_error("GLES: MSAA sample count " + std::to_string(config.msaa_samples) +
                          " (1 or 4)");
    auto r = std::unique_ptr<GlesRenderer>(new GlesRenderer());
    r->config_ = config;
    auto ctx = gles::EglContext::create(config.scanout ? &*config.scanout : nullptr);
    if (!ctx) return ctx.error();
    r->ctx_ = std::move(*ctx);
    if (!r->ctx_->has_extension("GL_EXT_texture_sRGB_decode"))
        return make_error(
            "GLES: the driver lacks GL_EXT_texture_sRGB_decode (the warp reads the "
            "eye buffers undecoded)");
    if (r->ctx_->has_extension("GL_EXT_clip_control")) {
        auto clip_control = reinterpret_cast<ClipControlFn>(eglGetProcAddress("glClipControlEXT"));
        if (clip_control) clip_control(kLowerLeft, kZeroToOne);
    }
    if (Status s = r->create_targets(); !s) return s.error();
    if (Status s = r->create_scene_program(); !s) return s.error();
    if (config.scanout) {
        auto scanout = gles::GlesScanout::create(*r->ctx_, *config.scanout, config.scanout_buffers);
        if (!scanout) return scanout.error();
        r->scanout_ = std::move(*scanout);
    }
    return std::unique_ptr<Renderer>(std::move(r));
}

GlesRenderer::~GlesRenderer() {
    // note: members delete their GL objects after this body; the context must be current.
    if (ctx_) (void)ctx_->make_current();
}

Status GlesRenderer::create_targets() {
    const int w = config_.eye_width, h = config_.eye_height;
    GLint max_texture = 0, max_renderbuffer = 0;
    glGetIntegerv(GL_MAX_TEXTURE_SIZE, &max_texture);
    glGetIntegerv(GL_MAX_RENDERBUFFER_SIZE, &max_renderbuffer);
    if (w > max_texture || h > max_texture || w > max_renderbuffer || h > max_renderbuffer)
        return make_error("GLES: eye buffer " + std::to_string(w) + "x" + std::to_string(h) +
                          " exceeds the driver's limit of " +
                          std::to_string(std::min(max_texture, max_renderbuffer)) +
                          " pixels per side");
    for (int e = 0; e < 2; ++e) {
        depth_[e] = gles::make<gles::Renderbuffer>(glGenRenderbuffers);
        glBindRenderbuffer(GL_RENDERBUFFER, depth_[e]);
        glRenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH_COMPONENT32F, w, h);
    }
    if (config_.msaa_samples > 1) {
        GLint max_samples = 0;
        glGetInternalformativ(GL_RENDERBUFFER, GL_SRGB8_ALPHA8, GL_SAMPLES, 1, &max_samples);
        if (max_samples < config_.msaa_samples)
            return make_error("GLES: " + std::to_string(config_.msaa_samples) +
                              "x MSAA is not offered for sRGB colour (at most " +
                              std::to_string(max_samples) + ")");
        for (int e = 0; e < 2; ++e) {
            msaa_color_[e] = gles::make<gles::Renderbuffer>(glGenRenderbuffers);
            glBindRenderbuffer(GL_RENDERBUFFER, msaa_color_[e]);
            glRenderbufferStorageMultisample(GL_RENDERBUFFER, config_.msaa_samples, GL_SRGB8_ALPHA8,
                                             w, h);
            msaa_depth_[e] = gles::make<gles::Renderbuffer>(glGenRenderbuffers);
            glBindRenderbuffer(GL_RENDERBUFFER, msaa_depth_[e]);
            glRenderbufferStorageMultisample(GL_RENDERBUFFER, config_.msaa_samples,
                                             GL_DEPTH_COMPONENT32F, w, h);
            msaa_framebuffer_[e] = gles::make<gles::Framebuffer>(glGenFramebuffers);
            glBindFramebuffer(GL_FRAMEBUFFER, msaa_framebuffer_[e]);
            glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER,
                                      msaa_color_[e]);
            glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER,
                                      msaa_depth_[e]);
            if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
                return make_error("GLES: the 4x MSAA eye framebuffer is incomplete");
        }
    }
    for (int slot = 0; slot < 2; ++slot)
        for (int e = 0; e < 2; ++e) {
            gles::Texture& color = color_[slot][e];
            color = gles::make<gles::Texture>(glGenTextures);
            glBindTexture(GL_TEXTURE_2D, color);
            glTexStorage2D(GL_TEXTURE_2D, 1, GL_SRGB8_ALPHA8, w, h);
            // The warp's sampling: bilinear over the encoded bytes, clamped (it blacks out the
            // outside itself).
            glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
            glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
            glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
            glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
            glTexParameteri(GL_TEXTURE_2D, kTextureSrgbDecode, GLint(kSkipDecode));
            gles::Framebuffer& fb = framebuffer_[slot][e];
            fb = gles::make<gles::Framebuffer>(glGenFramebuffers);
            glBindFramebuffer(GL_FRAMEBUFFER, fb);
            glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, color, 0);
            glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER,
                                      depth_[e]);
            if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
                return make_error(
                    "GLES: the eye framebuffer (sRGB colour, 32-bit float depth) "
                    "is incomplete");
        }
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    glBindTexture(GL_TEXTURE_2D, 0);
    return gles::check_gl("eye buffers");
}

Status GlesRenderer::create_scene_program() {
    for (int dithered = 0; dithered < 2; ++dithered) {
        // The dithered variant: DITHERED defined right after the #version line.
        std::string fragment = gles::kSceneFragment;
        if (dithered) fragment.insert(fragment.find('\n') + 1, "#define DITHERED 1\n");
        auto program = gles::build_program(gles::kSceneVertex, fragment.c_str(),
                                           dithered ? "scene (dithered)" : "scene");
        if (!program) return program.error();
        SceneProgram& sp = scene_program_[dithered];
        sp.program = gles::Program(*program);
        const GLuint p = sp.program;
        sp.view_projection = glGetUniformLocation(p, "u_view_projection");
        sp.world = glGetUniformLocation(p, "u_world");
        sp.base_color_factor = glGetUniformLocation(p, "u_base_color_factor");
        sp.lightmap = glGetUniformLocation(p, "u_lightmap");
        sp.emissive = glGetUniformLocation(p, "u_emissive");
        sp.dither = glGetUniformLocation(p, "u_dither");
        glUseProgram(p);
        glUniform1i(glGetUniformLocation(p, "base_color_texture"), 0);
        glUniform1i(glGetUniformLocation(p, "lightmap_texture"), 1);
    }
    glUseProgram(0);
    return gles::check_gl("scene programs");
}

Status GlesRenderer::upload(const Scene& scene) {
    if (Status s = ctx_->make_current(); !s) return s;
    auto gpu = gles::upload_scene(scene);
    if (!gpu) return gpu.error();
    scene_ = std::move(*gpu);
    return Status::success();
}

Status GlesRenderer::begin_frame(const StereoViews& views, std::span<const DrawItem> items) {
    if (Status s = ctx_->make_current(); !s) return s;
    if (Status s = frame_.begin(items, scene_ ? std::span<const gpu::MeshRange>(scene_->meshes)
                                              : std::span<const gpu::MeshRange>());
        !s)
        return s;
    for (int e = 0; e < 2; ++e) {
        frame_view_projection_[e] = views.projection[e] * views.view[e];
        frame_projection_[e] = views.projection[e];
    }
    frame_viewport_ =
        gpu::scaled_viewport(uint32_t(config_.eye_width), uint32_t(config_.eye_height), scale_);
    return Status::success();
}

void GlesRenderer::draw_piece(size_t first, size_t last) {
    // Dynamic resolution: the frame's part of the buffers only, its clear too.
    glViewport(0, 0, GLsizei(frame_viewport_.width), GLsizei(frame_viewport_.height));
    glScissor(0, 0, GLsizei(frame_viewport_.width), GLsizei(frame_viewport_.height));
    glEnable(GL_SCISSOR_TEST);
    glEnable(GL_DEPTH_TEST);
    glDepthFunc(GL_LESS);
    glDepthMask(GL_TRUE);
    glFrontFace(GL_CW);  // glTF's counter-clockwise, through Vulkan's y-down projection
    glCullFace(GL_BACK);
    const bool drawable = scene_ && scene_->vertex_array.get() != 0;
    if (drawable) glBindVertexArray(scene_->vertex_array);
    const bool msaa = config_.msaa_samples > 1;
    for (int e = 0; e < 2; ++e) {
        glBindFramebuffer(GL_FRAMEBUFFER, msaa ? msaa_framebuffer_[e] : framebuffer_[back_][e]);
        if (first == 0) {
            const glm::vec4& c = config_.clear_color;
            glClearColor(c.r, c.g, c.b, c.a);
            glClearDepthf(1.0f);
            glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
        }
        if (!drawable || first == last) continue;
        int cull = -1;  // unknown
        uint32_t bound_material = UINT32_MAX;
        int bound_program = -1;
        for (size_t i = first; i < last; ++i) {
            const DrawItem& item = frame_.items[i];
            const gpu::MeshRange& mesh = scene_->meshes[size_t(item.mesh)];
            if (mesh.primitive_count == 0) continue;
            const int program = item.dither != 0 ? 1 : 0;
            const SceneProgram& sp = scene_program_[program];
            if (program != bound_program) {
                glUseProgram(sp.program);
                glUniformMatrix4fv(sp.view_projection, 1, GL_FALSE,
                                   &frame_view_projection_[e][0][0]);
                bound_program = program;
                bound_material = UINT32_MAX;  // the uniforms are the program's own
            }
            if (program) glUniform1i(sp.dither, item.dither);
            glUniformMatrix4fv(sp.world, 1, GL_FALSE, &item.world[0][0]);
            for (uint32_t p = 0; p < mesh.primitive_count; ++p) {
                const gpu::PrimitiveRange& prim = scene_->primitives[mesh.first_primitive + p];
                const int want_cull = prim.double_sided ? 0 : 1;
                if (want_cull != cull) {
                    if (want_cull)
                        glEnable(GL_CULL_FACE);
                    else
                        glDisable(GL_CULL_FACE);
                    cull = want_cull;
                }
                if (prim.material != bound_material) {
                    const gles::GlesMaterial& m = scene_->materials[prim.material];
                    glUniform4fv(sp.base_color_factor, 1, &m.constants.base_color_factor[0]);
                    glUniform4fv(sp.lightmap, 1, &m.constants.lightmap[0]);
                    glUniform4fv(sp.emissive, 1, &m.constants.emissive[0]);
                    glActiveTexture(GL_TEXTURE0);
                    glBindTexture(GL_TEXTURE_2D, m.base_color);
                    glActiveTexture(GL_TEXTURE1);
                    glBindTexture(GL_TEXTURE_2D, m.lightmap);
                    bound_material = prim.material;
                }
                glDrawElements(GL_TRIANGLES, GLsizei(prim.index_count), GL_UNSIGNED_INT,
                               reinterpret_cast<const void*>(size_t(prim.first_index) * 4));
            }
        }
    }
    glBindVertexArray(0);
    glActiveTexture(GL_TEXTURE0);
}

Result<bool> GlesRenderer::run_piece(uint64_t max_triangles, int64_t* wait_ns,
                                     size_t* items_rendered) {
    if (Status s = ctx_->make_current(); !s) return s.error();
    if (!frame_.open) return make_error("renderer: render_more() without begin_frame()");
    const size_t last = frame_.piece_end(max_triangles);
    const bool done = last == frame_.items.size();
    draw_piece(frame_.cursor, last);
    if (done && config_.msaa_samples > 1)
        for (int e = 0; e < 2; ++e) {  // the resolve, before the warp or a read-back reads it
            glBindFramebuffer(GL_READ_FRAMEBUFFER, msaa_framebuffer_[e]);
            glBindFramebuffer(GL_DRAW_FRAMEBUFFER, framebuffer_[back_][e]);
            glBlitFramebuffer(0, 0, config_.eye_width, config_.eye_height, 0, 0, config_.eye_width,
                              config_.eye_height, GL_COLOR_BUFFER_BIT, GL_NEAREST);
        }
    const int64_t t0 = now_ns();
    glFinish();
    if (wait_ns) *wait_ns = now_ns() - t0;
    if (Status s = gles::check_gl("frame"); !s) return s.error();
    if (items_rendered) *items_rendered = last - frame_.cursor;
    frame_.cursor = last;
    if (!done) return false;
    // The frame is complete: it becomes the one warp() reads.
    frame_.open = false;
    rendered_ = true;
    for (int e = 0; e < 2; ++e) rendered_projection_[e] = frame_projection_[e];
    rendered_viewport_ = frame_viewport_;
    back_ = 1 - back_;
    return true;
}

Result<bool> GlesRenderer::render_more(uint64_t max_triangles, size_t* items_rendered) {
    return run_piece(max_triangles, nullptr, items_rendered);
}

void GlesRenderer::read_back(const GLuint fb[2], const int x0[2], int width, int height,
                             StereoImage& out) {
    glPixelStorei(GL_PACK_ALIGNMENT, 4);
    for (int e = 0; e < 2; ++e) {
        ImageRGBA8& eye = out.eye[e];
        eye.width = width;
        eye.height = height;
        eye.pixels.resize(size_t(width) * height * 4);  // allocates only when the size changes
        glBindFramebuffer(GL_READ_FRAMEBUFFER, fb[e]);
        // Row 0 is NDC y = -1: the top row of the Vulkan projections (see the note on top).
        glReadPixels(x0[e], 0, width, height, GL_RGBA, GL_UNSIGNED_BYTE, eye.pixels.data());
    }
    glBindFramebuffer(GL_READ_FRAMEBUFFER, 0);
}

Result<RenderStats> GlesRenderer::render(const StereoViews& views, std::span<const DrawItem> items,
                                         StereoImage* out_image) {
    RenderStats stats;
    const int64_t t0 = now_ns();
    if (Status s = begin_frame(views, items); !s) return s.error();
    stats.triangles = frame_.total_triangles();
    int64_t wait_ns = 0;
    auto done = run_piece(UINT64_MAX, &wait_ns, nullptr);
    if (!done) return done.error();
    const int64_t t2 = now_ns();
    if (out_image) {
        const GLuint fb[2] = {framebuffer_[1 - back_][0], framebuffer_[1 - back_][1]};
        const int x0[2] = {0, 0};
        read_back(fb, x0, config_.eye_width, config_.eye_height, *out_image);
        if (Status s = gles::check_gl("glReadPixels (eyes)"); !s) return s.error();
    }
    const int64_t t3 = now_ns();
    stats.gpu_wait_ns = wait_ns;
    stats.cpu_record_ns = t2 - t0 - wait_ns;
    stats.readback_ns = out_image ? t3 - t2 : 0;
    stats.passes = 2;
    return stats;
}

Status GlesRenderer::create_panel(int panel_width, int panel_height) {
    if (panel_width < 1 || panel_height < 1)
        return make_error("renderer: panel " + std::to_string(panel_width) + "x" +
                          std::to_string(panel_height) + " is empty");
    GLint max_texture = 0;
    glGetIntegerv(GL_MAX_TEXTURE_SIZE, &max_texture);
    if (panel_width > max_texture || panel_height > max_texture)
        return make_error("GLES: panel " + std::to_string(panel_width) + "x" +
                          std::to_string(panel_height) + " exceeds the driver's limit of " +
                          std::to_string(max_texture) + " pixels per side");
    if (scanout_ && (2 * panel_width > scanout_->width() || panel_height > scanout_->height()))
        return make_error("renderer: panel " + std::to_string(panel_width) + "x" +
                          std::to_string(panel_height) + " per eye does not fit the " +
                          std::to_string(scanout_->width()) + "x" +
                          std::to_string(scanout_->height()) + " scan-out buffers side by side");
    for (int e = 0; e < 2; ++e) {
        panel_[e] = gles::make<gles::Texture>(glGenTextures);
        glBindTexture(GL_TEXTURE_2D, panel_[e]);
        glTexStorage2D(GL_TEXTURE_2D, 1, GL_RGBA8, panel_width, panel_height);
        panel_framebuffer_[e] = gles::make<gles::Framebuffer>(glGenFramebuffers);
        glBindFramebuffer(GL_FRAMEBUFFER, panel_framebuffer_[e]);
        glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, panel_[e], 0);
        if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
            return make_error("GLES: the panel framebuffer is incomplete");
    }
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    glBindTexture(GL_TEXTURE_2D, 0);
    return Status::success();
}

Status GlesRenderer::set_lens_warp(int panel_width, int panel_height,
                                   const HeadsetProfile& profile) {
    if (Status s = ctx_->make_current(); !s) return s;
    auto setup = gpu::make_lens_pass_setup(profile, panel_width, panel_height);
    if (!setup) return setup.error();
    if (Status s = create_panel(panel_width, panel_height); !s) return s;
    panel_width_ = panel_height_ = 0;
    for (int e = 0; e < 2; ++e) {
        const gpu::LensPassEye& lens = setup->eye[e];
        lens_[e] = lens;
        for (int mono = 0; mono < 2; ++mono) {
            FusedProgram& fp = fused_program_[e][mono];
            fp = FusedProgram();
            if (!mono && !setup->chromatic) continue;
            const std::string fragment =
                "#version 300 es\n#define MODEL " + std::to_string(int(lens.model)) +
                "\n#define MONO " + std::to_string(mono) + "\n#define SHARED " +
                std::to_string(int(lens.shared)) + "\n#define CLAMP " +
                std::to_string(int(lens.clamped)) + "\n" + gles::kLensWarpFragmentBody;
            auto program =
                gles::build_program(gles::kLensWarpVertex, fragment.c_str(), "lens warp");
            if (!program) return program.error();
            fp.program = gles::Program(*program);
            const GLuint p = fp.program;
            glUseProgram(p);
            glUniform1i(glGetUniformLocation(p, "eye"), 0);
            const gpu::LensUniforms& u = lens.uniforms;
            glUniform4fv(glGetUniformLocation(p, "u_center_limit"), 3, &u.center_limit[0][0]);
            glUniform4fv(glGetUniformLocation(p, "u_coeffs"), 3, &u.coeffs[0][0]);
            glUniform4fv(glGetUniformLocation(p, "u_fov"), 1, &u.fov[0]);
            glUniform4fv(glGetUniformLocation(p, "u_panel"), 1, &u.panel[0]);
            const glm::vec3 row2(u.pre[0][2], u.pre[1][2], u.pre[2][2]), ahead(u.pre[3]);
            glUniform3fv(glGetUniformLocation(p, "u_pre_row2"), 1, &row2[0]);
            glUniform3fv(glGetUniformLocation(p, "u_ahead"), 1, &ahead[0]);
            fp.reproject = glGetUniformLocation(p, "u_reproject");
            fp.sample_rect = glGetUniformLocation(p, "u_sample_rect");
            fp.origin = glGetUniformLocation(p, "u_origin");
        }
    }
    glUseProgram(0);
    if (Status s = gles::check_gl("lens warp set-up"); !s) return s;
    fused_ = true;
    lens_chromatic_ = setup->chromatic;
    chromatic_ = true;
    panel_width_ = panel_width;
    panel_height_ = panel_height;
    return Status::success();
}

Status GlesRenderer::set_warp(int panel_width, int panel_height, const DistortionMesh& left,
                              const DistortionMesh& right) {
    if (Status s = ctx_->make_current(); !s) return s;
    const DistortionMesh* mesh[2] = {&left, &right};
    for (int e = 0; e < 2; ++e)
        if (Status s = gpu::check_distortion_mesh(*mesh[e], e); !s) return s;
    if (Status s = create_panel(panel_width, panel_height); !s) return s;
    panel_width_ = panel_height_ = 0;
    fused_ = false;
    chromatic_ = true;

    // 1. The program: one sample per pixel without chromatic aberration (as the Vulkan pass).
    const bool mono = gpu::channels_agree(left) && gpu::channels_agree(right);
    mesh_mono_ = mono;
    auto program = gles::build_program(
        gles::kWarpVertex, mono ? gles::kWarpMonoFragment : gles::kWarpFragment, "warp");
    if (!program) return program.error();
    warp_program_ = gles::Program(*program);
    u_reproject_ = glGetUniformLocation(warp_program_, "u_reproject");
    u_sample_rect_ = glGetUniformLocation(warp_program_, "u_sample_rect");
    glUseProgram(warp_program_);
    glUniform1i(glGetUniformLocation(warp_program_, "eye"), 0);
    if (!mono) {
        auto mono_program =
            gles::build_program(gles::kWarpVertex, gles::kWarpMonoFragment, "warp (no CA)");
        if (!mono_program) return mono_program.error();
        warp_mono_program_ = gles::Program(*mono_program);
        u_mono_reproject_ = glGetUniformLocation(warp_mono_program_, "u_reproject");
        u_mono_sample_rect_ = glGetUniformLocation(warp_mono_program_, "u_sample_rect");
        glUseProgram(warp_mono_program_);
        glUniform1i(glGetUniformLocation(warp_mono_program_, "eye"), 0);
    }
    glUseProgram(0);

    // 2. The meshes.
    for (int e = 0; e < 2; ++e) {
        warp_vertex_array_[e] = gles::make<gles::VertexArray>(glGenVertexArrays);
        glBindVertexArray(warp_vertex_array_[e]);
        warp_vertices_[e] = gles::make<gles::Buffer>(glGenBuffers);
        glBindBuffer(GL_ARRAY_BUFFER, warp_vertices_[e]);
        glBufferData(GL_ARRAY_BUFFER,
                     GLsizeiptr(mesh[e]->vertices.size() * sizeof(DistortionVertex)),
                     mesh[e]->vertices.data(), GL_STATIC_DRAW);
        warp_indices_[e] = gles::make<gles::Buffer>(glGenBuffers);
        glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, warp_indices_[e]);
        glBufferData(GL_ELEMENT_ARRAY_BUFFER, GLsizeiptr(mesh[e]->indices.size() * 4),
                     mesh[e]->indices.data(), GL_STATIC_DRAW);
        glEnableVertexAttribArray(gles::kNdc);
        glVertexAttribPointer(gles::kNdc, 2, GL_FLOAT, GL_FALSE, sizeof(DistortionVertex),
                              reinterpret_cast<const void*>(offsetof(DistortionVertex, ndc)));
        for (GLuint c = 0; c < 3; ++c) {
            glEnableVertexAttribArray(gles::kTangentR + c);
            glVertexAttribPointer(gles::kTangentR + c, 2, GL_FLOAT, GL_FALSE,
                                  sizeof(DistortionVertex),
                                  reinterpret_cast<const void*>(
                                      offsetof(DistortionVertex, tangent) + c * sizeof(glm::vec2)));
        }
        glBindVertexArray(0);
        warp_index_count_[e] = GLsizei(mesh[e]->indices.size());
    }
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    glBindTexture(GL_TEXTURE_2D, 0);
    if (Status s = gles::check_gl("warp set-up"); !s) return s;
    panel_width_ = panel_width;
    panel_height_ = panel_height;
    return Status::success();
}

void GlesRenderer::draw_marker(int x0) const {
    LatencyMarkerRect rects[kLatencyMarkerMaxRects];
    const size_t n = gpu::latency_overlay_rects(*marker_, panel_width_, panel_height_, rects);
    glEnable(GL_SCISSOR_TEST);
    for (size_t i = 0; i < n; ++i) {
        const LatencyMarkerRect& r = rects[i];
        glScissor(x0 + r.x, r.y, r.width, r.height);
        const float v = r.white ? 1.0f : 0.0f;
        glClearColor(v, v, v, 1.0f);
        glClear(GL_COLOR_BUFFER_BIT);
    }
    glDisable(GL_SCISSOR_TEST);
}

Result<WarpStats> GlesRenderer::warp(const glm::dquat& delta, StereoImage* out_panel) {
    if (Status s = ctx_->make_current(); !s) return s.error();
    if (panel_width_ <= 0) return make_error("renderer: warp() before set_warp()");
    if (!rendered_) return make_error("renderer: warp() before any render()");
    WarpStats stats;
    const int64_t t0 = now_ns();
    const int front = 1 - back_;
    // The targets: the panel textures, or one buffer object of the scan-out ring (eyes side by
    // side).
    GLuint target[2] = {panel_framebuffer_[0], panel_framebuffer_[1]};
    int x0[2] = {0, 0};
    const int scanout_buffer = scanout_ ? scanout_->ring.acquire() : -1;
    if (scanout_) {
        if (scanout_buffer < 0)
            return make_error("renderer: every scan-out buffer is shown or queued (" +
                              std::to_string(scanout_->ring.size()) + " buffers)");
        target[0] = target[1] = scanout_->framebuffer(scanout_buffer);
        x0[1] = panel_width_;
    }
    glDisable(GL_DEPTH_TEST);
    glDisable(GL_CULL_FACE);
    glDisable(GL_SCISSOR_TEST);
    glActiveTexture(GL_TEXTURE0);
    const glm::vec4& rect = rendered_viewport_.sample_rect;
    for (int e = 0; e < 2; ++e) {
        const glm::mat4 reproject = gpu::warp_reprojection(rendered_projection_[e], delta);
        glBindFramebuffer(GL_FRAMEBUFFER, target[e]);
        glViewport(x0[e], 0, panel_width_, panel_height_);
        glBindTexture(GL_TEXTURE_2D, color_[front][e]);
        if (fused_) {
            const FusedProgram& fp = fused_program_[e][lens_chromatic_ && chromatic_ ? 0 : 1];
            glUseProgram(fp.program);
            const glm::mat3 m = glm::mat3(gpu::lens_pass_reprojection(reproject, lens_[e]));
            glUniformMatrix3fv(fp.reproject, 1, GL_FALSE, &m[0][0]);
            glUniform4fv(fp.sample_rect, 1, &rect[0]);
            glUniform2f(fp.origin, float(x0[e]), 0.0f);
            glBindVertexArray(0);
            glDrawArrays(GL_TRIANGLES, 0, 3);
            continue;
        }
        const bool one_sample = !mesh_mono_ && !chromatic_;
        glUseProgram(one_sample ? warp_mono_program_ : warp_program_);
        glUniformMatrix4fv(one_sample ? u_mono_reproject_ : u_reproject_, 1, GL_FALSE,
                           &reproject[0][0]);
        glUniform4fv(one_sample ? u_mono_sample_rect_ : u_sample_rect_, 1, &rect[0]);
        glBindVertexArray(warp_vertex_array_[e]);
        glDrawElements(GL_TRIANGLES, warp_index_count_[e], GL_UNSIGNED_INT, nullptr);
    }
    glBindVertexArray(0);
    glBindTexture(GL_TEXTURE_2D, 0);
    if (marker_) {
        for (int e = 0; e < 2; ++e) {
            glBindFramebuffer(GL_FRAMEBUFFER, target[e]);
            draw_marker(x0[e]);
        }
    }
    const int64_t t1 = now_ns();
    glFinish();
    const int64_t t2 = now_ns();
    if (Status s = gles::check_gl("warp"); !s) return s.error();
    if (scanout_) scanout_->ring.finish(scanout_buffer);
    if (out_panel) {
        read_back(target, x0, panel_width_, panel_height_, *out_panel);
        if (Status s = gles::check_gl("glReadPixels (panel)"); !s) return s.error();
    }
    const int64_t t3 = now_ns();
    stats.cpu_record_ns = t1 - t0;
    stats.gpu_wait_ns = t2 - t1;
    stats.readback_ns = out_panel ? t3 - t2 : 0;
    return stats;
}

}  // namespace

Result<std::unique_ptr<Renderer>> create_gles_renderer(const RendererConfig& config) {
    return GlesRenderer::create(config);
}

}  // namespace hmdnode
