#include "hmdnode/lod/mesh_distance.hpp"
#include "hmdnode/lod/simplify.hpp"
#include "lod/test_meshes.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <utility>

#include <gtest/gtest.h>

namespace hmdnode {
namespace {

// The rectangle [0,w] x [0,1] at height z, two triangles.
Primitive rectangle(float w, float z) {
    Primitive p;
    p.positions = {{0, 0, z}, {w, 0, z}, {w, 1, z}, {0, 1, z}};
    p.indices = {0, 1, 2, 0, 2, 3};
    return p;
}

// The unit square cut into four triangles around its centre, raised to height h.
Primitive pyramid(float h) {
    Primitive p;
    p.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0.5f, 0.5f, h}};
    p.indices = {0, 1, 4, 1, 2, 4, 2, 3, 4, 3, 0, 4};
    return p;
}

// Unit-sphere icosphere: the icosahedron with each triangle split into 4, `levels` times.
Primitive icosphere(int levels) {
    return test::unit_icosphere(levels);
}

// Largest depth of a face below the unit sphere: 1 - the smallest distance from the origin to
// the plane of a face (the foot of that perpendicular lies inside the near-equilateral faces).
double sagitta(const Primitive& p) {
    double min_dist = 1.0;
    for (size_t i = 0; i < p.indices.size(); i += 3) {
        const glm::dvec3 a(p.positions[p.indices[i]]), b(p.positions[p.indices[i + 1]]),
            c(p.positions[p.indices[i + 2]]);
        const glm::dvec3 n = glm::normalize(glm::cross(b - a, c - a));
        min_dist = std::min(min_dist, std::abs(glm::dot(n, a)));
    }
    return 1.0 - min_dist;
}

TEST(MeshDistance, ParallelSquaresAreTheirSpacingApart) {
    const MeshDistance d = measure_mesh_distance(rectangle(1, 0), rectangle(1, 0.1f));
    EXPECT_NEAR(d.hausdorff, 0.1, 1e-6);
    EXPECT_NEAR(d.mean, 0.1, 1e-6);
    EXPECT_NEAR(d.rms, 0.1, 1e-6);
    EXPECT_NEAR(d.forward.max, 0.1, 1e-6);
    EXPECT_NEAR(d.backward.mean, 0.1, 1e-6);
    EXPECT_NEAR(d.diagonal, std::sqrt(2.0), 1e-6);
    EXPECT_NEAR(d.hausdorff_pct(), 10.0 / std::sqrt(2.0), 1e-4);
    EXPECT_GE(d.forward.samples, 1024u);  // the default's floor
    // Every corner's nearest triangle lies in the parallel plane, so the convex bound is exact.
    EXPECT_NEAR(d.hausdorff_upper, 0.1, 1e-6);
    EXPECT_LT(d.mean_stderr, 1e-6);
}

TEST(MeshDistance, IdenticalMeshesAreZeroApart) {
    const Primitive s = icosphere(2);
    const MeshDistance d = measure_mesh_distance(s, s);
    EXPECT_LT(d.hausdorff, 1e-6);
    EXPECT_LT(d.mean, 1e-7);
}

TEST(MeshDistance, RaisedCentreGivesClosedFormDistances) {
    const double h = 0.2;
    MeshDistanceOptions o;
    o.samples = 200'000;
    const MeshDistance d = measure_mesh_distance(pyramid(float(h)), pyramid(0.0f), o);
    // Pyramid -> flat: the distance is the height z, linear on each face: max h at the apex,
    // area mean h / 3, rms h / sqrt(6).
    EXPECT_NEAR(d.forward.max, h, 1e-6);
    EXPECT_NEAR(d.forward.mean, h / 3.0, 1e-3 * h);
    EXPECT_NEAR(d.forward.rms, h / std::sqrt(6.0), 1e-3 * h);
    // Flat -> pyramid: the distance to a face's plane, z_face * 0.5 / sqrt(h^2 + 0.25), largest
    // under the apex (the flat mesh's centre vertex).
    const double k = 0.5 / std::sqrt(h * h + 0.25);
    EXPECT_NEAR(d.backward.max, h * k, 1e-6);
    EXPECT_NEAR(d.backward.mean, h * k / 3.0, 1e-3 * h);
    EXPECT_NEAR(d.hausdorff, h, 1e-6);
}

