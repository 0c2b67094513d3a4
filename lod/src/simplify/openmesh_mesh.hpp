// Primitive <-> OpenMesh conversion for the simplifiers of lod/ (private: OpenMesh never appears in
// a public header), and the checked half-edge collapse the algorithms of Li and Kim 2020 share
// (H. Li, S. Kim, "Mesh Simplification Algorithms for Rendering Performance", International
// Journal of Engineering Research and Technology 13(6), 2020).
//
// Welding: input vertices whose positions are equal bit for bit (after +0 == -0) become one
// OpenMesh vertex. Each face keeps, per corner, the "wedge" it had: the input vertex index,
// deduplicated over vertices equal in position and every attribute. A wedge belongs to exactly one
// OpenMesh vertex at a time, so the output has one vertex per live wedge and the attributes of
// every corner come back exactly (or interpolated within one UV chart when a collapse moves a
// vertex). Faces OpenMesh refuses (complex edge or vertex, repeated corner) are counted in
// `rejected_faces` and left out, never a crash.
//
// Collapse rules (plan_collapse): OpenMesh's link condition (is_collapse_ok), locked vertices kept
// (SimplifyOptions::locked_positions: never removed, never moved), open borders kept
// (a border vertex only collapses along its border and never moves; none at all with
// lock_borders), UV / normal / colour seams kept (every wedge of the removed vertex must map onto a
// wedge of the survivor through the two faces of the collapsed edge: a seam vertex only moves
// along its seam), and no face flips or degenerates (new normal against old normal, cosine above
// `min_normal_cos`; with input normals, never facing away from its corners' normals; no slivers).
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <span>
#include <vector>

#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
#include <glm/glm.hpp>

#include "hmdnode/core/scene.hpp"
#include "hmdnode/lod/simplify.hpp"

