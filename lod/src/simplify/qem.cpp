// Quadric error metric simplification (cost "qem").
//
// Paper: M. Garland, P. Heckbert, "Surface simplification using quadric error metrics",
// SIGGRAPH 1997: each position carries the sum Q of the squared-distance quadrics of the planes of
// its faces; collapsing (a, b) costs v^T (Q_a + Q_b) v at the new point v, which is the minimiser
// of that quadric (the 4x4 / 3x3 solve, in double), or when the system is ill-conditioned the
// minimiser on the edge, else the best of the endpoints and the midpoint (optimal_placement in
// qem.cpp). Border edges (and both sides of seam edges) add a plane through the edge
// perpendicular to its face with a large weight (section 6.1 of the paper), so borders and seams
// keep their shape; flips are rejected by the engine.
//
// Departures: face quadrics are weighted by face area (M. Garland, "Quadric-Based Polygonal Surface
// Simplification", PhD thesis, Carnegie Mellon University 1999, section 3.4), so the result does
// not depend on the tessellation; the solved point is only accepted within one edge length of the
// edge's midpoint (further away the system is nearly singular and the point is noise), otherwise
// the segment minimiser is used, unless the quadric is flat along the edge to within 1e-8 of its
// trace (an edge along a crease or in a plane: every point of it fits, and rounding alone chose
// one, sliding crease vertices along their creases), where the better endpoint is kept (the
// midpoint only where it is cheaper by more than that). Collapses are ordered by the quadric error
// over W^0.75, W the area the two quadrics sum, not by the plain area-weighted sum, which removed
// small features first (order_scale()). Only two free positions merge at a new point; where a
// border, seam or locked endpoint is involved the candidate is the cheaper allowed endpoint (the
// engine keeps borders and seams exactly, as meshoptimizer does). The estimated error is
// sqrt(quadric error / total area weight), the RMS plane distance in metres.
//
// Cost: O(F) to build the quadrics (88 bytes per position); O(1) per edge evaluation (one 3x3
// solve); the engine's O(E log E) for the rest.
#include <cassert>
#include <cmath>
#include <limits>
#include <memory>

#include "collapse_engine.hpp"
#include "quadric.hpp"

