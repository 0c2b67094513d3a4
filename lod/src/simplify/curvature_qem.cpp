// Curvature-weighted QEM (cost "curvature-qem").
//
// Paper: J. He, P. Wang, J. Zhu, J. Zeng, "Application and Optimization of Mesh Simplification in
// 3D virtual Reality Scene in a High-performance Environment" (venue and year not stated in our
// copy; docs/references.md), LOD generation with an improved QEM, eq. (7)-(12): collapsing (v_i,
// v_j) to v costs |v_i v_j| * v^T (K_abs,i Q_i + K_abs,j Q_j) v, with Q the Garland-Heckbert
// quadrics and K_abs = |k1| + |k2|, k1,2 = H +- sqrt(max(H^2 - K, 0)) from the mean curvature H and
// the Gaussian curvature K of each vertex; the new point minimises the weighted quadric (the same
// placement as qem.cpp: 3x3 solve, else on the edge, else endpoints or midpoint).
//
// Departures:
// - H and K are the discrete operators of Meyer, Desbrun, Schroeder & Barr, "Discrete
//   differential-geometry operators for triangulated 2-manifolds", Visualization and Mathematics
//   III, Springer 2003: H = |sum (cot a + cot b) (x_i - x_j)| / (4 A_mixed) (cotangent Laplacian)
//   and K = (2 pi - sum theta) / A_mixed (angle deficit; pi on a border), with the mixed Voronoi
//   area. The paper's eq. (7) sums dihedral angles instead; the cotangent form is the standard
//   estimator and converges on smooth surfaces.
// - Flat regions have K_abs = 0, which would make their quadrics vanish: every flat edge would
//   cost 0 and, once merged with a curved vertex, would no longer hold the point on its plane. We
//   weight by K_abs + eps with eps = 1 / (bounding-box diagonal), the curvature of a sphere twice
//   the model's size, so flat regions still simplify first but keep their planes.
// - The weight is taken once on the input; a merged position carries the sum of its weighted
//   quadrics (K_abs,i Q_i + K_abs,j Q_j), as the formula does for one collapse.
// - The estimated error is that of the unweighted quadrics (RMS plane distance, metres).
//
// Cost: O(F) for the curvatures and quadrics (two quadrics per position, 176 bytes); O(1) per
// edge evaluation; the engine's O(E log E) for the rest.
#include <cassert>
#include <cmath>
#include <limits>
#include <memory>
#include <numbers>

#include "collapse_engine.hpp"
#include "quadric.hpp"

namespace hmdnode::lod_detail {
namespace {

std::vector<double> absolute_curvature(const CollapseMesh& m) {
    const size_t np = m.positions.size();
    std::vector<glm::dvec3> laplacian(np, glm::dvec3(0.0));
    std::vector<double> area(np, 0.0), angle(np, 0.0);
    for (uint32_t f = 0; f < uint32_t(m.face_alive.size()); ++f) {
        if (!m.face_alive[f]) continue;
        uint32_t id[3];
        glm::dvec3 p[3];
        for (int k = 0; k < 3; ++k) id[k] = m.face_position(f, k), p[k] = m.positions[id[k]];
        const double face_area = 0.5 * glm::length(glm::cross(p[1] - p[0], p[2] - p[0]));
        if (face_area == 0.0) continue;
        double cot[3], ang[3];
        for (int k = 0; k < 3; ++k) {
            const glm::dvec3 a = p[(k + 1) % 3] - p[k], b = p[(k + 2) % 3] - p[k];
            const double s = glm::length(glm::cross(a, b)), c = glm::dot(a, b);
            cot[k] = c / s;
            ang[k] = std::atan2(s, c);
        }
        const bool obtuse = ang[0] > std::numbers::pi / 2 || ang[1] > std::numbers::pi / 2 ||
                            ang[2] > std::numbers::pi / 2;
        for (int i = 0; i < 3; ++i) {
            const int j = (i + 1) % 3, k = (i + 2) % 3;
            laplacian[id[i]] += cot[k] * (p[i] - p[j]) + cot[j] * (p[i] - p[k]);
            angle[id[i]] += ang[i];
            if (!obtuse) {
                const glm::dvec3 eij = p[j] - p[i], eik = p[k] - p[i];
                area[id[i]] += (glm::dot(eij, eij) * cot[k] + glm::dot(eik, eik) * cot[j]) / 8.0;
            } else {
                area[id[i]] += ang[i] > std::numbers::pi / 2 ? face_area / 2 : face_area / 4;
            }
        }
    }
    std::vector<double> k_abs(np, 0.0);
    for (size_t i = 0; i < np; ++i) {
        if (area[i] <= 0.0) continue;
        const double h = glm::length(laplacian[i]) / (4.0 * area[i]);
        const double full = m.on_border[i] ? std::numbers::pi : 2.0 * std::numbers::pi;
        const double k = (full - angle[i]) / area[i];
        const double root = std::sqrt(std::max(h * h - k, 0.0));
        k_abs[i] = std::abs(h + root) + std::abs(h - root);
    }
    return k_abs;
}

class CurvatureQemCost final : public CollapseCost {
  public:
    void init(const CollapseMesh& m) override {
        plain_ = position_quadrics(m);
        const std::vector<double> k_abs = absolute_curvature(m);
        const double diagonal = m.bbox_diagonal();
        const double eps = diagonal > 0.0 ? 1.0 / diagonal : 1.0;
        weighted_.resize(plain_.size());
        for (size_t i = 0; i < plain_.size(); ++i) weighted_[i] = plain_[i] * (k_abs[i] + eps);
    }

    bool evaluate(const CollapseMesh& m, uint32_t a, uint32_t b, EdgeMoves moves,
                  CollapseCandidate& out) override {
        const Quadric q = weighted_[a] + weighted_[b];
        const glm::dvec3 pa = m.positions[a], pb = m.positions[b];
        const double length = glm::length(pb - pa);
        out.cost = std::numeric_limits<double>::infinity();
        if (moves.merge) {
            double cost = 0.0;
            const glm::dvec3 x = optimal_placement(q, pa, pb, cost);
            out = {length * cost, a, b, true, x, -1.0};
        }
        if (moves.a_to_b) {
            const double cost = length * q.evaluate(pb);
            if (cost < out.cost) out = {cost, a, b, false, pb, -1.0};
        }
        if (moves.b_to_a) {
            const double cost = length * q.evaluate(pa);
            if (cost < out.cost) out = {cost, b, a, false, pa, -1.0};
        }
        const Quadric plain = plain_[a] + plain_[b];
        out.error =
            plain.weight > 0.0 ? std::sqrt(plain.evaluate(out.position) / plain.weight) : 0.0;
        return true;
    }

    void collapsed(const CollapseMesh&, const CollapseCandidate& c) override {
        weighted_[c.to] += weighted_[c.from];
        plain_[c.to] += plain_[c.from];
        assert(std::isfinite(weighted_[c.to].c) && std::isfinite(plain_[c.to].c));
    }

  private:
    Scratch<Quadric> plain_, weighted_;
};

}  // namespace

std::unique_ptr<CollapseCost> make_curvature_qem_cost() {
    return std::make_unique<CurvatureQemCost>();
}

}  // namespace hmdnode::lod_detail