TEST(MeshDistance, ForwardAndBackwardAreSeparate) {
    // The unit square inside the 2 x 1 rectangle: square -> rectangle is 0; rectangle -> square
    // is the distance to x = 1 on the right half: max 1, mean 0.25, rms sqrt(1/6).
    const MeshDistance d = measure_mesh_distance(rectangle(1, 0), rectangle(2, 0));
    EXPECT_LT(d.forward.max, 1e-6);
    EXPECT_NEAR(d.backward.max, 1.0, 1e-6);
    EXPECT_NEAR(d.backward.mean, 0.25, 1e-3);
    EXPECT_NEAR(d.backward.rms, std::sqrt(1.0 / 6.0), 1e-3);
    EXPECT_NEAR(d.hausdorff, 1.0, 1e-6);
}

TEST(MeshDistance, IcospheresAreWithinTheirSagittas) {
    // Both meshes are inscribed in the unit sphere: by the triangle inequality the Hausdorff
    // distance lies between s_coarse - s_fine and s_coarse + s_fine (s: a mesh's sagitta).
    const Primitive coarse = icosphere(1), fine = icosphere(4);
    const double sc = sagitta(coarse), sf = sagitta(fine);
    const MeshDistance d = measure_mesh_distance(coarse, fine);
    EXPECT_GE(d.hausdorff, sc - sf);
    EXPECT_LE(d.hausdorff, sc + sf);
    // And the distance falls as the coarse mesh gets finer.
    const MeshDistance d2 = measure_mesh_distance(icosphere(2), fine);
    const MeshDistance d3 = measure_mesh_distance(icosphere(3), fine);
    EXPECT_GT(d.hausdorff, d2.hausdorff);
    EXPECT_GT(d2.hausdorff, d3.hausdorff);
    EXPECT_GT(d.mean, d2.mean);
    EXPECT_GT(d2.mean, d3.mean);
}

TEST(MeshDistance, IsReproducibleAndThreadIndependent) {
    MeshDistanceOptions one;
    one.threads = 1;
    one.samples = 20'000;
    MeshDistanceOptions four = one;
    four.threads = 4;
    const MeshDistance a = measure_mesh_distance(icosphere(1), icosphere(3), one);
    const MeshDistance b = measure_mesh_distance(icosphere(1), icosphere(3), four);
    EXPECT_DOUBLE_EQ(a.hausdorff, b.hausdorff);
    EXPECT_NEAR(a.mean, b.mean, 1e-12);
}

TEST(MeshDistance, TwoThreadsGiveTheOneThreadFiguresBitForBit) {
    // With two threads the directions run at once, each as it runs alone: every figure the same
    // (hmdnode lod's output must not depend on --measure-threads 1 or 2), with prism bounds too.
    const Primitive fine = test::unit_icosphere(4);
    const size_t targets[] = {600, 60};
    const Result<std::vector<SimplifiedLevel>> levels = simplify(fine, "qem", targets);
    ASSERT_TRUE(levels.ok());
    for (bool prism : {false, true})
        for (const SimplifiedLevel& l : *levels) {
            MeshDistanceOptions one;
            one.threads = 1;
            one.prism_bounds = prism;
            MeshDistanceOptions two = one;
            two.threads = 2;
            const MeshDistance a = measure_mesh_distance(fine, l.primitive, one);
            const MeshDistance b = measure_mesh_distance(fine, l.primitive, two);
            EXPECT_GT(a.hausdorff, 0.0);
            EXPECT_EQ(a.hausdorff, b.hausdorff);
            EXPECT_EQ(a.hausdorff_upper, b.hausdorff_upper);
            EXPECT_EQ(a.mean, b.mean);
            EXPECT_EQ(a.mean_stderr, b.mean_stderr);
            EXPECT_EQ(a.rms, b.rms);
            EXPECT_EQ(a.forward.queries, b.forward.queries);
            EXPECT_EQ(a.backward.max_upper, b.backward.max_upper);
        }
}

// The unit square turned by `angle` about its edge on the x axis.
Primitive tilted_square(double angle) {
    Primitive p = rectangle(1, 0);
    for (glm::vec3& v : p.positions)
        v = glm::vec3(v.x, float(v.y * std::cos(angle)), float(v.y * std::sin(angle)));
    return p;
}

// A closed polyhedron scaled about the origin.
Primitive scaled(Primitive p, float s) {
    for (glm::vec3& v : p.positions) v *= s;
    return p;
}

