// The stereo renderer, with two backends: Vulkan and OpenGL ES 3 on EGL. Backend types (Vulkan,
// EGL, GL) never appear here: the scene goes in as the core scene model, frames come out as CPU
// images. create_renderer() picks the backend (RendererConfig::backend, HMDNODE_RENDERER).
//
// Threads: one thread owns a Renderer (the frame thread); no method is thread-safe.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

#include "hmdnode/core/image.hpp"
#include "hmdnode/core/latency_marker.hpp"
#include "hmdnode/core/result.hpp"
#include "hmdnode/core/scanout_buffer.hpp"
#include "hmdnode/core/scene.hpp"
#include "hmdnode/render/lens.hpp"

namespace hmdnode {

struct RendererConfig {
    int eye_width = 540;                            // >= 1, pixels per eye
    int eye_height = 600;                           // >= 1
    glm::vec4 clear_color{0.0f, 0.0f, 0.0f, 1.0f};  // linear; encoded to sRGB like shaded pixels
    bool validation = false;  // enable VK_LAYER_KHRONOS_validation when installed (else ignored)
    // "vulkan" or "gles"; empty: the HMDNODE_RENDERER environment variable, else "vulkan".
    std::string backend;
    // Samples per pixel of the eye buffers: 1, or 4 (MSAA, resolved before the warp reads them;
    // an Error of creation where the device cannot).
    int msaa_samples = 1;
    // Zero-copy scan-out (GLES only; render/scanout.hpp): the backend renders on EGL's GBM
    // platform on this DRM device and warp() draws the panel into a ring of `scanout_buffers`
    // GBM buffer objects of the target's size (both eyes side by side) that the display flips.
    std::optional<ScanoutTargetInfo> scanout;
    int scanout_buffers = 3;  // >= 3: one shown, one queued, one drawn into
};

// Largest |DrawItem::dither|: the screen-door mask is a 4x4 tile of ranks 0..15.
inline constexpr int kMaxDither = 15;

// One draw: a mesh of the uploaded scene (all its primitives) with a world matrix.
struct DrawItem {
    int mesh = -1;
    glm::mat4 world{1.0f};
    // The LOD cross-fade's screen-door mask (docs/lod-selection.md): 0 draws every pixel; +k
    // (1..kMaxDither) only the pixels whose rank in a 4x4 ordered-dither tile is < k (k/16 of
    // them), -k exactly the others. Two items with +k and -k cover each pixel exactly once.
    int dither = 0;
};

// Per-eye matrices for one stereo frame, eye 0 = left.
struct StereoViews {
    glm::mat4 view[2];
    glm::mat4 projection[2];
};

struct RenderStats {
    uint64_t triangles = 0;     // triangles of the drawn items, counted once for both eyes
    int64_t cpu_record_ns = 0;  // recording + submission
    int64_t gpu_wait_ns = 0;    // submit to fence signalled
    int64_t readback_ns = 0;    // copy of both eyes into the output image (0 without one)
    int passes = 0;             // render passes: 1 = both eyes in one multiview pass,
                                // 2 = one pass per eye (Vulkan's fallback for a broken driver
                                // multiview; always on the GLES backend)
};

struct WarpStats {
    int64_t cpu_record_ns = 0;  // recording + submission
    int64_t gpu_wait_ns = 0;    // submit to fence signalled
    int64_t readback_ns = 0;    // copy of the panel image into the output (0 without one)
};

// The latency marker the lens pass draws (core/latency_marker.hpp; docs/latency.md, "The
// observer"): after the lens pass, into the panel image of both eyes, top-left at (x, y) of each
// eye's panel (rows top to bottom), cell_px panel pixels per cell (>= 1); the parts outside the
// panel are clipped. Pure black and white: the same bytes on every backend and pass, and exactly
// draw_latency_marker()'s.
struct LatencyMarkerOverlay {
    LatencyMarkerPayload payload;
    int x = 0, y = 0;
    int cell_px = 4;
};

// Where the node puts the marker on a panel of panel_width x panel_height per eye: centred
// horizontally, its top a tenth of the panel down (inside the lens's visible area near its top
// edge, where a camera looking through the lens sees it; docs/latency.md).
LatencyMarkerOverlay default_latency_marker_overlay(int panel_width, int panel_height, int cell_px);

class Renderer {
  public:
    virtual ~Renderer() = default;

