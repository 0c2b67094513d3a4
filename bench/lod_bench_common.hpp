// What bench_lod_bench and bench_lod_distance_bench share: the meshes they run on by default and
// printf into a string for their tables. Header-only (benches are one file each).
#pragma once

#include <cstdarg>
#include <cstdio>
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

// printf into a string (the tables are printed and may be written into the docs).
__attribute__((format(printf, 2, 3))) inline void appendf(std::string& out, const char* format,
                                                          ...) {
    char line[1024];
    va_list args;
    va_start(args, format);
    std::vsnprintf(line, sizeof line, format, args);
    va_end(args);
    out += line;
}

}  // namespace hmdnode::bench
