// Scan-out buffers for the GLES backend (gles_scanout.hpp), after kmscube's and Weston's GBM
// renderers, with the ring kept by the renderer instead of a gbm_surface (render/scanout_ring.hpp)
// so the number of buffers and when one is drawn again are ours:
//  1. the format and modifiers from the display plane's list (choose_scanout_allocation);
//  2. gbm_bo_create_with_modifiers2 with the plane's modifiers where it lists any, else (or when
//     that fails) gbm_bo_create with GBM_BO_USE_SCANOUT | GBM_BO_USE_RENDERING (the implicit
//     layout; what kms_swrast, Mesa's software path on bochs-drm or virtio-gpu, allocates: a
//     linear dumb buffer);
//  3. an EGLImage of each buffer object: EGL_NATIVE_PIXMAP_KHR with the gbm_bo itself (Mesa's GBM
//     platform), else a dma-buf import (EGL_EXT_image_dma_buf_import);
//  4. glEGLImageTargetRenderbufferStorageOES into a renderbuffer, one framebuffer object each.
// GL's framebuffer row 0 is the buffer's first row in memory, the panel's top row (the Vulkan
// projections' NDC y = -1, see gles_renderer.cpp), so the scanned-out image is upright.
// Cost: count buffers of width x height x 4 bytes, once; nothing per frame.
#include "gles_scanout.hpp"

#include <GLES2/gl2ext.h>
#include <gbm.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>

#include "hmdnode/render/scanout.hpp"