// The true value lies in [hausdorff, hausdorff_upper] and within 3 standard errors of the mean.
void expect_brackets(const MeshDistance& d, double hausdorff, double mean) {
    EXPECT_LE(d.hausdorff, hausdorff + 1e-6);
    EXPECT_GE(d.hausdorff_upper, hausdorff - 1e-6);
    EXPECT_LE(std::abs(d.mean - mean), 3.0 * d.mean_stderr + 1e-6)
        << "mean " << d.mean << " stderr " << d.mean_stderr << " true " << mean;
}

TEST(MeshDistanceBounds, TiltedSquareIsBracketed) {
    // Square -> its copy turned by a about an edge: the distance to the plane, y sin a (the foot
    // of the perpendicular stays on the square), both ways: Hausdorff sin a, mean sin(a) / 2.
    for (double a : {0.05, 0.3, 1.0}) {
        const MeshDistance d = measure_mesh_distance(rectangle(1, 0), tilted_square(a));
        expect_brackets(d, std::sin(a), std::sin(a) / 2.0);
        EXPECT_NEAR(d.hausdorff, std::sin(a), 1e-6);  // at the far corner, a vertex
        EXPECT_GT(d.mean_stderr, 0.0);
    }
}

TEST(MeshDistanceBounds, ScaledPolyhedronHasClosedFormDistances) {
    // A convex polyhedron P (circumradius R, inradius h) and sP, s < 1: P -> sP is largest at the
    // vertices, (1 - s) R (by symmetry the nearest point of sP to a vertex v is s v); every point
    // of sP is (1 - s) h from the boundary of P (its own face's parallel plane is the nearest).
    const Primitive p = icosphere(0);  // the icosahedron, R = 1
    const double h = 1.0 - sagitta(p), s = 0.8;
    const MeshDistance d = measure_mesh_distance(p, scaled(p, float(s)));
    EXPECT_NEAR(d.hausdorff, (1 - s), 1e-6);
    EXPECT_GE(d.hausdorff_upper, (1 - s) - 1e-6);
    EXPECT_LE(d.hausdorff_upper, (1 - s) * 1.01);  // refined to within 1 %
    EXPECT_NEAR(d.backward.mean, (1 - s) * h, 1e-6);
    EXPECT_NEAR(d.backward.max_upper, (1 - s) * h, 1e-6);  // constant: exact
    EXPECT_LE(d.backward.mean_stderr, 1e-6);
}

TEST(MeshDistanceBounds, RaisedCentreMeanIsWithinItsStandardError) {
    const double h = 0.2;
    const MeshDistance d = measure_mesh_distance(pyramid(float(h)), pyramid(0.0f));
    EXPECT_LE(std::abs(d.forward.mean - h / 3.0), 3.0 * d.forward.mean_stderr);
    EXPECT_GT(d.forward.mean_stderr, 0.0);
    EXPECT_LE(d.forward.max, h + 1e-6);
    EXPECT_GE(d.forward.max_upper, h - 1e-6);
}

TEST(MeshDistanceBounds, UpperBoundHoldsAgainstADenseMeasurement) {
    // The default measurement's upper bound is above what 400 000 samples per direction find, and
    // its lower bound below the dense upper bound, on curved meshes where nothing is exact.
    MeshDistanceOptions dense;
    dense.samples = 400'000;
    dense.threads = 0;
    for (auto [ca, cb] : {std::pair{1, 3}, std::pair{2, 4}}) {
        const Primitive a = icosphere(cb), b = icosphere(ca);
        const MeshDistance quick = measure_mesh_distance(a, b);
        const MeshDistance full = measure_mesh_distance(a, b, dense);
        EXPECT_GE(quick.hausdorff_upper, full.hausdorff);
        EXPECT_LE(quick.hausdorff, full.hausdorff_upper);
        EXPECT_LE(quick.hausdorff, quick.hausdorff_upper);
        EXPECT_LE(std::abs(quick.mean - full.mean),
                  3.0 * (quick.mean_stderr + full.mean_stderr) + 1e-9);
    }
}

