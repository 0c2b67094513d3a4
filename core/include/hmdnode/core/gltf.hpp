// glTF 2.0 I/O (tinygltf): the scene model from/to .gltf and .glb, with MOZ_lightmap, COLOR_0,
// TEXCOORD_1, KHR_lights_punctual and MSFT_lod (+ extras.MSFT_screencoverage, extras.geometric_error).
#pragma once

#include <filesystem>

#include "hmdnode/core/result.hpp"
#include "hmdnode/core/scene.hpp"

namespace hmdnode {

// Loads a .gltf or .glb. Errors name the file and the problem: missing, truncated, not glTF,
// a missing buffer or image, an accessor out of range, a non-triangle primitive, ...
Result<Scene> load_gltf(const std::filesystem::path& path);

// Writes a self-contained .glb (textures embedded as PNG) atomically: a temporary file beside the
// target, renamed over it only when complete.
Status save_glb(const Scene& scene, const std::filesystem::path& path);

}  // namespace hmdnode