namespace hmdnode::gles {
namespace {

std::string egl_code() {
    char code[16];
    std::snprintf(code, sizeof code, "0x%04x", unsigned(eglGetError()));
    return code;
}

}  // namespace

Result<std::unique_ptr<GlesScanout>> GlesScanout::create(EglContext& ctx,
                                                         const ScanoutTargetInfo& target,
                                                         int count) {
    const std::string where = "scan-out on " + target.device;
    if (!ctx.gbm()) return make_error(where + ": the renderer is not on EGL's GBM platform");
    if (count < 3)
        return make_error(where + ": " + std::to_string(count) +
                          " buffers (at least 3: one shown, one queued, one drawn into)");
    if (target.width < 2 || target.height < 1)
        return make_error(where + ": mode " + std::to_string(target.width) + "x" +
                          std::to_string(target.height) + " is too small");
    auto alloc = choose_scanout_allocation(target.formats, target.device);
    if (!alloc) return alloc.error();
    auto image_target = reinterpret_cast<PFNGLEGLIMAGETARGETRENDERBUFFERSTORAGEOESPROC>(
        eglGetProcAddress("glEGLImageTargetRenderbufferStorageOES"));
    auto create_image =
        reinterpret_cast<PFNEGLCREATEIMAGEKHRPROC>(eglGetProcAddress("eglCreateImageKHR"));
    if (!image_target || !create_image || !ctx.has_extension("GL_OES_EGL_image"))
        return make_error(where + ": the driver lacks GL_OES_EGL_image / EGL_KHR_image_base");

    auto s = std::unique_ptr<GlesScanout>(new GlesScanout());
    s->display_ = ctx.display();
    s->width_ = target.width;
    s->height_ = target.height;
    s->ring = gpu::ScanoutRing(count);
    const uint32_t usage = GBM_BO_USE_SCANOUT | GBM_BO_USE_RENDERING;
    bool explicit_modifiers = false, pixmap = true;
    for (int i = 0; i < count; ++i) {
        gbm_bo* bo = nullptr;
        if (!alloc->modifiers.empty()) {
            bo = gbm_bo_create_with_modifiers2(
                ctx.gbm(), uint32_t(target.width), uint32_t(target.height), alloc->fourcc,
                alloc->modifiers.data(), unsigned(alloc->modifiers.size()), usage);
            explicit_modifiers = bo != nullptr;
        }
        if (!bo && alloc->implicit_ok)
            bo = gbm_bo_create(ctx.gbm(), uint32_t(target.width), uint32_t(target.height),
                               alloc->fourcc, usage);
        if (!bo)
            return make_error(where + ": gbm_bo_create " + std::to_string(target.width) + "x" +
                              std::to_string(target.height) + " " + fourcc_text(alloc->fourcc) +
                              " for scan-out and rendering failed (" + std::strerror(errno) + ")");
        s->bos_.push_back(bo);

        ScanoutBuffer b;
        b.width = target.width;
        b.height = target.height;
        b.fourcc = gbm_bo_get_format(bo);
        b.modifier = explicit_modifiers ? gbm_bo_get_modifier(bo) : kDrmModInvalid;
        b.planes = gbm_bo_get_plane_count(bo);
        if (b.planes < 1 || b.planes > 4)
            return make_error(where + ": a buffer object with " + std::to_string(b.planes) +
                              " planes");
        for (int p = 0; p < b.planes; ++p) {
            b.handles[p] = gbm_bo_get_handle_for_plane(bo, p).u32;
            b.pitches[p] = gbm_bo_get_stride_for_plane(bo, p);
            b.offsets[p] = gbm_bo_get_offset(bo, p);
        }

        // The EGLImage: the buffer object itself, else its dma-buf.
        EGLImageKHR image = EGL_NO_IMAGE_KHR;
        if (pixmap)
            image = create_image(s->display_, EGL_NO_CONTEXT, EGL_NATIVE_PIXMAP_KHR,
                                 static_cast<EGLClientBuffer>(bo), nullptr);
        std::string why = image == EGL_NO_IMAGE_KHR ? "pixmap " + egl_code() : "";
        if (image == EGL_NO_IMAGE_KHR) {
            pixmap = false;
            const int fd = gbm_bo_get_fd(bo);
            if (fd >= 0 && b.planes == 1) {
                std::vector<EGLint> attrs = {EGL_WIDTH,
                                             b.width,
                                             EGL_HEIGHT,
                                             b.height,
                                             EGL_LINUX_DRM_FOURCC_EXT,
                                             EGLint(b.fourcc),
                                             EGL_DMA_BUF_PLANE0_FD_EXT,
                                             fd,
                                             EGL_DMA_BUF_PLANE0_OFFSET_EXT,
                                             EGLint(b.offsets[0]),
                                             EGL_DMA_BUF_PLANE0_PITCH_EXT,
                                             EGLint(b.pitches[0])};
                if (b.modifier != kDrmModInvalid) {
                    attrs.insert(
                        attrs.end(),
                        {EGL_DMA_BUF_PLANE0_MODIFIER_LO_EXT, EGLint(b.modifier & 0xffffffffu),
                         EGL_DMA_BUF_PLANE0_MODIFIER_HI_EXT, EGLint(b.modifier >> 32)});
                }
                attrs.push_back(EGL_NONE);
                image = create_image(s->display_, EGL_NO_CONTEXT, EGL_LINUX_DMA_BUF_EXT, nullptr,
                                     attrs.data());
                why += ", dma-buf " + egl_code();
            }
            if (fd >= 0) close(fd);
        }
        if (image == EGL_NO_IMAGE_KHR)
            return make_error(where + ": no EGLImage of a GBM buffer object (" + why + ")");
        s->images_.push_back(image);

        s->renderbuffers_.push_back(make<Renderbuffer>(glGenRenderbuffers));
        glBindRenderbuffer(GL_RENDERBUFFER, s->renderbuffers_.back());
        image_target(GL_RENDERBUFFER, static_cast<GLeglImageOES>(image));
        s->framebuffers_.push_back(make<Framebuffer>(glGenFramebuffers));
        glBindFramebuffer(GL_FRAMEBUFFER, s->framebuffers_.back());
        glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER,
                                  s->renderbuffers_.back());
        if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
            return make_error(where + ": the framebuffer of a GBM buffer object is incomplete");
        glViewport(0, 0, target.width, target.height);
        glClearColor(0.0f, 0.0f, 0.0f, 1.0f);
        glClear(GL_COLOR_BUFFER_BIT);
        s->buffers_.push_back(b);
    }
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    glBindRenderbuffer(GL_RENDERBUFFER, 0);
    glFinish();
    if (Status st = check_gl("scan-out buffers"); !st)
        return make_error(where + ": " + st.error().message);
    const ScanoutBuffer& b0 = s->buffers_.front();
    char mod[48];
    if (b0.modifier == kDrmModInvalid)
        std::snprintf(mod, sizeof mod, "implicit modifier");
    else
        std::snprintf(mod, sizeof mod, "modifier 0x%llx",
                      static_cast<unsigned long long>(b0.modifier));
    s->describe_ = std::string("GBM (") + gbm_device_get_backend_name(ctx.gbm()) + ") " +
                   std::to_string(count) + " buffers " + std::to_string(b0.width) + "x" +
                   std::to_string(b0.height) + " " + fourcc_text(b0.fourcc) + " " + mod +
                   ", pitch " + std::to_string(b0.pitches[0]) + ", EGLImage from " +
                   (pixmap ? "the gbm_bo" : "its dma-buf");
    return s;
}

GlesScanout::~GlesScanout() {
    framebuffers_.clear();
    renderbuffers_.clear();
    auto destroy_image =
        reinterpret_cast<PFNEGLDESTROYIMAGEKHRPROC>(eglGetProcAddress("eglDestroyImageKHR"));
    for (EGLImageKHR image : images_)
        if (destroy_image) destroy_image(display_, image);
    for (gbm_bo* bo : bos_) gbm_bo_destroy(bo);
}

}  // namespace hmdnode::gles
