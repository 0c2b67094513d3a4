// The GLES backend's EGL context and GL object handles. Off-screen only: an EGL display on Mesa's
// surfaceless platform (EGL_MESA_platform_surfaceless), else the default display with
// EGL_KHR_surfaceless_context, and an OpenGL ES 3 context made current without any surface
// (everything renders into framebuffer objects). For zero-copy scan-out the display is EGL's GBM
// platform on a GBM device made on a duplicate of the KMS display's DRM file instead (the same GEM
// handle space, so the display can make framebuffers of the GBM buffer objects). Cost: context
// creation once per renderer.
#pragma once

#include <EGL/egl.h>
#include <GLES3/gl3.h>

#include <memory>
#include <string>
#include <utility>

#include "hmdnode/core/result.hpp"
#include "hmdnode/core/scanout_buffer.hpp"

struct gbm_device;

namespace hmdnode::gles {

class EglContext {
  public:
    // Errors name the EGL step that failed and the EGL error code. scanout: EGL on GBM on that
    // DRM device (errors name the device); null: off-screen (surfaceless).
    static Result<std::unique_ptr<EglContext>> create(const ScanoutTargetInfo* scanout = nullptr);
    ~EglContext();
    EglContext(const EglContext&) = delete;
    EglContext& operator=(const EglContext&) = delete;

    // Makes the context current on the calling thread when it is not already.
    Status make_current();
    // True when the GL context offers the extension (GL_EXTENSIONS, exact name).
    bool has_extension(const char* name) const;

    std::string renderer;  // GL_RENDERER, e.g. "llvmpipe (LLVM 15.0.6, 256 bits)"
    std::string platform;  // "surfaceless", "default" or "gbm"

    EGLDisplay display() const { return display_; }
    // The GBM device (scan-out only, else null) and its backend's name ("drm").
    gbm_device* gbm() const { return gbm_; }

  private:
    EglContext() = default;
    Status open_gbm(const ScanoutTargetInfo& target);
    EGLDisplay display_ = EGL_NO_DISPLAY;
    EGLContext context_ = EGL_NO_CONTEXT;
    gbm_device* gbm_ = nullptr;
    int gbm_fd_ = -1;  // the duplicate of the display's DRM file the GBM device is made on
};

// "glDrawElements: GL_INVALID_OPERATION" when glGetError() reports one, else success; drains the
// error queue.
Status check_gl(const char* what);

// Compiles and links a program; errors name `what` and carry the driver's log.
Result<GLuint> build_program(const char* vertex_src, const char* fragment_src, const char* what);

// Owns one GL object name; Delete(GLuint) frees it. The context must be current on destruction.
template <void (*Delete)(GLuint)>
class Handle {
  public:
    Handle() = default;
    explicit Handle(GLuint name) : name_(name) {}
    ~Handle() { reset(); }
    Handle(Handle&& o) noexcept : name_(std::exchange(o.name_, 0)) {}
    Handle& operator=(Handle&& o) noexcept {
        if (this != &o) {
            reset();
            name_ = std::exchange(o.name_, 0);
        }
        return *this;
    }
    void reset() {
        if (name_) Delete(name_);
        name_ = 0;
    }
    GLuint get() const { return name_; }
    operator GLuint() const { return name_; }

  private:
    GLuint name_ = 0;
};

void delete_texture(GLuint name);
void delete_buffer(GLuint name);
void delete_framebuffer(GLuint name);
void delete_renderbuffer(GLuint name);
void delete_program(GLuint name);
void delete_vertex_array(GLuint name);
using Texture = Handle<delete_texture>;
using Buffer = Handle<delete_buffer>;
using Framebuffer = Handle<delete_framebuffer>;
using Renderbuffer = Handle<delete_renderbuffer>;
using Program = Handle<delete_program>;
using VertexArray = Handle<delete_vertex_array>;

// A new object name from one of the glGen* functions, owned: make<Texture>(glGenTextures).
template <class H>
H make(void (*gen)(GLsizei, GLuint*)) {
    GLuint name = 0;
    gen(1, &name);
    return H(name);
}

}  // namespace hmdnode::gles