    // Uploads every mesh, material and texture of the scene (all LOD levels), once. Replaces any
    // scene uploaded before (on failure the previous scene stays). Errors name the malformed
    // mesh, primitive, material or texture, or the GPU failure. Allocates and blocks: not for the
    // frame path.
    //
    // Shading (docs/formats.md): albedo = base_color_factor * base colour texture (sRGB-decoded,
    // TEXCOORD_0) * COLOR_0; with a lightmap, colour = albedo.rgb * E / pi where E = lightmap
    // texel (linear, TEXCOORD_1 when lightmap.tex_coord == 1, else TEXCOORD_0) * intensity;
    // without one, colour = albedo.rgb * _LIGHT_0 / pi (Primitive::light, baked vertex
    // irradiance; factor 1 without it: unlit). Alpha is 1. Output pixels are sRGB-encoded.
    // Single-sided materials cull back faces (glTF: counter-clockwise is front).
    virtual Status upload(const Scene& scene) = 0;

    // Renders both eyes (one multiview pass; see RenderStats::passes) and, when out_image is not
    // null, reads both eyes back into it (eye[0] = left, eye[1] = right, rows top to bottom; the
    // vectors are resized only when the eye size changes). Draws exactly the given items, in the
    // given order, and waits for the GPU. A DrawItem whose mesh is not in the uploaded scene, or
    // whose |dither| exceeds kMaxDither, is an Error (nothing is drawn). After a lost device or a
    // GPU timeout every later call returns an Error.
    virtual Result<RenderStats> render(const StereoViews& views, std::span<const DrawItem> items,
                                       StereoImage* out_image) = 0;

    // A frame in pieces, so that a re-warp of the previous frame can run between them on one
    // queue: begin_frame() starts a frame into the back eye buffers (the last finished frame
    // stays what warp() reads); render_more() records and runs the next draws, at least one item
    // and then items while the piece's triangles stay within max_triangles, and waits; it returns
    // true once the frame is complete, which then becomes the frame warp() reads. render() is
    // begin_frame() + render_more(all) + the read-back. A DrawItem whose mesh is not in the
    // uploaded scene is an Error of begin_frame(); begin_frame() while a frame is unfinished
    // drops it (a failing one too). Each piece after the first costs a render pass that loads the
    // attachments.
    virtual Status begin_frame(const StereoViews& views, std::span<const DrawItem> items) = 0;
    // items_rendered (optional) receives the number of draw items of the piece.
    virtual Result<bool> render_more(uint64_t max_triangles, size_t* items_rendered = nullptr) = 0;

    // Sets up the late-warp + lens-distortion pass: the panel size per eye and one distortion mesh
    // per eye (lens.hpp; a mesh whose tangents span the eye buffer's field of view linearly gives a
    // warp without distortion). Allocates and blocks: not for the frame path. Replaces an earlier
    // set-up. Errors: an empty or malformed mesh, a panel beyond the device's limits.
    virtual Status set_warp(int panel_width, int panel_height, const DistortionMesh& left,
                            const DistortionMesh& right) = 0;

    // The fused late-warp + lens pass instead (render/src/lens_pass.hpp): one full-screen pass per
    // eye that evaluates the profile's lens model per panel pixel (no mesh, no interpolation
    // error), reprojects rotationally and corrects chromatic aberration, at about the cost of its
    // three bilinear samples. Same contract as set_warp(), which it replaces (and the other way
    // round). Errors: an empty panel, a profile validate_headset_profile() refuses, a panel beyond
    // the device's limits.
    virtual Status set_lens_warp(int panel_width, int panel_height,
                                 const HeadsetProfile& profile) = 0;
    // "mesh" (set_warp), "fused" (set_lens_warp), or "" before either.
    virtual const char* lens_pass_name() const = 0;
    // Chromatic-aberration correction (on after set_warp and set_lens_warp): off, one sample per
    // pixel through the green channel's lens (or mesh tangents) serves all three colours (the
    // pixel-cost ladder's last step). No effect where the lens has no aberration. Between frames
    // only; allocates nothing.
    virtual void set_chromatic_aberration(bool on) = 0;
    virtual bool chromatic_aberration() const = 0;  // true only where the pass corrects it now

    // Dynamic resolution: frames begun from now on render into the top-left scale x scale of the
    // eye buffers (per axis, (0, 1], rounded to whole pixels, at least one) with the same field of
    // view, and the warp samples that part; the finished frame keeps the scale it was rendered
    // at, so a re-warp stays right. render()'s read-back returns the whole buffers. Allocates
    // nothing. Errors: a scale outside (0, 1].
    virtual Status set_render_scale(double scale) = 0;
    virtual double render_scale() const = 0;

