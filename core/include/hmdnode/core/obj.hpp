// Wavefront OBJ reader for source meshes (the bundled bunny and spot, meshes from DCC tools).
#pragma once

#include <filesystem>

#include "hmdnode/core/result.hpp"
#include "hmdnode/core/scene.hpp"

namespace hmdnode {

// Loads the geometry of an OBJ file into one Mesh with one Primitive (no material; `mtllib`,
// `usemtl`, groups, objects, smoothing groups, lines and points are ignored).
//
// - `v x y z [w]`, `vt u [v [w]]`, `vn x y z`; faces `f` with corners `v`, `v/vt`, `v//vn` or
//   `v/vt/vn`; negative indices count back from the newest element; polygons are fan-triangulated
//   from their first corner.
// - One output vertex per distinct (v, vt, vn) triple, in order of first use.
// - uv0 = (u, 1 - v): OBJ puts v = 0 at the bottom of the image, glTF at the top.
// - Without any `vn` in the faces, normals are area-weighted averages of the face normals around
//   each position (shared across vertices that differ only by vt, so UV seams do not crease).
// - The mesh is named after the file's stem.
//
// Errors name the file and the 1-based line: a malformed number, an index out of range or zero,
// a face with fewer than three corners, a file without faces, an unreadable file.
Result<Mesh> load_obj(const std::filesystem::path& path);

}  // namespace hmdnode
