// Formula 1 of Lazányi 2003 (cost "formula1"): cost(e) = |e| / (n1 . n2), the edge length over the
// dot product of the unit normals of the two faces beside the edge; the edge is collapsed onto one
// of its endpoints (half-edge collapse), as the paper does.
//
// Paper: I. Zs. Lazányi, "... virtual worlds for virtual reality applications", Central European
// Seminar on Computer Graphics (CESCG) 2003, Budapest University of Technology and Economics (the
// first words of the title are missing from our copy; docs/references.md), section 2.2, Formula 1
// and Figure 4: the cost grows with the length and with the "crack" between the two faces and is
// infinite at a right angle. The paper notes it is short-sighted: on a cube split into triangles, a
// face diagonal has parallel face normals, so it is among the cheapest edges and its collapse pulls
// a corner across the face (Figure 5).
//
// Edge cases the paper leaves open, and what we do:
// - n1 . n2 <= 0 (a right or wider angle): "infinite". We use 1e20 * |e|, so such edges go last,
//   shortest first, rather than never (simplify() must reach its target when the engine allows);
// - a border edge has one face: n1 = n2, cost = |e|;
// - direction: the formula is symmetric; we remove the endpoint with the lower id among those the
//   engine's rules (seams, borders) allow, a deterministic stand-in for the paper's
//   unspecified choice.
// The engine's rules (no flip, link condition, seams, borders) apply as for every cost.
// The estimated error is unknown (-1): the cost is not a distance.
//
// Cost: O(valence) per edge evaluation (find the two faces); ring re-evaluation after each
// collapse, since the cost of an edge reads the faces beside it; O(E log E) overall.
#include <cmath>
#include <memory>

#include "collapse_engine.hpp"

namespace hmdnode::lod_detail {
namespace {

class Formula1Cost final : public CollapseCost {
  public:
    void init(const CollapseMesh&) override {}

    bool evaluate(const CollapseMesh& m, uint32_t a, uint32_t b, EdgeMoves moves,
                  CollapseCandidate& out) override {
        glm::dvec3 normals[2];
        int faces = 0;
        m.for_each_face(a, [&](uint32_t f, int k) {
            if (m.face_position(f, (k + 1) % 3) != b && m.face_position(f, (k + 2) % 3) != b) {
                return;
            }
            if (faces < 2) {
                normals[faces] =
                    m.face_unit_normals.empty() ? m.face_unit_normal(f) : m.face_unit_normals[f];
            }
            ++faces;
        });
        if (faces == 0 || faces > 2) return false;
        const double dot = faces == 1 ? 1.0 : glm::dot(normals[0], normals[1]);
        const double length = glm::length(glm::dvec3(m.positions[b]) - glm::dvec3(m.positions[a]));
        const double cost = dot > 0.0 ? length / dot : 1e20 * length;
        const bool remove_a = moves.a_to_b && (!moves.b_to_a || a < b);
        const uint32_t from = remove_a ? a : b, to = remove_a ? b : a;
        out = {cost, from, to, false, glm::dvec3(m.positions[to]), -1.0};
        return true;
    }

    bool depends_on_ring() const override { return true; }
};

}  // namespace

std::unique_ptr<CollapseCost> make_formula1_cost() {
    return std::make_unique<Formula1Cost>();
}

}  // namespace hmdnode::lod_detail