    // Late warp: resamples the eye buffers of the last render() through the distortion meshes
    // into the panel image, for a head whose orientation differs from the rendered one by
    // `delta` = inverse(rendered orientation) * displayed orientation (rotational reprojection, per
    // pixel exact for the rotation; colour channels sampled separately through their own lens
    // tangents), and reads the panel image back into out_panel when not null. May run several
    // times on the same eye buffers (a re-warp of the previous frame for a vsync that got no new
    // one). Waits for the GPU. Errors: no set_warp() yet, no render() yet, a lost device.
    virtual Result<WarpStats> warp(const glm::dquat& delta, StereoImage* out_panel) = 0;

    // The latency marker every later warp() draws (null: none, the default; the panel is then
    // exactly what the lens pass drew). Between warps only; allocates nothing.
    virtual void set_latency_marker(const LatencyMarkerOverlay* overlay) = 0;

    // e.g. "llvmpipe (LLVM 15.0.6, 256 bits)".
    virtual std::string device_name() const = 0;
    // "vulkan" or "gles" (what reports call renderer_backend).
    virtual const char* backend_name() const = 0;
    // Samples per eye-buffer pixel (RendererConfig::msaa_samples).
    virtual int msaa_samples() const { return 1; }

    // Zero-copy scan-out (RendererConfig::scanout; empty / -1 / no-op without it). The ring's
    // buffer objects, described for the display's framebuffers (GEM handles on its DRM file);
    // each warp() draws the panel into one that is neither shown nor queued (both eyes side by
    // side, eye e at x = e * panel width; out_panel, when given, is read back from it), and
    // finishes it before it returns.
    virtual const std::vector<ScanoutBuffer>& scanout_buffers() const {
        static const std::vector<ScanoutBuffer> none;
        return none;
    }
    // The buffer the newest warp() drew and nothing has committed yet: what the display flips.
    virtual int scanout_drawn() const { return -1; }
    // The display committed a flip to `buffer` (scanout_drawn()), after the flip before it
    // completed: that one's buffer is on screen, the one shown before may be drawn again.
    virtual void scanout_committed(int buffer) { (void)buffer; }
    // "GBM (kms_swrast) XR24 implicit modifier, 3 buffers" ("" without scan-out).
    virtual std::string scanout_describe() const { return ""; }
};

// The backend names create_renderer() accepts, for usage texts: "vulkan|gles".
const char* renderer_backend_names();

// The backend config.backend names, else HMDNODE_RENDERER's, else "vulkan". Errors: an unknown
// name, saying where it came from and what is accepted.
Result<std::string> resolve_renderer_backend(const RendererConfig& config);

// The backend resolve_renderer_backend() names, created with the config.
Result<std::unique_ptr<Renderer>> create_renderer(const RendererConfig& config);

// The Vulkan backend: the first physical device with Vulkan 1.1 and the multiview feature (a GPU if
// present, else lavapipe); HMDNODE_VK_DEVICE=<substring> picks a device by name. Headless: no
// window-system extension is used. Errors: no Vulkan driver, no usable device (with the reason
// per device), an eye buffer beyond the device's limits, out of memory. Creation renders one probe
// frame to check the driver's multiview; HMDNODE_VK_MULTIVIEW=1 forces the multiview pass, =0 one
// pass per eye (see render/src/vulkan/vulkan_renderer.cpp).
Result<std::unique_ptr<Renderer>> create_vulkan_renderer(const RendererConfig& config);

// The OpenGL ES 3 backend on EGL, off-screen: Mesa's surfaceless platform
// (EGL_MESA_platform_surfaceless) when offered, else the default display with
// EGL_KHR_surfaceless_context; rendering into framebuffer objects, one pass per eye. Same
// shading, stereo, late warp and read-back as the Vulkan backend
// (render/src/gles/gles_renderer.cpp; where the pixels may differ: docs/rendering.md). Needs
// GL_EXT_texture_sRGB_decode; uses GL_EXT_clip_control (Vulkan's depth range) where offered. With
// RendererConfig::scanout it runs on EGL's GBM platform (EGL_KHR_platform_gbm) on that DRM device
// instead and allocates the scan-out ring (render/scanout.hpp). Errors: no EGL display, no OpenGL
// ES 3 context, a shader the driver rejects, an eye buffer beyond the driver's limits; with
// scan-out, GBM or EGL failing on the device (the error names it), no format the plane accepts.
Result<std::unique_ptr<Renderer>> create_gles_renderer(const RendererConfig& config);

}  // namespace hmdnode
