// EGL set-up for off-screen OpenGL ES 3 (see gles_context.hpp) and GL helpers.
//
// note: the EGL display is never terminated: on Mesa's surfaceless platform every
// eglGetPlatformDisplay call of the process returns the same display, so terminating it would
// pull the contexts of other renderers in the process from under them. Destroying the context
// frees the renderer's GPU objects. A GBM platform display is the renderer's own (one per GBM
// device): it is terminated with the context, then the GBM device is destroyed.
#include "gles_context.hpp"

#include <EGL/eglext.h>
#include <fcntl.h>
#include <gbm.h>
#include <unistd.h>

#include <cerrno>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

namespace hmdnode::gles {
namespace {

std::string egl_error(const char* what) {
    char code[16];
    std::snprintf(code, sizeof(code), "0x%04x", unsigned(eglGetError()));
    return std::string("EGL: ") + what + " failed (error " + code + ")";
}

bool has_word(const char* list, const char* word) {
    if (!list) return false;
    const size_t n = std::strlen(word);
    for (const char* p = list; (p = std::strstr(p, word)) != nullptr; p += n)
        if ((p == list || p[-1] == ' ') && (p[n] == ' ' || p[n] == '\0')) return true;
    return false;
}

const char* gl_error_name(GLenum e) {
    switch (e) {
        case GL_INVALID_ENUM:
            return "GL_INVALID_ENUM";
        case GL_INVALID_VALUE:
            return "GL_INVALID_VALUE";
        case GL_INVALID_OPERATION:
            return "GL_INVALID_OPERATION";
        case GL_INVALID_FRAMEBUFFER_OPERATION:
            return "GL_INVALID_FRAMEBUFFER_OPERATION";
        case GL_OUT_OF_MEMORY:
            return "GL_OUT_OF_MEMORY";
        default:
            return "unknown GL error";
    }
}

Result<GLuint> compile(GLenum stage, const char* src, const char* what) {
    const GLuint shader = glCreateShader(stage);
    glShaderSource(shader, 1, &src, nullptr);
    glCompileShader(shader);
    GLint ok = GL_FALSE;
    glGetShaderiv(shader, GL_COMPILE_STATUS, &ok);
    if (ok) return shader;
    GLint len = 0;
    glGetShaderiv(shader, GL_INFO_LOG_LENGTH, &len);
    std::string log(size_t(std::max(len, 1)), '\0');
    glGetShaderInfoLog(shader, GLsizei(log.size()), nullptr, log.data());
    glDeleteShader(shader);
    return make_error(std::string("GLES: ") + what +
                      (stage == GL_VERTEX_SHADER ? " vertex" : " fragment") +
                      " shader does not compile: " + log.c_str());
}

}  // namespace

Status EglContext::open_gbm(const ScanoutTargetInfo& target) {
    const std::string where = "GLES on GBM (" + target.device + ")";
    const char* client = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
    if (!has_word(client, "EGL_KHR_platform_gbm") && !has_word(client, "EGL_MESA_platform_gbm"))
        return make_error(where + ": EGL lacks EGL_KHR_platform_gbm");
    gbm_fd_ = fcntl(target.drm_fd, F_DUPFD_CLOEXEC, 0);
    if (gbm_fd_ < 0)
        return make_error(where + ": cannot duplicate the DRM file: " + std::strerror(errno));
    gbm_ = gbm_create_device(gbm_fd_);
    if (!gbm_) return make_error(where + ": gbm_create_device failed (not a DRM device?)");
    auto get_platform_display = reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(
        eglGetProcAddress("eglGetPlatformDisplayEXT"));
    if (get_platform_display) display_ = get_platform_display(EGL_PLATFORM_GBM_KHR, gbm_, nullptr);
    if (display_ == EGL_NO_DISPLAY)
        return make_error(where + ": " + egl_error("eglGetPlatformDisplay (EGL_PLATFORM_GBM_KHR)"));
    platform = "gbm";
    return Status::success();
}

Result<std::unique_ptr<EglContext>> EglContext::create(const ScanoutTargetInfo* scanout) {
    auto c = std::unique_ptr<EglContext>(new EglContext());
    // 1. The display: GBM for scan-out; else the surfaceless platform, else the default one.
    const char* client = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
    if (scanout) {
        if (Status s = c->open_gbm(*scanout); !s) return s.error();
    } else if (has_word(client, "EGL_MESA_platform_surfaceless")) {
        auto get_platform_display = reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(
            eglGetProcAddress("eglGetPlatformDisplayEXT"));
        if (get_platform_display) {
            c->display_ =
                get_platform_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
            c->platform = "surfaceless";
        }
    }
    if (c->display_ == EGL_NO_DISPLAY) {
        c->display_ = eglGetDisplay(EGL_DEFAULT_DISPLAY);
        c->platform = "default";
    }
    if (c->display_ == EGL_NO_DISPLAY) return make_error(egl_error("eglGetDisplay"));
    EGLint major = 0, minor = 0;
    if (!eglInitialize(c->display_, &major, &minor))
        return make_error((scanout ? "GLES on GBM (" + scanout->device + "): " : std::string()) +
                          egl_error("eglInitialize (no EGL driver?)"));
    if (!has_word(eglQueryString(c->display_, EGL_EXTENSIONS), "EGL_KHR_surfaceless_context"))
        return make_error("EGL: the display lacks EGL_KHR_surfaceless_context");
    if (!eglBindAPI(EGL_OPENGL_ES_API)) return make_error(egl_error("eglBindAPI (OpenGL ES)"));

    // 2. An OpenGL ES 3 context (no surface: the config only states the API).
    const EGLint config_attribs[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_ES3_BIT, EGL_SURFACE_TYPE, 0,
                                     EGL_NONE};
    EGLConfig config = nullptr;
    EGLint count = 0;
    if (!eglChooseConfig(c->display_, config_attribs, &config, 1, &count) || count < 1)
        return make_error("EGL: no config with OpenGL ES 3 (EGL_OPENGL_ES3_BIT)");
    const EGLint context_attribs[] = {EGL_CONTEXT_MAJOR_VERSION, 3, EGL_CONTEXT_MINOR_VERSION, 0,
                                      EGL_NONE};
    c->context_ = eglCreateContext(c->display_, config, EGL_NO_CONTEXT, context_attribs);
    if (c->context_ == EGL_NO_CONTEXT)
        return make_error(egl_error("eglCreateContext (OpenGL ES 3.0)"));
    if (Status s = c->make_current(); !s) return s.error();
    const auto* name = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
    c->renderer = name ? name : "unknown";
    return c;
}

EglContext::~EglContext() {
    if (context_ != EGL_NO_CONTEXT) {
        if (eglGetCurrentContext() == context_)
            eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
        eglDestroyContext(display_, context_);
    }
    if (gbm_) {
        if (display_ != EGL_NO_DISPLAY) eglTerminate(display_);
        gbm_device_destroy(gbm_);
    }
    if (gbm_fd_ >= 0) close(gbm_fd_);
}

Status EglContext::make_current() {
    if (eglGetCurrentContext() == context_) return Status::success();
    if (!eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, context_))
        return make_error(egl_error("eglMakeCurrent (surfaceless)"));
    return Status::success();
}

