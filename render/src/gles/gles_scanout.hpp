// The GLES backend's scan-out ring (docs/rendering.md, "Scan-out"): GBM buffer objects allocated
// for scan-out and rendering on the KMS display's device, each an EGLImage bound to a renderbuffer
// of its own framebuffer object, so the warp draws straight into the memory the display scans out.
#pragma once

#include <EGL/egl.h>
#include <EGL/eglext.h>

#include <memory>
#include <string>
#include <vector>

#include "gles_context.hpp"
#include "hmdnode/core/scanout_buffer.hpp"
#include "scanout_ring.hpp"

struct gbm_bo;

namespace hmdnode::gles {

class GlesScanout {
  public:
    // count buffer objects of the target's size in a format its plane accepts
    // (choose_scanout_allocation), each cleared to black. The context must be current. Errors
    // name the device and the step (allocation, EGLImage, framebuffer).
    static Result<std::unique_ptr<GlesScanout>> create(EglContext& ctx,
                                                       const ScanoutTargetInfo& target, int count);
    // The context must be current.
    ~GlesScanout();
    GlesScanout(const GlesScanout&) = delete;
    GlesScanout& operator=(const GlesScanout&) = delete;

    const std::vector<ScanoutBuffer>& buffers() const { return buffers_; }
    GLuint framebuffer(int b) const { return framebuffers_[size_t(b)]; }
    int width() const { return width_; }
    int height() const { return height_; }
    std::string describe() const { return describe_; }

    gpu::ScanoutRing ring{3};

  private:
    GlesScanout() = default;
    EGLDisplay display_ = EGL_NO_DISPLAY;
    int width_ = 0, height_ = 0;
    std::vector<gbm_bo*> bos_;
    std::vector<EGLImageKHR> images_;
    std::vector<Renderbuffer> renderbuffers_;
    std::vector<Framebuffer> framebuffers_;
    std::vector<ScanoutBuffer> buffers_;
    std::string describe_;
};

}  // namespace hmdnode::gles
