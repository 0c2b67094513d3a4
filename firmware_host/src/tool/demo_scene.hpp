// The bundled demo scene's generator (`hmdnode scene demo`, built into the hmdnode tool only): a
// lit 6 m x 3 m x 6 m room with the Stanford bunny, Keenan Crane's spot and a sphere on stands, LOD
// chains (QEM simplification) and a path-traced lightmap bake.
// docs/demo-scene.md describes what is in it and how it is made.
//
// Threads: runs entirely on the calling thread. Deterministic: the same data gives the same bytes.
#pragma once

#include <filesystem>
#include <string>

#include "hmdnode/core/result.hpp"
#include "hmdnode/core/scene.hpp"

namespace hmdnode {

// Builds the scene in memory from data_dir/meshes/{stanford-bunny,spot}.obj, LOD chains and bake
// included. out_summary (optional) receives a human-readable summary: objects, levels with
// triangles and errors, the lightmap, the lights and the time each step took.
Result<Scene> make_demo_scene(const std::filesystem::path& data_dir, std::string* out_summary);

// make_demo_scene, then save_glb to out_glb (atomically: nothing is left behind on failure).
Status build_demo_scene(const std::filesystem::path& data_dir, const std::filesystem::path& out_glb,
                        std::string* out_summary);

}  // namespace hmdnode
