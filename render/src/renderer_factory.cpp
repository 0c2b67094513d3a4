// Backend selection: RendererConfig::backend, else HMDNODE_RENDERER, else Vulkan. Callers create
// renderers through create_renderer() and stay backend-agnostic. Cost: one getenv per creation.
#include <cstdlib>
#include <string>

#include "hmdnode/render/renderer.hpp"

namespace hmdnode {

const char* renderer_backend_names() {
    return "vulkan|gles";
}

Result<std::string> resolve_renderer_backend(const RendererConfig& config) {
    std::string name = config.backend;
    std::string source = "renderer backend";
    if (name.empty()) {
        const char* env = std::getenv("HMDNODE_RENDERER");
        if (env && *env) {
            name = env;
            source = "HMDNODE_RENDERER";
        } else {
            name = "vulkan";
        }
    }
    if (name != "vulkan" && name != "gles")
        return make_error(source + ": unknown renderer backend \"" + name + "\" (expected " +
                          renderer_backend_names() + ")");
    return name;
}

Result<std::unique_ptr<Renderer>> create_renderer(const RendererConfig& config) {
    auto backend = resolve_renderer_backend(config);
    if (!backend) return backend.error();
    if (*backend == "vulkan" && config.scanout)
        return make_error(
            "renderer vulkan: zero-copy scan-out needs the gles backend (dma-buf import of the "
            "Vulkan image is planned: docs/rendering.md, \"Scan-out\")");
    return *backend == "gles" ? create_gles_renderer(config) : create_vulkan_renderer(config);
}

}  // namespace hmdnode
