#include "hmdnode/lod/mesh_distance.hpp"
#include "lod/test_meshes.hpp"

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
    EXPECT_GE(d.forward.samples, MeshDistanceOptions{}.samples);
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
