// glTF 2.0 I/O (tinygltf): the scene model from/to .gltf and .glb, with MOZ_lightmap, COLOR_0,
// TEXCOORD_1, KHR_lights_punctual and MSFT_lod (+ extras.MSFT_screencoverage,
// extras.geometric_error).
#pragma once

#include <filesystem>

#include "hmdnode/core/result.hpp"
#include "hmdnode/core/scene.hpp"

namespace hmdnode {

// Loads a .gltf or .glb (told apart by the magic bytes "glTF", not the extension). Errors start
// with the file's path and name the problem: missing, empty, truncated (declared vs actual
// length), not glTF, a missing buffer or image (its uri), an accessor out of range, a
// non-triangle primitive (POINTS/LINES: mesh and primitive named; strips and fans become lists),
// an index out of range, a node cycle, a non-finite position, a bad MSFT_lod id. Never throws.
// Missing normals are computed (area-weighted); textures are decoded to RGBA8; a node matrix is
// decomposed into TRS; with no "scenes", every parentless node is a root.
// Thread: any; touches only the given file and the buffers and images it names.
Result<Scene> load_gltf(const std::filesystem::path& path);

// Writes a self-contained .glb (textures embedded as PNG) atomically: a temporary file beside the
// target, renamed over it only when complete. A scene glTF cannot hold (index or reference out of
// range, attribute counts that differ, a node graph that is not a forest, an empty mesh) is an
// error and writes nothing. Thread: any.
Status save_glb(const Scene& scene, const std::filesystem::path& path);

}  // namespace hmdnode
