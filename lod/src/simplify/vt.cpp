// VT, "vertex triplex": every triangle's three vertices aggregated into its circumcentre.
//
// Paper: H. Li, S. Kim, "Mesh Simplification Algorithms for Rendering Performance", International
// Journal of Engineering Research and Technology 13(6), 2020, pp. 1110-1119, sec. III.I (VT): the
// circumcentre of each triangle (equations 1-4) replaces its three vertices; the resulting point
// cloud, evenly spread over the surface, is re-triangulated by Delaunay.
//
// Departures from the paper:
// - Target instead of one fixed pass: triangles are aggregated one at a time, smallest
//   circumradius first (the paper's aim, evenly spread vertices, comes from shrinking the small
//   triangles first), until the requested triangle count is reached. Aggregating every triangle
//   at once is not a mesh operation: neighbouring triangles share vertices.
// - No Delaunay: a triangle is aggregated as two half-edge collapses into one of its vertices,
//   which moves to the circumcentre (the link condition, border, seam and flip rules of
//   openmesh_mesh.hpp apply; when no vertex of the triangle may move, on borders and UV seams, the
//   vertex nearest the circumcentre is kept in place; when no order passes the rules the triangle
//   waits until its neighbourhood changes).
// - Obtuse triangles: their circumcentre lies outside the triangle (and far away for slivers); the
//   midpoint of the longest edge is used instead.
// - Attributes of the moved vertex are interpolated along the first collapsed edge (within one UV
//   chart, see openmesh_mesh.hpp).
//
// Cost: O(n log n) queue operations over faces, each O(valence^2); memory O(T).
#include <algorithm>

#include "algorithms.hpp"
#include "openmesh_mesh.hpp"

namespace hmdnode::lod_detail {
namespace {

using VH = OmMesh::VertexHandle;
using FH = OmMesh::FaceHandle;

}  // namespace

Result<std::vector<SimplifiedLevel>> simplify_vt(const Primitive& in,
                                                 std::span<const size_t> targets,
                                                 const SimplifyOptions& options) {
    WeldedMesh m = weld_to_openmesh(in, options.locked_positions);
    CollapseRules rules;
    rules.lock_borders = options.lock_borders;
    GreedyHooks hooks;
    hooks.kind = ElementKind::Face;
    hooks.cost = [&m](int i) {
        glm::dvec3 p[3];
        VH v[3];
        face_corners(m.mesh, FH(i), v, p);
        glm::dvec3 c = clamped_circumcenter(p[0], p[1], p[2]);
        return std::max({glm::distance(c, p[0]), glm::distance(c, p[1]), glm::distance(c, p[2])});
    };
    hooks.apply = [&m, rules](int i, VH* out_survivor) {
        glm::dvec3 p[3];
        VH v[3];
        face_corners(m.mesh, FH(i), v, p);
        return collapse_triangle(m, FH(i), clamped_circumcenter(p[0], p[1], p[2]), rules,
                                 out_survivor);
    };
    return run_greedy(m, targets, hooks, options);
}

}  // namespace hmdnode::lod_detail
