// Checks and repairs of input meshes before simplification (`hmdnode lod`): what cannot be
// repaired safely is rejected with an error naming the primitive and the vertex or index; what
// can is repaired and counted. Implementation: lod/src/simplify/mesh_repair.cpp.
//
// Pure functions over caller-owned data: no I/O, no threads, no globals.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

#include "hmdnode/core/result.hpp"
#include "hmdnode/core/scene.hpp"

namespace hmdnode {

struct RepairReport {
    size_t degenerate_faces = 0;       // dropped: a repeated corner or zero area
    size_t duplicate_faces = 0;        // dropped: same three corners as an earlier face
    size_t non_manifold_faces = 0;     // dropped: would put a third face on an edge
    size_t reoriented_faces = 0;       // flipped to agree with their neighbours
    size_t unreferenced_vertices = 0;  // dropped, indices remapped
    // One line per repair that changed something, naming the primitive ("mesh 2 \"name\"
    // primitive 0: dropped 3 degenerate faces (zero area or repeated corner)").
    std::vector<std::string> messages;

    size_t total() const {
        return degenerate_faces + duplicate_faces + non_manifold_faces + reoriented_faces +
               unreferenced_vertices;
    }
};

// Checks `in` and returns a repaired copy. `label` names the primitive in messages and errors.
//
// Rejected (error): no positions or no triangles, an index count not a multiple of 3, an index
// out of range (its position in the index array and value named), a non-finite position (vertex
// index named), an attribute array whose size is neither 0 nor positions.size(), nothing left
// after the repairs.
//
// Repaired, in this order, on the connectivity of positions welded where they are bit-identical,
// -0 taken as +0 (how simplify() sees the mesh, so seams of split vertices are no borders here):
// 1. degenerate faces (two corners at the same position, or area below 1e-12 of the squared
//    longest edge): dropped;
// 2. duplicate faces (the same three welded corners, any order or orientation): the later ones
//    dropped;
// 3. orientation and non-manifold edges, greedily in face order: a face that would use a directed
//    edge an earlier kept face already uses is flipped when the flip makes all three of its
//    edges consistent (counted as reoriented), otherwise, or when one of its edges already has
//    two faces, it is dropped (counted as non-manifold). The result has at most two faces per
//    edge, each edge used once in each direction. Non-manifold vertices (two fans meeting at one
//    point) are left as they are.
// 4. unreferenced vertices: dropped, remaining vertices keep their order.
Result<Primitive> repair_primitive(const Primitive& in, std::string_view label,
                                   RepairReport& report);

// repair_primitive on every primitive of every mesh of `scene`, in place; labels are
// `mesh M "name" primitive P`. On an error the scene is left unchanged.
Status repair_scene(Scene& scene, RepairReport& report);

}  // namespace hmdnode