TEST(MeshDistanceBounds, CornerCoveringRadiusIsTheFarthestPoint) {
    // Closed forms: the equilateral triangle's circumradius 1/sqrt(3); a right triangle's half
    // hypotenuse; and, for any triangle, the largest distance of a point to its nearest corner,
    // found on a fine grid of points, at most the radius and close to it.
    using glm::dvec3;
    EXPECT_NEAR(corner_covering_radius({0, 0, 0}, {1, 0, 0}, {0.5, std::sqrt(0.75), 0}),
                1 / std::sqrt(3.0), 1e-12);
    EXPECT_NEAR(corner_covering_radius({0, 0, 0}, {1, 0, 0}, {0, 1, 0}), std::sqrt(0.5), 1e-12);
    EXPECT_EQ(corner_covering_radius({1, 1, 1}, {1, 1, 1}, {1, 1, 1}), 0.0);
    const dvec3 tris[][3] = {{{0, 0, 0}, {1, 0, 0}, {0.5, 0.01, 0}},   // sliver
                             {{0, 0, 0}, {1, 0, 0}, {0.2, 0.3, 0.1}},  // obtuse
                             {{0, 0, 0}, {1, 0, 0}, {0.4, 0.8, 0}},    // acute
                             {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}}};       // flat
    for (const auto& t : tris) {
        const double r = corner_covering_radius(t[0], t[1], t[2]);
        double far = 0.0;
        const int n = 400;
        for (int i = 0; i <= n; ++i)
            for (int j = 0; i + j <= n; ++j) {
                const dvec3 p =
                    t[0] + (t[1] - t[0]) * (double(i) / n) + (t[2] - t[0]) * (double(j) / n);
                far = std::max(far, std::min({glm::length(p - t[0]), glm::length(p - t[1]),
                                              glm::length(p - t[2])}));
            }
        EXPECT_LE(far, r + 1e-12);
        EXPECT_GE(far, r * 0.99);
    }
}

TEST(MeshDistanceBounds, AReferenceMeasuresLikeTheOneCall) {
    const Primitive a = icosphere(3);
    const MeshDistanceReference ref(view_of(a));
    for (int level : {0, 1, 2}) {
        const Primitive b = icosphere(level);
        const MeshDistance x = ref.measure(view_of(b)), y = measure_mesh_distance(a, b);
        EXPECT_EQ(x.hausdorff, y.hausdorff);
        EXPECT_EQ(x.hausdorff_upper, y.hausdorff_upper);
        EXPECT_EQ(x.mean, y.mean);
    }
}

// The icosphere with every vertex moved along its radius by a hash of its index (up to +-amp):
// a bumpy closed surface where no distance has a closed form.
Primitive bumpy_sphere(int levels, float amp) {
    Primitive p = icosphere(levels);
    for (size_t i = 0; i < p.positions.size(); ++i) {
        uint32_t h = uint32_t(i) * 2654435761u;
        h ^= h >> 15, h *= 2246822519u, h ^= h >> 13;
        p.positions[i] *= 1.0f + amp * (float(h % 2001) / 1000.0f - 1.0f);
    }
    return p;
}

// Brute force over every triangle of `to`: the distance from p to the surface.
double brute_distance(const glm::dvec3& p, const Primitive& to) {
    double best = 1e300;
    for (size_t i = 0; i < to.indices.size(); i += 3) {
        const glm::dvec3 a(to.positions[to.indices[i]]), b(to.positions[to.indices[i + 1]]),
            c(to.positions[to.indices[i + 2]]);
        // The nearest point: inside the triangle's plane projection, else on an edge.
        const glm::dvec3 n = glm::cross(b - a, c - a);
        const double n2 = glm::dot(n, n);
        if (n2 > 0.0) {
            const glm::dvec3 q = p - n * (glm::dot(p - a, n) / n2);
            const double u = glm::dot(glm::cross(b - q, c - q), n),
                         v = glm::dot(glm::cross(c - q, a - q), n),
                         w = glm::dot(glm::cross(a - q, b - q), n);
            if (u >= 0 && v >= 0 && w >= 0) {
                best = std::min(best, glm::length(p - q));
                continue;
            }
        }
        for (auto [s0, s1] : {std::pair{a, b}, std::pair{b, c}, std::pair{c, a}}) {
            const glm::dvec3 d = s1 - s0;
            const double len2 = glm::dot(d, d);
            const double t = len2 > 0 ? std::clamp(glm::dot(p - s0, d) / len2, 0.0, 1.0) : 0.0;
            best = std::min(best, glm::length(p - (s0 + t * d)));
        }
    }
    return best;
}