namespace hmdnode::lod_detail {

struct OmTraits : public OpenMesh::DefaultTraits {
    VertexAttributes(OpenMesh::Attributes::Status);
    EdgeAttributes(OpenMesh::Attributes::Status);
    HalfedgeAttributes(OpenMesh::Attributes::Status);
    FaceAttributes(OpenMesh::Attributes::Status);
};
using OmMesh = OpenMesh::TriMesh_ArrayKernelT<OmTraits>;

struct Corner {
    int vertex = -1;     // OpenMesh vertex index
    uint32_t wedge = 0;  // index into WeldedMesh::wedges
};

struct WeldedMesh {
    OmMesh mesh;
    std::vector<std::array<Corner, 3>> corners;  // by face index (faces are never added later)
    Primitive wedges;  // one entry per wedge: input attributes (positions unused on output)
    size_t alive_faces = 0;
    size_t rejected_faces = 0;  // input faces OpenMesh could not add (or with a repeated corner)
};

// Welds `in` (valid indices) into a WeldedMesh. Vertices at `locked_positions` get OpenMesh's
// locked status: plan_collapse() and the Decimater neither remove nor move them.
WeldedMesh weld_to_openmesh(const Primitive& in, std::span<const glm::vec3> locked_positions = {});
// The live faces as a Primitive with exactly the attribute arrays of the input, one vertex per
// live wedge; corner order follows OpenMesh's (input) orientation.
Primitive to_primitive(const WeldedMesh& m);

uint32_t wedge_at(const WeldedMesh& m, OmMesh::FaceHandle f, OmMesh::VertexHandle v);
glm::dvec3 point(const OmMesh& mesh, OmMesh::VertexHandle v);
// The three corners of face f in winding order: their vertices and points.
void face_corners(const OmMesh& mesh, OmMesh::FaceHandle f, OmMesh::VertexHandle v[3],
                  glm::dvec3 p[3]);
// Unnormalised normal (twice the area) of face f.
glm::dvec3 face_normal(const OmMesh& mesh, OmMesh::FaceHandle f);

struct CollapseRules {
    bool lock_borders = false;
    // Reject when a face normal turns by acos(min_normal_cos) or more in one collapse; 60 degrees
    // keeps a run of collapses from turning a face over step by step.
    // When the input has normals, a face must also not face away from the sum of its corners'
    // normals (anchored to the input, so turns cannot add up); min_normal_cos <= -1 disables both.
    double min_normal_cos = 0.5;
};

struct CollapsePlan {
    OmMesh::HalfedgeHandle h;  // from v0 (removed) to v1 (kept)
    OmMesh::VertexHandle v0, v1;
    bool move = false;  // v1 goes to `target`, its wedges interpolated (see `interpolation`)
    glm::dvec3 target{0.0};
    // When moving: wedge `dst` of v1 becomes sum w[k] * wedge src[k], the barycentric coordinates
    // of the target in one face of the collapsed edge (so that UVs stay an affine function of the
    // position inside a chart).
    struct Interpolation {
        uint32_t dst;
        uint32_t src[3];
        float w[3];
    };
    std::vector<Interpolation> interpolation;
    std::vector<std::pair<uint32_t, uint32_t>> wedge_map;  // wedge of v0 -> wedge of v1
    double min_cos = 1.0;  // smallest cosine between a face's normal before and after
    int removed_faces = 0;
};

// Checks the collapse of h (v0 -> v1), placing v1 at *placement when given and allowed (neither
// end on a border, every wedge of v1 mapped from v0, and when v1 is on a seam the placement on
// the edge), else leaving v1 where it is. Faces thinner than 1e-4 (|n| against the squared
// longest edge) count as degenerate. Fills *out.
bool plan_collapse(const WeldedMesh& m, OmMesh::HalfedgeHandle h, const glm::dvec3* placement,
                   const CollapseRules& rules, CollapsePlan* out);
// For a collapse someone else already decided (OpenMesh's Decimater only re-checks topology
// before collapsing): the plan without moving, wedges of v0 that no face of the edge maps sent to
// the first mapped wedge of v1.
CollapsePlan forced_plan(const WeldedMesh& m, OmMesh::HalfedgeHandle h);
// Split for OpenMesh's Decimater, which collapses itself: prepare before mesh.collapse(h),
// finish after. apply_collapse does all three.
void prepare_collapse(WeldedMesh& m, const CollapsePlan& plan);
void finish_collapse(WeldedMesh& m, const CollapsePlan& plan);
void apply_collapse(WeldedMesh& m, const CollapsePlan& plan);

// The circumcentre of triangle abc, or the midpoint of its longest edge when the triangle is
// obtuse (the circumcentre then lies outside it) or degenerate.
glm::dvec3 clamped_circumcenter(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c);

// Collapses triangle f into one of its vertices placed at `c` (two half-edge collapses, the first
// one moving the survivor); when no vertex may move to c (seams, borders), into the vertex nearest
// c left in place. Returns false when no vertex order passes the rules; true when at least the
// first collapse was made. *out_survivor receives the kept vertex.
bool collapse_triangle(WeldedMesh& m, OmMesh::FaceHandle f, const glm::dvec3& c,
                       const CollapseRules& rules, OmMesh::VertexHandle* out_survivor);
// Collapses edge e to its midpoint (either direction), else onto either end without moving.
bool collapse_edge_to_point(WeldedMesh& m, OmMesh::VertexHandle a, OmMesh::VertexHandle b,
                            const glm::dvec3& p, const CollapseRules& rules,
                            OmMesh::VertexHandle* out_survivor);

// Greedy driver: a lazy priority queue of elements (vertices, edges or faces by index) ordered by
// `cost` (+inf: nothing to do now); the cheapest is popped and `apply`d (false: not possible now,
// dropped until its neighbourhood changes); after each success the elements on the survivor's
// 1-ring are re-costed. A snapshot is taken each time the live face count reaches a target;
// targets not reached (queue empty, or cost above `stop_cost`) get the last state. Time
// O(n log n) plus the callbacks; memory O(n).
enum class ElementKind { Vertex, Edge, Face };
struct GreedyHooks {
    ElementKind kind = ElementKind::Vertex;
    std::function<double(int)> cost;
    std::function<bool(int, OmMesh::VertexHandle*)> apply;
};
std::vector<SimplifiedLevel> run_greedy(WeldedMesh& m, std::span<const size_t> targets,
                                        const GreedyHooks& hooks, const SimplifyOptions& options,
                                        double stop_cost = 1e300);

// fad.cpp: FAD's vertex order and removal, shared with FASS.
GreedyHooks fad_hooks(WeldedMesh& m, const CollapseRules& rules);
// ss.cpp: one spherical-scanning pass of radius `radius`; returns the largest distance a vertex
// moved (to its cluster's representative).
// Stops as soon as the live face count is at most `stop_faces`.
double ss_pass(WeldedMesh& m, double radius, const CollapseRules& rules, size_t stop_faces = 0);
// ss.cpp: SS reaching `target` with the smallest radius found (a geometric sweep, then bisection),
// stopping the scan at the target; else the closest count above it. Works on copies of `base`.
SimplifiedLevel ss_to_target(const WeldedMesh& base, size_t target, const CollapseRules& rules);

}  // namespace hmdnode::lod_detail