namespace hmdnode::lod_detail {

Scratch<Quadric> position_quadrics(const CollapseMesh& m) {
    const uint32_t np = uint32_t(m.positions.size());
    Scratch<Quadric> quadrics(np);
    Quadric* const q = quadrics.data();
    // note: each half sums, for its own positions, the planes in the same order as one loop
    // would (faces in id order, then the constraint edges), so the split changes no bit.
    auto half = [&m, q, np](int h) {  // note: by value (two_way.hpp)
        const uint32_t lo = h == 0 ? 0 : m.region_start, hi = h == 0 ? m.region_start : np;
        if (lo == hi) return;
        auto mine = [lo, hi](uint32_t p) { return p >= lo && p < hi; };
        for (uint32_t f = 0; f < uint32_t(m.face_alive.size()); ++f) {
            if (!m.face_alive[f]) continue;
            const uint32_t p0 = m.face_position(f, 0), p1 = m.face_position(f, 1),
                           p2 = m.face_position(f, 2);
            if (!mine(p0) && !mine(p1) && !mine(p2)) continue;
            const glm::dvec3 n = m.face_normal_unnormalized(f);
            const double len = glm::length(n);
            if (len == 0.0) continue;
            const glm::dvec3 unit = n / len;
            const glm::dvec3 x0 = m.positions[p0];
            const Quadric plane = Quadric::plane(unit, -glm::dot(unit, x0), 0.5 * len);
            for (uint32_t p : {p0, p1, p2}) {
                if (mine(p)) q[p] += plane;
            }
        }
        for (const ConstraintEdge& e : m.constraint_edges) {
            if (!mine(e.a) && !mine(e.b)) continue;
            const glm::dvec3 pa = m.positions[e.a], pb = m.positions[e.b];
            const glm::dvec3 n = m.face_normal_unnormalized(e.face);
            const glm::dvec3 perp = glm::cross(pb - pa, n);
            const double len = glm::length(perp);
            if (len == 0.0) continue;
            const glm::dvec3 unit = perp / len;
            const double el2 = glm::dot(pb - pa, pb - pa);
            Quadric plane = Quadric::plane(unit, -glm::dot(unit, pa), kBoundaryWeight * el2);
            plane.weight = 0.0;  // note: not surface area, keep it out of the error estimate
            if (mine(e.a)) q[e.a] += plane;
            if (mine(e.b)) q[e.b] += plane;
        }
    };
    if (m.split) {
        m.split->run(half);
    } else {
        half(0);
        half(1);
    }
    return quadrics;
}

glm::dvec3 optimal_placement(const Quadric& q, const glm::dvec3& p0, const glm::dvec3& p1,
                             double& cost) {
    // 3x3 solve A x = -b by cofactors, accepted when the determinant is not tiny relative to the
    // matrix scale and the point is not far off the edge.
    const double a00 = q.a00, a01 = q.a01, a02 = q.a02, a11 = q.a11, a12 = q.a12, a22 = q.a22;
    const double c00 = a11 * a22 - a12 * a12;
    const double c01 = a02 * a12 - a01 * a22;
    const double c02 = a01 * a12 - a02 * a11;
    const double det = a00 * c00 + a01 * c01 + a02 * c02;
    // note: a sum of plane quadrics is positive semi-definite, so its diagonal is >= 0.
    const double scale = a00 + a11 + a22;
    const double ex = p1.x - p0.x, ey = p1.y - p0.y, ez = p1.z - p0.z;
    const double ee = ex * ex + ey * ey + ez * ez;
    if (scale > 0.0 && std::abs(det) > 1e-9 * scale * scale * scale) {
        const double c11 = a00 * a22 - a02 * a02;
        const double c12 = a01 * a02 - a00 * a12;
        const double c22 = a00 * a11 - a01 * a01;
        const double inv = -1.0 / det;
        const double x = (c00 * q.b0 + c01 * q.b1 + c02 * q.b2) * inv;
        const double y = (c01 * q.b0 + c11 * q.b1 + c12 * q.b2) * inv;
        const double z = (c02 * q.b0 + c12 * q.b1 + c22 * q.b2) * inv;
        const double ox = x - 0.5 * (p0.x + p1.x), oy = y - 0.5 * (p0.y + p1.y),
                     oz = z - 0.5 * (p0.z + p1.z);
        if (ox * ox + oy * oy + oz * oz <= 4.0 * ee) {  // note: false for NaN
            // note: at the minimiser A x = -b, so Q(x) = c + b.x.
            const double r = q.c + q.b0 * x + q.b1 * y + q.b2 * z;
            cost = r > 0.0 ? r : 0.0;
            return {x, y, z};
        }
    }
    const glm::dvec3 e{ex, ey, ez};
    // Minimise along the segment: f(t) = Q(p0 + t e).
    const glm::dvec3 ae{q.a00 * e.x + q.a01 * e.y + q.a02 * e.z,
                        q.a01 * e.x + q.a11 * e.y + q.a12 * e.z,
                        q.a02 * e.x + q.a12 * e.y + q.a22 * e.z};
    const double eae = glm::dot(e, ae);
    const double tie = 1e-8 * scale * ee;
    if (eae > tie) {
        const glm::dvec3 ap0{q.a00 * p0.x + q.a01 * p0.y + q.a02 * p0.z + q.b0,
                             q.a01 * p0.x + q.a11 * p0.y + q.a12 * p0.z + q.b1,
                             q.a02 * p0.x + q.a12 * p0.y + q.a22 * p0.z + q.b2};
        const double t = std::clamp(-glm::dot(e, ap0) / eae, 0.0, 1.0);
        const glm::dvec3 x = p0 + e * t;
        cost = q.evaluate(x);
        return x;
    }
    const glm::dvec3 mid = (p0 + p1) * 0.5;
    const double c0 = q.evaluate(p0), c1 = q.evaluate(p1), cm = q.evaluate(mid);
    if (cm < c0 - tie && cm < c1 - tie) {
        cost = cm;
        return mid;
    }
    cost = c0 <= c1 ? c0 : c1;
    return c0 <= c1 ? p0 : p1;
}

namespace {

// The order of the collapses: the quadric error over W^0.75, W the face area the two quadrics sum
// (1 without area). note: the plain sum of area-weighted squared distances (W^0) is cheapest where
// the area is small, so small features went early and long faces then spanned where they had
// been (a large Hausdorff distance at coarse levels); the mean squared distance (W^1) keeps them
// but spends mean error; W^0.75 keeps most of both (the figures: docs/simplification.md,
// "Measurements behind the engine's choices").
double order_scale(double w) {
    return w > 0.0 ? 1.0 / std::sqrt(w * std::sqrt(w)) : 1.0;
}

class QemCost final : public CollapseCost {
  public:
    void init(const CollapseMesh& m) override { quadrics_ = position_quadrics(m); }