// The one-sided Hausdorff distance from `from` to `to` to within `slack`: the largest brute-force
// distance over a grid of n x n points per triangle of `from` (each point of a triangle is within
// its grid cell's covering radius of a grid point, and the distance is 1-Lipschitz, so the true
// value lies in [max, max + largest cell radius]).
std::pair<double, double> brute_hausdorff(const Primitive& from, const Primitive& to, int n) {
    double max = 0.0, slack = 0.0;
    for (size_t i = 0; i < from.indices.size(); i += 3) {
        const glm::dvec3 a(from.positions[from.indices[i]]), b(from.positions[from.indices[i + 1]]),
            c(from.positions[from.indices[i + 2]]);
        slack = std::max(
            slack, corner_covering_radius(a, a + (b - a) / double(n), a + (c - a) / double(n)));
        for (int u = 0; u <= n; ++u)
            for (int v = 0; u + v <= n; ++v)
                max = std::max(
                    max,
                    brute_distance(a + (b - a) * (double(u) / n) + (c - a) * (double(v) / n), to));
    }
    return {max, slack};
}

// qem's levels of `bumpy` (160, 40 and 12 faces) and a smooth coarse sphere: what the
// brute-force comparisons below measure it against.
std::vector<Primitive> levels_and_a_sphere(const Primitive& bumpy) {
    std::vector<Primitive> out;
    const size_t targets[] = {160, 40, 12};
    const Result<std::vector<SimplifiedLevel>> levels = simplify(bumpy, "qem", targets);
    EXPECT_TRUE(levels.ok());
    if (levels.ok())
        for (const SimplifiedLevel& l : *levels) out.push_back(l.primitive);
    out.push_back(icosphere(1));
    return out;
}

TEST(MeshDistanceBounds, BracketHoldsAgainstABruteForceReference) {
    // A bumpy sphere against qem's levels of it and against a smooth coarse sphere: the default
    // measurement's upper bound is at least the brute-force Hausdorff distance (a grid of 66
    // points per triangle, every triangle of the other mesh), both ways; its lower bound at most
    // that plus the grid's slack, and close to it (within 10 %: the maximum is found).
    const Primitive bumpy = bumpy_sphere(2, 0.05f);
    const std::vector<Primitive> others = levels_and_a_sphere(bumpy);
    for (const Primitive& b : others) {
        const MeshDistance d = measure_mesh_distance(bumpy, b);
        const auto [fwd, fwd_slack] = brute_hausdorff(bumpy, b, 10);
        const auto [bwd, bwd_slack] = brute_hausdorff(b, bumpy, 10);
        const double truth = std::max(fwd, bwd), slack = std::max(fwd_slack, bwd_slack);
        SCOPED_TRACE(testing::Message()
                     << b.triangle_count() << " triangles: brute force " << truth << " (+" << slack
                     << "), bracket " << d.hausdorff << ".." << d.hausdorff_upper);
        EXPECT_GE(d.forward.max_upper, fwd - 1e-9);
        EXPECT_GE(d.backward.max_upper, bwd - 1e-9);
        EXPECT_GE(d.hausdorff_upper, truth - 1e-9);
        EXPECT_LE(d.hausdorff, truth + slack + 1e-9);
        EXPECT_GE(d.hausdorff, 0.9 * truth);
    }
}

TEST(MeshDistanceBounds, PrismBoundsHoldAndCloseTheBracket) {
    // The same meshes with prism bounds: the upper bound still at least the brute-force distance
    // both ways, never above the default measurement's, and within 1 % of a distance measured (the
    // bracket closed; without prism bounds it is 3.7 times that on the 160-triangle level, where
    // the grid of the brute force finds 4 % less than the measured point).
    const Primitive bumpy = bumpy_sphere(2, 0.05f);
    const std::vector<Primitive> others = levels_and_a_sphere(bumpy);
    MeshDistanceOptions prism;
    prism.prism_bounds = true;
    for (const Primitive& b : others) {
        const MeshDistance plain = measure_mesh_distance(bumpy, b);
        const MeshDistance d = measure_mesh_distance(bumpy, b, prism);
        const auto [fwd, fwd_slack] = brute_hausdorff(bumpy, b, 10);
        const auto [bwd, bwd_slack] = brute_hausdorff(b, bumpy, 10);
        const double truth = std::max(fwd, bwd), slack = std::max(fwd_slack, bwd_slack);
        SCOPED_TRACE(testing::Message()
                     << b.triangle_count() << " triangles: brute force " << truth << " (+" << slack
                     << "), bracket " << d.hausdorff << ".." << d.hausdorff_upper << ", without "
                     << plain.hausdorff << ".." << plain.hausdorff_upper);
        EXPECT_GE(d.forward.max_upper, fwd - 1e-9);
        EXPECT_GE(d.backward.max_upper, bwd - 1e-9);
        EXPECT_LE(d.hausdorff, truth + slack + 1e-9);
        EXPECT_LE(d.hausdorff_upper, plain.hausdorff_upper + 1e-12);
        EXPECT_LE(d.hausdorff_upper, 1.01 * d.hausdorff);
    }
}

