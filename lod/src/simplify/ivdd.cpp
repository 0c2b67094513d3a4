// IVDD, "intervertex distance dependence": iterative folding of the shortest edges to their
// midpoints, and of small triangles to their circumcentres.
//
// Paper: H. Li, S. Kim, "Mesh Simplification Algorithms for Rendering Performance", International
// Journal of Engineering Research and Technology 13(6), 2020, pp. 1110-1119, sec. III.III (IVDD):
// in each triangle, two vertices closer than a distance threshold are folded into their midpoint;
// when a vertex is closer than the threshold to both others, the three are folded into the
// circumcentre of the triangle; the result is re-triangulated.
//
// Departures from the paper:
// - Target instead of threshold: edges are folded shortest first (the threshold is the length of
//   the edge being folded, rising as the mesh coarsens) until the requested triangle count is
//   reached.
// - "All three edges under the threshold": with a threshold that rises edge by edge, a triangle
//   is folded to its circumcentre when its longest edge is at most kTriangleFactor times the edge
//   being folded (a near-equilateral small triangle the paper's fixed threshold would catch whole).
// - No Delaunay: folds are half-edge collapses whose survivor moves to the midpoint /
//   circumcentre, under the link condition, border, seam and flip rules of openmesh_mesh.hpp;
//   when the survivor may not move (border, seam) it stays, and when no direction is valid the
//   edge waits until its neighbourhood changes. Obtuse triangles use the midpoint of their longest
//   edge instead of the circumcentre (which lies outside them).
// - Attributes of the moved vertex are interpolated along the folded edge.
//
// Cost: O(n log n) queue operations over edges, each O(valence^2); memory O(E).
#include <algorithm>

#include "algorithms.hpp"
#include "openmesh_mesh.hpp"

namespace hmdnode::lod_detail {
namespace {

using VH = OmMesh::VertexHandle;
using FH = OmMesh::FaceHandle;
using EH = OmMesh::EdgeHandle;

constexpr double kTriangleFactor = 1.25;

}  // namespace

Result<std::vector<SimplifiedLevel>> simplify_ivdd(const Primitive& in,
                                                   std::span<const size_t> targets,
                                                   const SimplifyOptions& options) {
    WeldedMesh m = weld_to_openmesh(in, options.locked_positions);
    CollapseRules rules;
    rules.lock_borders = options.lock_borders;
    GreedyHooks hooks;
    hooks.kind = ElementKind::Edge;
    hooks.cost = [&m](int i) { return double(m.mesh.calc_edge_length(EH(i))); };
    hooks.apply = [&m, rules](int i, VH* out_survivor) {
        OmMesh& mesh = m.mesh;
        auto h = mesh.halfedge_handle(EH(i), 0);
        VH a = mesh.from_vertex_handle(h), b = mesh.to_vertex_handle(h);
        glm::dvec3 pa = point(mesh, a), pb = point(mesh, b);
        double d = glm::distance(pa, pb);
        for (auto hh : {h, mesh.opposite_halfedge_handle(h)}) {
            FH f = mesh.face_handle(hh);
            if (!f.is_valid()) continue;
            glm::dvec3 pc = point(mesh, mesh.to_vertex_handle(mesh.next_halfedge_handle(hh)));
            if (std::max(glm::distance(pa, pc), glm::distance(pb, pc)) > kTriangleFactor * d)
                continue;
            if (collapse_triangle(m, f, clamped_circumcenter(pa, pb, pc), rules, out_survivor))
                return true;
        }
        return collapse_edge_to_point(m, a, b, 0.5 * (pa + pb), rules, out_survivor);
    };
    return run_greedy(m, targets, hooks, options);
}

}  // namespace hmdnode::lod_detail