    // note: flattened, so that optimal_placement() is inlined rather than called with the summed
    // quadric in memory: 1.1-2.2 % fewer instructions per simplify(), the same outputs
    // (docs/simplification.md, "Where the difference goes").
    [[gnu::flatten]] bool evaluate(const CollapseMesh& m, uint32_t a, uint32_t b, EdgeMoves moves,
                                   CollapseCandidate& out) override {
        const Quadric& qa = quadrics_[a];
        const Quadric& qb = quadrics_[b];
        Quadric q;
        q.a00 = qa.a00 + qb.a00, q.a01 = qa.a01 + qb.a01, q.a02 = qa.a02 + qb.a02;
        q.a11 = qa.a11 + qb.a11, q.a12 = qa.a12 + qb.a12, q.a22 = qa.a22 + qb.a22;
        q.b0 = qa.b0 + qb.b0, q.b1 = qa.b1 + qb.b1, q.b2 = qa.b2 + qb.b2, q.c = qa.c + qb.c;
        const glm::dvec3 pa = m.positions[a], pb = m.positions[b];
        const double scale = order_scale(qa.weight + qb.weight);
        // note: the error estimate is left to error_of(), for the few candidates applied.
        out.error = -1.0;
        if (moves.merge) {
            out.from = a, out.to = b, out.moves = true;
            out.position = optimal_placement(q, pa, pb, out.cost);
            out.cost *= scale;
            // note: the placement already compared the endpoints, or solved for a point no
            // endpoint beats, so both half-edge moves are dominated.
            return true;
        }
        out.cost = std::numeric_limits<double>::infinity();
        out.moves = false;
        if (moves.a_to_b) {
            out.cost = q.evaluate(pb), out.from = a, out.to = b, out.position = pb;
        }
        if (moves.b_to_a) {
            const double cost = q.evaluate(pa);
            if (cost < out.cost) out.cost = cost, out.from = b, out.to = a, out.position = pa;
        }
        out.cost *= scale;
        return true;
    }

    void prefetch(uint32_t p) const override {
        const char* q = reinterpret_cast<const char*>(&quadrics_[p]);
        __builtin_prefetch(q);
        __builtin_prefetch(q + 80);
    }

    // sqrt(quadric error / area weight): the RMS plane distance in metres.
    double error_of(const CollapseMesh&, const CollapseCandidate& c) override {
        const double w = quadrics_[c.from].weight + quadrics_[c.to].weight;
        return w > 0.0 ? std::sqrt(c.cost / order_scale(w) / w) : 0.0;
    }

    void collapsed(const CollapseMesh&, const CollapseCandidate& c) override {
        quadrics_[c.to] += quadrics_[c.from];
        assert(std::isfinite(quadrics_[c.to].c) && std::isfinite(quadrics_[c.to].weight));
    }

  private:
    Scratch<Quadric> quadrics_;
};

}  // namespace

std::unique_ptr<CollapseCost> make_qem_cost() {
    return std::make_unique<QemCost>();
}

}  // namespace hmdnode::lod_detail