bool EglContext::has_extension(const char* name) const {
    GLint n = 0;
    glGetIntegerv(GL_NUM_EXTENSIONS, &n);
    for (GLint i = 0; i < n; ++i) {
        const auto* e = reinterpret_cast<const char*>(glGetStringi(GL_EXTENSIONS, GLuint(i)));
        if (e && std::strcmp(e, name) == 0) return true;
    }
    return false;
}

Status check_gl(const char* what) {
    const GLenum first = glGetError();
    if (first == GL_NO_ERROR) return Status::success();
    while (glGetError() != GL_NO_ERROR) {
    }
    return make_error(std::string("GLES: ") + what + ": " + gl_error_name(first));
}

Result<GLuint> build_program(const char* vertex_src, const char* fragment_src, const char* what) {
    auto vs = compile(GL_VERTEX_SHADER, vertex_src, what);
    if (!vs) return vs.error();
    auto fs = compile(GL_FRAGMENT_SHADER, fragment_src, what);
    if (!fs) {
        glDeleteShader(*vs);
        return fs.error();
    }
    const GLuint program = glCreateProgram();
    glAttachShader(program, *vs);
    glAttachShader(program, *fs);
    glLinkProgram(program);
    glDeleteShader(*vs);
    glDeleteShader(*fs);
    GLint ok = GL_FALSE;
    glGetProgramiv(program, GL_LINK_STATUS, &ok);
    if (ok) return program;
    GLint len = 0;
    glGetProgramiv(program, GL_INFO_LOG_LENGTH, &len);
    std::string log(size_t(std::max(len, 1)), '\0');
    glGetProgramInfoLog(program, GLsizei(log.size()), nullptr, log.data());
    glDeleteProgram(program);
    return make_error(std::string("GLES: ") + what + " program does not link: " + log.c_str());
}

void delete_texture(GLuint name) {
    glDeleteTextures(1, &name);
}
void delete_buffer(GLuint name) {
    glDeleteBuffers(1, &name);
}
void delete_framebuffer(GLuint name) {
    glDeleteFramebuffers(1, &name);
}
void delete_renderbuffer(GLuint name) {
    glDeleteRenderbuffers(1, &name);
}
void delete_program(GLuint name) {
    glDeleteProgram(name);
}
void delete_vertex_array(GLuint name) {
    glDeleteVertexArrays(1, &name);
}

}  // namespace hmdnode::gles
