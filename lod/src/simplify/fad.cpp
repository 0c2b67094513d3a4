// FAD, "face angle dependency": vertex removal ordered by the angles between the normals of the
// faces around a vertex.
//
// Paper: H. Li, S. Kim, "Mesh Simplification Algorithms for Rendering Performance", International
// Journal of Engineering Research and Technology 13(6), 2020, pp. 1110-1119, sec. III.II (FAD): for
// every vertex, the angles between the normals of all faces around it are computed pairwise; when
// all of them are below a threshold the vertex lies in a flat region and is removed; holes are
// re-triangulated by Delaunay.
//
// Departures from the paper:
// - Target instead of threshold: vertices are removed in increasing order of the paper's
//   criterion (the largest pairwise normal angle of their fan, theta) until the requested triangle
//   count is reached; a threshold run is the prefix of this order with the key below it (FASS
//   uses it that way).
// - No Delaunay: a 2D Delaunay of a 3D point set is not a surface. The removed vertex is
//   half-edge collapsed onto the neighbour that turns the surviving faces least (the re-
//   triangulation of the hole is the fan of that neighbour), with the link condition, border,
//   seam and flip rules of openmesh_mesh.hpp.
// - The key is theta + delta, delta the largest normal turn of that best collapse, so that of two
//   vertices with the same theta the one whose removal changes the surface less goes first: on a
//   cube the vertices along an edge (theta 90, delta 0) go before the corners (delta > 0).
// - Open borders: the paper has none; a border vertex's key also counts the turn of the border at
//   it (the angle between its two border edges), so that outline corners stay like sharp edges.
// - Removed vertices are not moved and no attribute is interpolated: the survivor keeps its own.
//
// Cost: O(n log n) queue operations; a key costs O(valence^2) (every collapse of the fan tried),
// and the survivor's 1-ring is re-keyed after each removal. Memory O(V) for the queue.
#include <algorithm>
#include <cmath>
#include <memory>

#include "algorithms.hpp"
#include "openmesh_mesh.hpp"

namespace hmdnode::lod_detail {
namespace {

using VH = OmMesh::VertexHandle;

double angle_of_cos(double c) {
    return std::acos(std::clamp(c, -1.0, 1.0));
}

// Largest angle between the normals of two faces around v (the paper's criterion), or the turn of
// the open border at v when larger.
double fan_angle(const OmMesh& mesh, VH v) {
    glm::dvec3 n[64];
    int k = 0;
    for (auto f : mesh.vf_range(v)) {
        glm::dvec3 fn = face_normal(mesh, f);
        double l = glm::length(fn);
        if (l > 0.0 && k < 64) n[k++] = fn / l;
    }
    double min_cos = 1.0;
    for (int i = 0; i < k; ++i)
        for (int j = i + 1; j < k; ++j) min_cos = std::min(min_cos, glm::dot(n[i], n[j]));
    // On an open border, the turn of the border at v is a feature angle too.
    for (auto h : mesh.voh_range(v)) {
        if (!mesh.is_boundary(h)) continue;
        glm::dvec3 p = point(mesh, v);
        glm::dvec3 next = point(mesh, mesh.to_vertex_handle(h)) - p;
        glm::dvec3 prev = p - point(mesh, mesh.from_vertex_handle(mesh.prev_halfedge_handle(h)));
        double l = glm::length(next) * glm::length(prev);
        if (l > 0.0) min_cos = std::min(min_cos, glm::dot(next, prev) / l);
    }
    return angle_of_cos(min_cos);
}

// The valid collapse of v onto a neighbour that turns the surviving faces least.
bool best_collapse(const WeldedMesh& m, VH v, const CollapseRules& rules, CollapsePlan* out) {
    bool found = false;
    CollapsePlan plan;
    for (auto h : m.mesh.voh_range(v)) {
        if (!plan_collapse(m, h, nullptr, rules, &plan)) continue;
        if (!found || plan.min_cos > out->min_cos ||
            (plan.min_cos == out->min_cos &&
             m.mesh.calc_edge_sqr_length(h) < m.mesh.calc_edge_sqr_length(out->h))) {
            *out = plan;
            found = true;
        }
    }
    return found;
}

}  // namespace

GreedyHooks fad_hooks(WeldedMesh& m, const CollapseRules& rules) {
    GreedyHooks hooks;
    hooks.kind = ElementKind::Vertex;
    hooks.cost = [&m, rules](int i) {
        VH v(i);
        if (m.mesh.is_isolated(v)) return 1e301;
        CollapsePlan plan;
        if (!best_collapse(m, v, rules, &plan)) return 1e301;
        return fan_angle(m.mesh, v) + angle_of_cos(plan.min_cos);
    };
    hooks.apply = [&m, rules](int i, VH* out_survivor) {
        CollapsePlan plan;
        if (!best_collapse(m, VH(i), rules, &plan)) return false;
        apply_collapse(m, plan);
        *out_survivor = plan.v1;
        return true;
    };
    return hooks;
}

Result<std::vector<SimplifiedLevel>> simplify_fad(const Primitive& in,
                                                  std::span<const size_t> targets,
                                                  const SimplifyOptions& options) {
    WeldedMesh m = weld_to_openmesh(in, options.locked_positions);
    CollapseRules rules;
    rules.lock_borders = options.lock_borders;
    return run_greedy(m, targets, fad_hooks(m, rules), options);
}

}  // namespace hmdnode::lod_detail