TEST(MeshDistanceBounds, PrismBoundsHoldOnAnOpenBumpyPatch) {
    // A height field with an open border (where the walks stop) against qem's levels of it: the
    // prism upper bound is at least the brute-force distance both ways.
    Primitive patch;
    const int n = 16;
    for (int j = 0; j <= n; ++j)
        for (int i = 0; i <= n; ++i) {
            const float x = float(i) / n, y = float(j) / n;
            patch.positions.push_back({x, y,
                                       0.06f * std::sin(7.0f * x) * std::cos(5.0f * y) +
                                           0.02f * std::sin(23.0f * x * y)});
        }
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            const uint32_t a = uint32_t(j * (n + 1) + i), b = a + 1, c = a + uint32_t(n + 1),
                           d = c + 1;
            patch.indices.insert(patch.indices.end(), {a, b, d, a, d, c});
        }
    const size_t targets[] = {120, 30};
    const Result<std::vector<SimplifiedLevel>> levels = simplify(patch, "qem", targets);
    ASSERT_TRUE(levels.ok());
    MeshDistanceOptions prism;
    prism.prism_bounds = true;
    for (const SimplifiedLevel& l : *levels) {
        const MeshDistance d = measure_mesh_distance(patch, l.primitive, prism);
        const auto [fwd, fwd_slack] = brute_hausdorff(patch, l.primitive, 10);
        const auto [bwd, bwd_slack] = brute_hausdorff(l.primitive, patch, 10);
        SCOPED_TRACE(testing::Message()
                     << l.primitive.triangle_count() << " triangles: brute force " << fwd << " / "
                     << bwd << ", bounds " << d.forward.max_upper << " / " << d.backward.max_upper);
        EXPECT_GE(d.forward.max_upper, fwd - 1e-9);
        EXPECT_GE(d.backward.max_upper, bwd - 1e-9);
        EXPECT_LE(d.hausdorff, d.hausdorff_upper);
        (void)fwd_slack, (void)bwd_slack;
    }
}

TEST(MeshDistanceBounds, PrismBoundsKeepTheClosedForms) {
    // Open borders (the squares: the walks stop there) and a convex polyhedron: the brackets of
    // the closed forms hold with prism bounds too.
    MeshDistanceOptions prism;
    prism.prism_bounds = true;
    for (double a : {0.05, 0.3, 1.0}) {
        const MeshDistance d = measure_mesh_distance(rectangle(1, 0), tilted_square(a), prism);
        expect_brackets(d, std::sin(a), std::sin(a) / 2.0);
        EXPECT_NEAR(d.hausdorff, std::sin(a), 1e-6);
    }
    const Primitive p = icosphere(0);
    const double h = 1.0 - sagitta(p), s = 0.8;
    const MeshDistance d = measure_mesh_distance(p, scaled(p, float(s)), prism);
    EXPECT_NEAR(d.hausdorff, (1 - s), 1e-6);
    EXPECT_GE(d.hausdorff_upper, (1 - s) - 1e-6);
    EXPECT_LE(d.hausdorff_upper, (1 - s) * 1.01);
    EXPECT_GE(d.backward.max_upper, (1 - s) * h - 1e-6);
    EXPECT_LE(d.backward.max_upper, (1 - s) * h * (1 + 1e-3));
}

TEST(MeshDistance, EmptyOrZeroAreaMeshHasNoSamples) {
    Primitive flat;
    flat.positions = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}};
    flat.indices = {0, 1, 2};
    const MeshDistance d = measure_mesh_distance(flat, rectangle(1, 0));
    EXPECT_EQ(d.forward.samples, 0u);
    EXPECT_EQ(d.forward.mean, 0.0);
    EXPECT_EQ(bounding_box_diagonal(view_of(Primitive{})), 0.0);
}

}  // namespace
}  // namespace hmdnode
