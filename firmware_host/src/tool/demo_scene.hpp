// The bundled demo scene's generator (`hmdnode scene demo`, built into the hmdnode tool only): a
// lit 6 m x 3 m x 6 m room with the Stanford bunny, Keenan Crane's spot and a sphere on stands, LOD
// chains (QEM simplification) and a path-traced lightmap bake.
// docs/demo-scene.md describes what is in it and how it is made.
//
// Threads: runs entirely on the calling thread. Deterministic: the same data gives the same bytes.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "hmdnode/bake/bake.hpp"
#include "hmdnode/core/result.hpp"
#include "hmdnode/core/scene.hpp"

namespace hmdnode {

// The bake settings of the demo scene (docs/baking.md "Demo scene"), modest so that the
// build-time generation stays a matter of seconds: 32 paths per texel with the indirect part's
// fireflies clamped (factor 8), the direct light filtered by 5 edge-aware A-trous passes and the
// indirect light by 5 variance-guided ones, 64 paths per vertex sample (with 2 the LOD
// objects' per-vertex light glittered, each level with its own noise), 2 bounces, 4 validity rays,
// the lightmap's 8-bit range set by the 98th percentile texel (the insides of the lamp shades
// clamp). Shared with bench/bake_noise_bench.cpp, which rebakes the room with them.
inline BakeOptions demo_bake_options() {
    BakeOptions o;
    o.samples = 32;
    o.firefly_factor = 8.0f;
    o.vertex_samples = 64;
    o.bounces = 2;
    o.validity_rays = 4;
    o.denoise_iterations = 5;
    o.indirect_denoise_iterations = 5;
    o.intensity_percentile = 0.98;
    o.seed = 1;
    return o;
}

// Translates a primitive so that its bounding box's bottom centre is at the origin; returns the
// box size.
glm::vec3 stand_on_origin(Primitive* p);

// An LOD chain as `hmdnode lod` makes it: levels[0] = base, then one QEM level per target
// triangle count (lod/simplify.hpp; vertex clustering if QEM fails), errors[k] = level k's
// measured Hausdorff distance to level 0 (mesh units; 0 for level 0).
struct LodLevels {
    std::vector<Primitive> levels;
    std::vector<double> errors;
    double diameter_m = 0.0;  // of base's bounding box, mesh units
};
LodLevels make_lod_levels(const Primitive& base, const std::vector<size_t>& targets);
// MSFT_screencoverage for a chain: level k+1 from where its error projects under 1/1000 of the
// screen height; the last level down to 0.
std::vector<double> lod_screen_coverage(const LodLevels& chain);

// Builds the scene in memory from data_dir/meshes/{stanford-bunny,spot}.obj, LOD chains and bake
// included. out_summary (optional) receives a human-readable summary: objects, levels with
// triangles and errors, the lightmap, the lights and the time each step took.
Result<Scene> make_demo_scene(const std::filesystem::path& data_dir, std::string* out_summary);

// make_demo_scene, then save_glb to out_glb (atomically: nothing is left behind on failure).
Status build_demo_scene(const std::filesystem::path& data_dir, const std::filesystem::path& out_glb,
                        std::string* out_summary);

}  // namespace hmdnode
