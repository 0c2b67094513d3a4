// The stereo renderer. Backend types (Vulkan) never appear here: the scene goes in as the core
// scene model, frames come out as CPU images.
//
// Threads: one thread owns a Renderer (the frame thread); no method is thread-safe.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <string>

#include <glm/glm.hpp>

#include "hmdnode/core/image.hpp"
#include "hmdnode/core/result.hpp"
#include "hmdnode/core/scene.hpp"

namespace hmdnode {

struct RendererConfig {
    int eye_width = 540;   // >= 1, pixels per eye
    int eye_height = 600;  // >= 1
    glm::vec4 clear_color{0.0f, 0.0f, 0.0f, 1.0f};
    bool validation = false;  // enable VK_LAYER_KHRONOS_validation when installed
};

// One draw: a mesh of the uploaded scene (all its primitives) with a world matrix.
struct DrawItem {
    int mesh = -1;
    glm::mat4 world{1.0f};
};

// Per-eye matrices for one stereo frame, eye 0 = left.
struct StereoViews {
    glm::mat4 view[2];
    glm::mat4 projection[2];
};

struct RenderStats {
    uint64_t triangles = 0;       // triangles submitted (both eyes share one multiview pass)
    int64_t cpu_record_ns = 0;    // recording + submission
    int64_t gpu_wait_ns = 0;      // submit to fence signalled
    int64_t readback_ns = 0;      // copy of both eyes into the output image
};

class Renderer {
public:
    virtual ~Renderer() = default;

    // Uploads every mesh, material and texture of the scene (all LOD levels), once. Replaces any
    // scene uploaded before.
    virtual Status upload(const Scene& scene) = 0;

    // Renders both eyes in one multiview pass and, when out_image is not null, reads both eyes
    // back into it. Draws exactly the given items, in the given order.
    virtual Result<RenderStats> render(const StereoViews& views, std::span<const DrawItem> items,
                                       StereoImage* out_image) = 0;

    // e.g. "llvmpipe (LLVM 15.0.6, 256 bits)".
    virtual std::string device_name() const = 0;
};

// The Vulkan backend: the first physical device that supports multiview (a GPU if present,
// else lavapipe); HMDNODE_VK_DEVICE=<substring> picks a device by name.
Result<std::unique_ptr<Renderer>> create_vulkan_renderer(const RendererConfig& config);

}  // namespace hmdnode
