// optimal_placement() (lod/src/simplify/qem.cpp), the placement of Garland-Heckbert's QEM, against
// closed-form answers: the minimiser of a full-rank quadric; the segment minimiser when the
// quadric is singular; an endpoint, never a point chosen by rounding noise, when the quadric is
// flat along the edge (an edge along a crease or in a plane).
#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "../../lod/src/simplify/quadric.hpp"

namespace hmdnode::lod_detail {
namespace {

Quadric plane_through(const glm::dvec3& n, const glm::dvec3& point, double area) {
    const glm::dvec3 u = glm::normalize(n);
    return Quadric::plane(u, -glm::dot(u, point), area);
}

TEST(QemPlacement, FullRankQuadricGivesTheCornerOfItsThreePlanes) {
    const glm::dvec3 corner{0.3, -0.2, 0.1};
    const Quadric q = plane_through({1, 0, 0}, corner, 1.0) +
                      plane_through({0, 1, 0}, corner, 2.0) + plane_through({1, 1, 1}, corner, 0.5);
    double cost = -1.0;
    const glm::dvec3 x = optimal_placement(q, {0, 0, 0}, {0.5, -0.5, 0.2}, cost);
    EXPECT_NEAR(glm::length(x - corner), 0.0, 1e-12);
    EXPECT_NEAR(cost, 0.0, 1e-12);
}

TEST(QemPlacement, SingularQuadricGivesTheBestPointOfTheEdge) {
    // Two planes meeting in the line x = 0.25, y = 0 (along z); the edge crosses it at t = 0.25.
    const Quadric q =
        plane_through({1, 0, 0}, {0.25, 0, 0}, 1.0) + plane_through({0, 1, 0}, {0.25, 0, 0}, 1.0);
    double cost = -1.0;
    const glm::dvec3 x = optimal_placement(q, {0, 0, 0}, {1, 0, 0}, cost);
    EXPECT_NEAR(x.x, 0.25, 1e-12);
    EXPECT_NEAR(x.y, 0.0, 1e-12);
    EXPECT_NEAR(cost, 0.0, 1e-12);
}

// An edge along a crease in a general direction: the two planes of the crease contain the edge,
// so every point of it costs 0 up to rounding. The rounding left a tiny curvature along the edge,
// and the segment minimiser then put the point anywhere on it (the fandisk's crease vertices slid
// along their creases). Within rounding the cost is flat, so an endpoint is kept.
TEST(QemPlacement, FlatAlongTheEdgeKeepsAnEndpoint) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    int interior = 0;
    for (int i = 0; i < 200; ++i) {
        const glm::dvec3 d = glm::normalize(glm::dvec3{u(rng), u(rng), u(rng)});
        const glm::dvec3 p0{u(rng), u(rng), u(rng)};
        const glm::dvec3 p1 = p0 + d * (0.1 + std::abs(u(rng)));
        const glm::dvec3 side = glm::normalize(glm::cross(d, glm::dvec3{u(rng), u(rng), u(rng)}));
        const glm::dvec3 other = glm::normalize(glm::cross(d, side) + 0.3 * side);
        const Quadric q = plane_through(side, p0, 1.0 + std::abs(u(rng))) +
                          plane_through(other, p0, 1.0 + std::abs(u(rng)));
        double cost = -1.0;
        const glm::dvec3 x = optimal_placement(q, p0, p1, cost);
        EXPECT_LT(cost, 1e-12);
        if (x != p0 && x != p1) ++interior;
    }
    EXPECT_EQ(interior, 0);
}

// A plane with the edge in it: the same (the point stays where a vertex is).
TEST(QemPlacement, EdgeInAPlaneKeepsAnEndpoint) {
    const glm::dvec3 n = glm::normalize(glm::dvec3{0.2, 0.7, -0.4});
    const glm::dvec3 p0{0.5, 0.1, 0.3};
    const glm::dvec3 p1 = p0 + glm::normalize(glm::cross(n, glm::dvec3{1, 0, 0})) * 0.37;
    double cost = -1.0;
    const glm::dvec3 x = optimal_placement(plane_through(n, p0, 2.0), p0, p1, cost);
    EXPECT_TRUE(x == p0 || x == p1);
    EXPECT_LT(cost, 1e-12);
}

}  // namespace
}  // namespace hmdnode::lod_detail
