// The heavy LOD scene's generator (`hmdnode scene stress`, built into the hmdnode tool only): a
// field of hundreds of LOD objects (the bundled bunny, spot and fandisk, each with a QEM chain as
// `hmdnode lod` makes it) around the viewer, vertex-lit by a converged sun-and-sky bake, tens of
// millions of triangles at full detail (docs/lod-selection.md, "Heavy scene").
//
// Threads: the bake uses every core; the rest runs on the calling thread. Deterministic.
#pragma once

#include <filesystem>
#include <string>

#include "hmdnode/core/result.hpp"
#include "hmdnode/core/scene.hpp"

namespace hmdnode {

struct StressSceneOptions {
    int copies = 100;          // groups of 3 bunnies, a spot and a fandisk (5 objects each)
    int vertex_samples = 256;  // bake paths per vertex
    uint64_t seed = 1;         // placement
};

// Builds the scene from data_dir/meshes/{stanford-bunny,spot,fandisk}.obj. out_summary
// (optional) receives objects, triangles at full detail and at the coarsest levels, the bake and
// the time each step took.
Result<Scene> make_stress_scene(const std::filesystem::path& data_dir,
                                const StressSceneOptions& options, std::string* out_summary);

}  // namespace hmdnode
