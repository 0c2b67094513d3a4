// Melax's cost, Formula 2 of Lazányi 2003 (cost "melax"): collapsing u onto v costs
//   |u - v| * max over faces f around u of ( min over faces n on the edge uv of (1 - f.n . n.n)/2 )
// with unit face normals; the edge is collapsed onto an endpoint (half-edge collapse), in the
// cheaper of the directions the engine's rules allow.
//
// Papers: S. Melax, "A simple, fast and effective polygon reduction algorithm", Game Developer,
// November 1998; I. Zs. Lazányi, "... virtual worlds for virtual reality applications", Central
// European Seminar on Computer Graphics (CESCG) 2003, Budapest University of Technology and
// Economics (the first words of the title are missing from our copy; docs/references.md), section
// 2.2, Formula 2 and Figures 6-7: on a flat surface the cost is 0; across a cube's face diagonal, a
// face of u in a perpendicular side gives (1 - 0)/2 = 0.5, so the diagonal waits until nothing
// cheaper is left (unlike Formula 1).
//
// Departures: none in the cost. faces(u) includes the faces on the edge (they contribute 0, as in
// Melax's code). Border edges have one face on the edge; Melax's code special-cases nothing for
// them either, the engine keeps border vertices on the border. The estimated error is unknown
// (-1): the cost is not a distance.
//
// Cost: O(valence) per direction per edge evaluation; ring re-evaluation after each collapse,
// since the cost reads the faces around an endpoint; O(E log E) overall.
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>

#include "collapse_engine.hpp"

namespace hmdnode::lod_detail {
namespace {

glm::dvec3 unit_normal(const CollapseMesh& m, uint32_t f) {
    return m.face_unit_normals.empty() ? m.face_unit_normal(f) : m.face_unit_normals[f];
}

class MelaxCost final : public CollapseCost {
  public:
    void init(const CollapseMesh&) override {}

    bool evaluate(const CollapseMesh& m, uint32_t a, uint32_t b, EdgeMoves moves,
                  CollapseCandidate& out) override {
        glm::dvec3 edge_normals[2];
        int edge_faces = 0;
        m.for_each_face(a, [&](uint32_t f, int k) {
            if (m.face_position(f, (k + 1) % 3) != b && m.face_position(f, (k + 2) % 3) != b) {
                return;
            }
            if (edge_faces < 2) edge_normals[edge_faces] = unit_normal(m, f);
            ++edge_faces;
        });
        if (edge_faces == 0 || edge_faces > 2) return false;
        const double length = glm::length(glm::dvec3(m.positions[b]) - glm::dvec3(m.positions[a]));
        auto directed = [&](uint32_t u) {
            double curvature = 0.0;
            m.for_each_face(u, [&](uint32_t f, int) {
                const glm::dvec3 n = unit_normal(m, f);
                double lowest = 1.0;
                for (int i = 0; i < edge_faces; ++i) {
                    lowest = std::min(lowest, (1.0 - glm::dot(n, edge_normals[i])) * 0.5);
                }
                curvature = std::max(curvature, lowest);
            });
            return length * curvature;
        };
        out.cost = std::numeric_limits<double>::infinity();
        if (moves.a_to_b) out = {directed(a), a, b, false, glm::dvec3(m.positions[b]), -1.0};
        if (moves.b_to_a) {
            const double cost = directed(b);
            if (cost < out.cost) out = {cost, b, a, false, glm::dvec3(m.positions[a]), -1.0};
        }
        return true;
    }

    bool depends_on_ring() const override { return true; }
};

}  // namespace

std::unique_ptr<CollapseCost> make_melax_cost() {
    return std::make_unique<MelaxCost>();
}

}  // namespace hmdnode::lod_detail
