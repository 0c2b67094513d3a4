// libFuzzer harness: the mesh-file readers of `hmdnode lod` (load_mesh_file: the PLY and OFF
// readers of lod/src/simplify/mesh_file.cpp and core's OBJ reader) on untrusted bytes. The bytes go
// to a temporary file (the readers take a path), named .obj when the first byte is odd (OBJ is
// recognised by extension; PLY and OFF by content either way). Invariants for an accepted file:
// one mesh of one primitive with triangles, indices in range, attribute arrays empty or one per
// position.
//
// glTF (the "glTF" magic or a leading '{') is read by tinygltf through core's gltf.cpp, not by
// these readers: such inputs are skipped.
#include <unistd.h>

#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "hmdnode/core/gltf.hpp"
#include "hmdnode/lod/mesh_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    using namespace hmdnode;
    if (size == 0) return 0;
    const std::string bytes(reinterpret_cast<const char*>(data) + 1, size - 1);
    if (bytes.compare(0, 4, "glTF") == 0) return 0;
    const size_t first = bytes.find_first_not_of(" \t\r\n");
    if (first != std::string::npos && bytes[first] == '{') return 0;
    static const std::string dir = std::filesystem::temp_directory_path().string();
    const std::string path =
        dir + "/mesh_file_fuzz_" + std::to_string(getpid()) + ((data[0] & 1) ? ".obj" : ".ply");
    std::ofstream(path, std::ios::binary | std::ios::trunc).write(bytes.data(), bytes.size());
    Result<Scene> scene = load_mesh_file(path);
    std::filesystem::remove(path);
    if (!scene.ok()) return 0;
    if (scene->meshes.size() != 1 || scene->meshes[0].primitives.size() != 1) abort();
    const Primitive& p = scene->meshes[0].primitives[0];
    if (p.indices.empty() || p.indices.size() % 3 != 0) abort();
    for (uint32_t i : p.indices)
        if (i >= p.positions.size()) abort();
    const size_t n = p.positions.size();
    for (size_t a : {p.normals.size(), p.uv0.size(), p.uv1.size(), p.colors.size()})
        if (a != 0 && a != n) abort();
    return 0;
}
