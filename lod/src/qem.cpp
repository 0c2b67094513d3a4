// Quadric error metric simplification (cost "qem").
//
// Paper: M. Garland, P. Heckbert, "Surface simplification using quadric error metrics",
// SIGGRAPH 1997: each position carries the sum Q of the squared-distance quadrics of the planes of
// its faces; collapsing (a, b) costs v^T (Q_a + Q_b) v at the new point v, which is the minimiser
// of that quadric (the 4x4 / 3x3 solve, in double), or when the system is ill-conditioned the
// minimiser on the edge, else the best of the endpoints and the midpoint (optimal_placement in
// collapse_engine.cpp). Border edges (and both sides of seam edges) add a plane through the edge
// perpendicular to its face with a large weight (section 6.1 of the paper), so borders and seams
// keep their shape; flips are rejected by the engine.
//
// Departures: face quadrics are weighted by face area (Garland's thesis, section 3.4), so the
// result does not depend on the tessellation; the solved point is only accepted within one edge
// length of the edge's midpoint (further away the system is nearly singular and the point is
// noise), otherwise the segment minimiser is used. Only two free positions merge at a new point;
// where a border, seam or locked endpoint is involved the candidate is the cheaper allowed
// endpoint (the engine keeps borders and seams exactly, as meshoptimizer does). The estimated
// error is sqrt(cost / total area weight), the RMS plane distance in metres.
//
// Cost: O(F) to build the quadrics (88 bytes per position); O(1) per edge evaluation (one 3x3
// solve); the engine's O(E log E) for the rest.
#include <cmath>
#include <limits>
#include <memory>

#include "collapse_engine.hpp"

namespace hmdnode::lod_detail {

std::vector<Quadric> position_quadrics(const CollapseMesh& m) {
    std::vector<Quadric> q(m.positions.size());
    for (uint32_t f = 0; f < uint32_t(m.face_alive.size()); ++f) {
        if (!m.face_alive[f]) continue;
        const glm::dvec3 n = m.face_normal_unnormalized(f);
        const double len = glm::length(n);
        if (len == 0.0) continue;
        const glm::dvec3 unit = n / len;
        const glm::dvec3 p0 = m.positions[m.face_position(f, 0)];
        const Quadric plane = Quadric::plane(unit, -glm::dot(unit, p0), 0.5 * len);
        for (int k = 0; k < 3; ++k) q[m.face_position(f, k)] += plane;
    }
    for (const ConstraintEdge& e : m.constraint_edges) {
        const glm::dvec3 pa = m.positions[e.a], pb = m.positions[e.b];
        const glm::dvec3 n = m.face_normal_unnormalized(e.face);
        const glm::dvec3 perp = glm::cross(pb - pa, n);
        const double len = glm::length(perp);
        if (len == 0.0) continue;
        const glm::dvec3 unit = perp / len;
        const double el2 = glm::dot(pb - pa, pb - pa);
        Quadric plane = Quadric::plane(unit, -glm::dot(unit, pa), kBoundaryWeight * el2);
        plane.weight = 0.0;  // note: not surface area, keep it out of the error estimate
        q[e.a] += plane;
        q[e.b] += plane;
    }
    return q;
}

namespace {

class QemCost final : public CollapseCost {
  public:
    void init(const CollapseMesh& m) override { quadrics_ = position_quadrics(m); }

    bool evaluate(const CollapseMesh& m, uint32_t a, uint32_t b, EdgeMoves moves,
                  CollapseCandidate& out) override {
        const Quadric q = quadrics_[a] + quadrics_[b];
        const glm::dvec3 pa = m.positions[a], pb = m.positions[b];
        out.cost = std::numeric_limits<double>::infinity();
        if (moves.merge) {
            double cost = 0.0;
            const glm::dvec3 x = optimal_placement(q, pa, pb, cost);
            out = {cost, a, b, true, x, -1.0};
            // note: the placement already compared the endpoints, or solved for a point no
            // endpoint beats, so both half-edge moves are dominated.
            out.error = q.weight > 0.0 ? std::sqrt(out.cost / q.weight) : 0.0;
            return true;
        }
        if (moves.a_to_b) {
            const double cost = q.evaluate(pb);
            if (cost < out.cost) out = {cost, a, b, false, pb, -1.0};
        }
        if (moves.b_to_a) {
            const double cost = q.evaluate(pa);
            if (cost < out.cost) out = {cost, b, a, false, pa, -1.0};
        }
        out.error = q.weight > 0.0 ? std::sqrt(out.cost / q.weight) : 0.0;
        return true;
    }

    void collapsed(const CollapseMesh&, const CollapseCandidate& c) override {
        quadrics_[c.to] += quadrics_[c.from];
    }

  private:
    std::vector<Quadric> quadrics_;
};

}  // namespace

std::unique_ptr<CollapseCost> make_qem_cost() {
    return std::make_unique<QemCost>();
}

Result<std::vector<SimplifiedLevel>> simplify_qem(const Primitive& in,
                                                  std::span<const size_t> targets,
                                                  const SimplifyOptions& options) {
    QemCost cost;
    return run_edge_collapse(in, targets, options, cost);
}

}  // namespace hmdnode::lod_detail
