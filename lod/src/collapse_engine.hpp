// The edge-collapse engine shared by qem.cpp, curvature_qem.cpp, formula1.cpp and melax.cpp: the
// mesh on flat arrays, the candidate heap, the validity checks (seams, borders, link condition,
// flips) and the snapshots. Each cost lives in its own file and plugs in as a CollapseCost.
// See collapse_engine.cpp for the method and its cost.
#pragma once

#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <span>
#include <vector>

#include <glm/glm.hpp>

#include "hmdnode/core/result.hpp"
#include "hmdnode/core/scene.hpp"
#include "hmdnode/lod/progressive_mesh.hpp"
#include "hmdnode/lod/simplify.hpp"
#include "scratch.hpp"
#include "two_way.hpp"

namespace hmdnode::lod_detail {

inline constexpr uint32_t kNone = std::numeric_limits<uint32_t>::max();

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

// The output primitive of a state: live faces in id order, the wedges they use in id order.
// Shared by the engine's snapshots and refine() so that both agree bit for bit. `wedges` is only
// read for the attributes the flags name (it may be empty when none is set).
Primitive compact_primitive(std::span<const glm::vec3> positions,
                            std::span<const uint32_t> wedge_position,
                            std::span<const PmWedge> wedges, std::span<const uint32_t> corners,
                            std::span<const uint8_t> face_alive, bool has_normals, bool has_uv0,
                            bool has_uv1, bool has_colors, int material);

// The argument checks of simplify() (simplify.cpp), shared with build_progressive_mesh().
Status check_simplify_arguments(const Primitive& in, std::string_view algorithm,
                                std::span<const size_t> targets);

// Factories, one per cost file.
std::unique_ptr<CollapseCost> make_qem_cost();
std::unique_ptr<CollapseCost> make_curvature_qem_cost();
std::unique_ptr<CollapseCost> make_formula1_cost();
std::unique_ptr<CollapseCost> make_melax_cost();
// nullptr for a name that is not an edge-collapse cost.
std::unique_ptr<CollapseCost> make_collapse_cost(std::string_view algorithm);

// A symmetric 4x4 quadric (Garland & Heckbert 1997) v^T A v + 2 b.v + c, plus the total weight
// (area) it gathered, for error estimates.
struct Quadric {
    double a00 = 0, a01 = 0, a02 = 0, a11 = 0, a12 = 0, a22 = 0;
    double b0 = 0, b1 = 0, b2 = 0, c = 0;
    double weight = 0;

    // The plane n.x + d = 0 (n unit length) with weight w.
    static Quadric plane(const glm::dvec3& n, double d, double w) {
        Quadric q;
        q.a00 = w * n.x * n.x, q.a01 = w * n.x * n.y, q.a02 = w * n.x * n.z;
        q.a11 = w * n.y * n.y, q.a12 = w * n.y * n.z, q.a22 = w * n.z * n.z;
        q.b0 = w * n.x * d, q.b1 = w * n.y * d, q.b2 = w * n.z * d;
        q.c = w * d * d;
        q.weight = w;
        return q;
    }
    Quadric& operator+=(const Quadric& o) {
        a00 += o.a00, a01 += o.a01, a02 += o.a02, a11 += o.a11, a12 += o.a12, a22 += o.a22;
        b0 += o.b0, b1 += o.b1, b2 += o.b2, c += o.c, weight += o.weight;
        return *this;
    }
    Quadric operator+(const Quadric& o) const {
        Quadric q = *this;
        q += o;
        return q;
    }
    Quadric operator*(double s) const {
        Quadric q;
        q.a00 = a00 * s, q.a01 = a01 * s, q.a02 = a02 * s, q.a11 = a11 * s, q.a12 = a12 * s;
        q.a22 = a22 * s, q.b0 = b0 * s, q.b1 = b1 * s, q.b2 = b2 * s, q.c = c * s;
        q.weight = weight * s;
        return q;
    }
    double evaluate(const glm::dvec3& v) const {
        const double ax = a00 * v.x + a01 * v.y + a02 * v.z;
        const double ay = a01 * v.x + a11 * v.y + a12 * v.z;
        const double az = a02 * v.x + a12 * v.y + a22 * v.z;
        const double r =
            v.x * ax + v.y * ay + v.z * az + 2.0 * (b0 * v.x + b1 * v.y + b2 * v.z) + c;
        return r > 0.0 ? r : 0.0;
    }
};

// The placement of Garland & Heckbert for merging p and q under quadric `q`: the minimiser of the
// 3x3 system when well conditioned (and not far off the edge), else the minimiser on the segment,
// else the best of the endpoints and the midpoint. Returns the point; `cost` its quadric value.
glm::dvec3 optimal_placement(const Quadric& q, const glm::dvec3& p0, const glm::dvec3& p1,
                             double& cost);

// Garland & Heckbert's per-position quadrics (qem.cpp): the planes of the faces around each
// position weighted by face area, plus, for every border edge and each side of every seam edge,
// the plane through the edge perpendicular to its face, weighted by kBoundaryWeight * length^2.
inline constexpr double kBoundaryWeight = 10.0;
Scratch<Quadric> position_quadrics(const CollapseMesh& mesh);

}  // namespace hmdnode::lod_detail
