// The meshes the LOD benchmarks run on by default, shared by bench_lod_bench and
// bench_lod_distance_bench. Header-only (benches are one file each).
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace hmdnode::bench {

// A mesh file, and how many times each triangle is split into 4 on its own plane.
struct LodInput {
    std::string name;
    std::filesystem::path file;
    int splits = 0;
};

// The files given, or the bundled meshes of `mesh_dir` and the bunny with each triangle split into
// 4 on its own plane (piecewise-flat input, like tessellated walls and CAD parts: most collapses
// cost zero there).
inline std::vector<LodInput> lod_inputs(const std::filesystem::path& mesh_dir,
                                        const std::vector<std::filesystem::path>& files) {
    std::vector<LodInput> inputs;
    if (files.empty())
        return {{"bunny", mesh_dir / "stanford-bunny.obj"},
                {"fandisk", mesh_dir / "fandisk.obj"},
                {"spot", mesh_dir / "spot.obj"},
                {"bunny-split", mesh_dir / "stanford-bunny.obj", 1}};
    for (const std::filesystem::path& f : files) inputs.push_back({f.stem().string(), f});
    return inputs;
}

}  // namespace hmdnode::bench
