// Input of `hmdnode lod`: a scene from a glTF (.gltf/.glb), OBJ, PLY or OFF file. Implementation:
// lod/src/simplify/mesh_file.cpp.
//
// Thread: any; reads only the given file (and, for glTF, the buffers and images it names).
#pragma once

#include <filesystem>

#include "hmdnode/core/result.hpp"
#include "hmdnode/core/scene.hpp"

namespace hmdnode {

// Loads `path` by its content: glTF binary by the "glTF" magic, PLY by "ply", OFF by "OFF"
// (also "NOFF", "COFF", ...), JSON glTF by a leading '{', else OBJ when the extension is .obj.
// OBJ, PLY and OFF give one node (a root, identity transform) with one mesh of one primitive, no
// material, named after the file's stem.
//
// PLY: ascii, binary_little_endian and binary_big_endian; element "vertex" with x, y, z (any
// scalar type), optional nx, ny, nz, u/v (or s/t, texture_u/texture_v; v flipped to glTF's top-left
// origin) and red, green, blue[, alpha] (integers / 255 or floats, made linear as given); element
// "face" with a list "vertex_indices" (or "vertex_index"), polygons fan-triangulated; other
// elements and properties skipped. Missing normals are computed area-weighted.
// OFF: ascii, "OFF" then "V F E", V lines of x y z, F lines of "n i0 .. in-1" (colours ignored).
// Errors name the file and the element, property or line at fault (truncated, bad number, index
// out of range, unknown format or type); positions are not checked here (mesh_repair.hpp does).
Result<Scene> load_mesh_file(const std::filesystem::path& path);

// A scene of one mesh on one root node named after it.
Scene single_mesh_scene(Mesh mesh);

}  // namespace hmdnode
