// The edge-collapse engine's interface to its costs (qem.cpp, curvature_qem.cpp, formula1.cpp,
// melax.cpp): the mesh as a cost sees it, the moves an edge allows, a candidate collapse, and the
// CollapseCost each cost file implements; run_edge_collapse() runs the engine with one. The
// engine itself: collapse_engine.cpp (its file map), collapse_mesh.hpp, collapse_check.hpp,
// greedy_schedule.cpp, pass_schedule.cpp; the quadrics: quadric.hpp.
#pragma once

#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <span>
#include <vector>

#include <glm/glm.hpp>

#include "compact_primitive.hpp"
#include "hmdnode/core/result.hpp"
#include "hmdnode/core/scene.hpp"
#include "hmdnode/lod/progressive_mesh.hpp"
#include "hmdnode/lod/simplify.hpp"
#include "scratch.hpp"
#include "two_way.hpp"

namespace hmdnode::lod_detail {

// What may happen to a position.
enum class VertexKind : uint8_t {
    Free,    // one wedge, interior: may collapse onto any neighbour
    Border,  // on one open border (two border edges), one wedge: only along the border
    Seam,    // two wedges, on exactly two seam edges, interior: only along the seam
    Locked,  // seam corner or end, seam on a border, non-manifold, or asked for
             // (SimplifyOptions::locked_positions): never removed, never moved
};

// A border edge (one face) or one side of a seam edge: the costs add boundary planes for them.
struct ConstraintEdge {
    uint32_t a = 0, b = 0;  // positions
    uint32_t face = 0;      // the face on this side
};

// The mesh as the costs see it. Positions are welded (one per distinct coordinate); a face's
// corners hold wedges (a position plus attributes). Dead faces stay in the corner lists until the
// engine prunes them: iterate with for_each_face. The corner lists are only kept for costs that
// depends_on_ring() (the pass schedule of the others walks a flat per-pass copy instead).
struct CollapseMesh {
    Scratch<glm::vec3> positions;
    Scratch<VertexKind> kinds;
    Scratch<uint8_t> on_border;
    Scratch<uint8_t> position_alive;
    Scratch<uint32_t> wedge_position;
    Scratch<uint32_t> corners;          // 3 wedges per face
    Scratch<uint32_t> corner_position;  // per corner: wedge_position[corners[c]] (cached)
    Scratch<uint8_t> face_alive;
    Scratch<uint32_t> corner_head;  // per position: first corner of its list
    Scratch<uint32_t> corner_next;  // per corner
    Scratch<ConstraintEdge> constraint_edges;
    // Unit normal of each live face (zero when degenerate), kept current by the engine for costs
    // that depend_on_ring(); empty otherwise.
    Scratch<glm::dvec3> face_unit_normals;
    glm::vec3 bbox_min{0.0f}, bbox_max{0.0f};
    bool lock_borders = false;
    // The pass schedule's two regions: positions before region_start and from it on (0: one).
    // A cost's init() may split work on positions by them through `split` (two threads where the
    // engine has a helper); nullptr: do it in one piece.
    uint32_t region_start = 0;
    TwoWay* split = nullptr;

    uint32_t face_position(uint32_t face, int k) const { return corner_position[3 * face + k]; }
    // f(face, k): every live face around position p, k the corner of p in it.
    template <class F>
    void for_each_face(uint32_t p, F&& f) const {
        for (uint32_t c = corner_head[p]; c != kNone; c = corner_next[c]) {
            if (face_alive[c / 3]) f(c / 3, int(c % 3));
        }
    }
    glm::dvec3 face_normal_unnormalized(uint32_t face) const {
        const glm::dvec3 p0 = positions[face_position(face, 0)];
        const glm::dvec3 p1 = positions[face_position(face, 1)];
        const glm::dvec3 p2 = positions[face_position(face, 2)];
        return glm::cross(p1 - p0, p2 - p0);
    }
    double bbox_diagonal() const { return double(glm::length(bbox_max - bbox_min)); }
    glm::dvec3 face_unit_normal(uint32_t face) const {
        const glm::dvec3 n = face_normal_unnormalized(face);
        const double len = glm::length(n);
        return len > 0.0 ? n / len : glm::dvec3(0.0);
    }
};

// The collapses allowed on an edge (a, b).
struct EdgeMoves {
    bool a_to_b = false;  // a may be removed onto b where b stands
    bool b_to_a = false;
    // Both may move to a new position: only two free positions. Border and seam positions move
    // onto a neighbour along their border or seam (as meshoptimizer does), so borders, seams and
    // their corners stay exactly where they were and seam UVs stay exact.
    bool merge = false;
};

struct CollapseCandidate {
    double cost = 0.0;
    uint32_t from = kNone;  // removed
    uint32_t to = kNone;    // kept
    bool moves = false;     // true: `to` moves to `position`; false: it stays
    glm::dvec3 position{0.0};
    double error = -1.0;  // estimate of the geometric error, in metres; < 0: none
};

class CollapseCost {
  public:
    virtual ~CollapseCost() = default;
    // Called once, before any evaluate().
    virtual void init(const CollapseMesh& mesh) = 0;
    // The cheapest allowed collapse of edge (a, b) (at least one move is allowed); false: none.
    virtual bool evaluate(const CollapseMesh& mesh, uint32_t a, uint32_t b, EdgeMoves moves,
                          CollapseCandidate& out) = 0;
    // The error estimate of a candidate about to be applied (its endpoints not yet merged), for
    // costs that leave `error` to be computed only for the collapses applied.
    virtual double error_of(const CollapseMesh& mesh, const CollapseCandidate& c) {
        (void)mesh;
        return c.error;
    }
    // A hint: evaluate() will soon read what the cost keeps for position p (no effect on results).
    virtual void prefetch(uint32_t p) const { (void)p; }
    // After `c` was applied (positions and faces updated).
    virtual void collapsed(const CollapseMesh& mesh, const CollapseCandidate& c) {
        (void)mesh;
        (void)c;
    }
    // True when a cost depends on the faces around an endpoint (not only on the endpoints): the
    // engine then re-evaluates every edge of the 1-ring after a collapse.
    virtual bool depends_on_ring() const { return false; }
};

// Runs the collapses in order of cost until the live face count reaches the last target,
// snapshotting each target. `log`, when given, receives the progressive mesh (base = final state).
Result<std::vector<SimplifiedLevel>> run_edge_collapse(const Primitive& in,
                                                       std::span<const size_t> targets,
                                                       const SimplifyOptions& options,
                                                       CollapseCost& cost,
                                                       ProgressiveMesh* log = nullptr);

// The argument checks of simplify() (simplify.cpp), shared with build_progressive_mesh().
Status check_simplify_arguments(const Primitive& in, std::string_view algorithm,
                                std::span<const size_t> targets);

// The input's baked light (_LIGHT_0) onto every level that an algorithm returned without it
// (carry_vertex_light, attribute_transfer.hpp); simplify() and build_progressive_mesh() end with
// it.
Status carry_light_to_levels(const Primitive& in, std::vector<SimplifiedLevel>& levels);

// Factories, one per cost file.
std::unique_ptr<CollapseCost> make_qem_cost();
std::unique_ptr<CollapseCost> make_curvature_qem_cost();
std::unique_ptr<CollapseCost> make_formula1_cost();
std::unique_ptr<CollapseCost> make_melax_cost();
// nullptr for a name that is not an edge-collapse cost.
std::unique_ptr<CollapseCost> make_collapse_cost(std::string_view algorithm);

}  // namespace hmdnode::lod_detail
