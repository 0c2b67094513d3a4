// The algorithms of H. Li, S. Kim, "Mesh Simplification Algorithms for Rendering Performance",
// International Journal of Engineering Research and Technology 13(6), 2020 (SS, FAD, VT, IVDD, VTD,
// FASS), uniform-grid clustering and OpenMesh's ModQuadric baseline, called through the private
// table (lod/src/simplify/algorithms.hpp) so that this suite does not depend on the name table in
// simplify.cpp.
#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "../../lod/src/simplify/algorithms.hpp"
#include "../../lod/src/simplify/openmesh_mesh.hpp"
#include "lod/test_meshes.hpp"

namespace hmdnode::lod_detail {
namespace {

struct Algo {
    const char* name;
    AlgorithmFn fn;
    bool connectivity;  // collapses on the connectivity: closed stays closed
    // No face turned over. OpenMesh's Decimater re-checks only the topology of a collapse whose
    // heap entry went stale, so its baseline can leave a face standing on edge.
    bool no_flips = connectivity;
};

const Algo kAlgos[] = {
    {"ss", simplify_ss, true},      {"fad", simplify_fad, true},
    {"vt", simplify_vt, true},      {"ivdd", simplify_ivdd, true},
    {"vtd", simplify_vtd, true},    {"fass", simplify_fass, true},
    {"grid", simplify_grid, false}, {"openmesh-quadric", simplify_openmesh_quadric, true, false},
};

Primitive icosphere(int subdivisions) {
    Primitive p = test::unit_icosphere(subdivisions);
    p.normals = p.positions;
    return p;
}

// n x n quads on [0,1]^2 at z = 0, each split in two, counter-clockwise seen from +z.
Primitive flat_grid(int n) {
    Primitive p;
    for (int y = 0; y <= n; ++y)
        for (int x = 0; x <= n; ++x) p.positions.push_back({float(x) / n, float(y) / n, 0.0f});
    auto id = [&](int x, int y) { return uint32_t(y * (n + 1) + x); };
    for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x)
            p.indices.insert(p.indices.end(), {id(x, y), id(x + 1, y), id(x + 1, y + 1), id(x, y),
                                               id(x + 1, y + 1), id(x, y + 1)});
    return p;
}

// A cube [-1,1]^3 with every face an n x n grid (faces share positions along the cube's edges).
Primitive subdivided_cube(int n) {
    Primitive p;
    for (int axis = 0; axis < 3; ++axis)
        for (float side : {-1.0f, 1.0f}) {
            uint32_t base = uint32_t(p.positions.size());
            for (int j = 0; j <= n; ++j)
                for (int i = 0; i <= n; ++i) {
                    glm::vec3 q;
                    q[axis] = side;
                    q[(axis + 1) % 3] = -1.0f + 2.0f * i / n;
                    q[(axis + 2) % 3] = -1.0f + 2.0f * j / n;
                    p.positions.push_back(q);
                }
            for (int j = 0; j < n; ++j)
                for (int i = 0; i < n; ++i) {
                    uint32_t a = base + j * (n + 1) + i, b = a + 1, c = a + n + 2, d = a + n + 1;
                    if (side > 0)
                        p.indices.insert(p.indices.end(), {a, b, c, a, c, d});
                    else
                        p.indices.insert(p.indices.end(), {a, c, b, a, d, c});
                }
        }
    return p;
}

glm::vec3 corner(const Primitive& p, size_t t, int k) {
    return p.positions[p.indices[t * 3 + k]];
}

// Indices in range, attribute arrays sized like positions, no degenerate or repeated faces.
void expect_valid(const Primitive& in, const Primitive& out, const std::string& what) {
    SCOPED_TRACE(what);
    ASSERT_EQ(out.indices.size() % 3, 0u);
    for (uint32_t i : out.indices) ASSERT_LT(i, out.positions.size());
    EXPECT_EQ(out.normals.size(), in.normals.empty() ? 0 : out.positions.size());
    EXPECT_EQ(out.uv0.size(), in.uv0.empty() ? 0 : out.positions.size());
    EXPECT_EQ(out.uv1.size(), in.uv1.empty() ? 0 : out.positions.size());
    EXPECT_EQ(out.colors.size(), in.colors.empty() ? 0 : out.positions.size());
    std::set<std::array<std::array<float, 3>, 3>> seen;
    for (size_t t = 0; t < out.triangle_count(); ++t) {
        glm::vec3 a = corner(out, t, 0), b = corner(out, t, 1), c = corner(out, t, 2);
        ASSERT_GT(glm::length(glm::cross(b - a, c - a)), 0.0f) << "degenerate face " << t;
        std::array<std::array<float, 3>, 3> key = {
            {{a.x, a.y, a.z}, {b.x, b.y, b.z}, {c.x, c.y, c.z}}};
        std::sort(key.begin(), key.end());
        ASSERT_TRUE(seen.insert(key).second) << "repeated face " << t;
    }
}

// Every edge (by position) in exactly two faces.
bool closed_manifold(const Primitive& p) {
    std::map<std::array<float, 6>, int> uses;
    for (size_t t = 0; t < p.triangle_count(); ++t)
        for (int k = 0; k < 3; ++k) {
            glm::vec3 a = corner(p, t, k), b = corner(p, t, (k + 1) % 3);
            std::array<float, 6> key = {a.x, a.y, a.z, b.x, b.y, b.z};
            if (std::lexicographical_compare(key.begin() + 3, key.end(), key.begin(),
                                             key.begin() + 3))
                key = {b.x, b.y, b.z, a.x, a.y, a.z};
            ++uses[key];
        }
    for (auto& [k, n] : uses)
        if (n != 2) return false;
    return true;
}

// Largest | |p| - 1 | over the vertices and face centroids.
double sphere_error(const Primitive& p) {
    double e = 0.0;
    for (auto& v : p.positions) e = std::max(e, std::abs(double(glm::length(v)) - 1.0));
    for (size_t t = 0; t < p.triangle_count(); ++t) {
        glm::vec3 c = (corner(p, t, 0) + corner(p, t, 1) + corner(p, t, 2)) / 3.0f;
        e = std::max(e, std::abs(double(glm::length(c)) - 1.0));
    }
    return e;
}

class LiKim2020 : public ::testing::TestWithParam<Algo> {};

TEST_P(LiKim2020, SphereReachesTargetsStaysClosedUnflippedAndErrorFallsWithCount) {
    const Algo& algo = GetParam();
    const Primitive in = icosphere(3);  // 1280 triangles
    ASSERT_EQ(in.triangle_count(), 1280u);
    const std::vector<size_t> targets = {640, 256, 64};
    auto result = algo.fn(in, targets, {});
    ASSERT_TRUE(result.ok()) << result.error().message;
    ASSERT_EQ(result->size(), 3u);
    double err[3];
    for (int i = 0; i < 3; ++i) {
        const Primitive& out = (*result)[i].primitive;
        std::string what = std::string(algo.name) + " target " + std::to_string(targets[i]);
        SCOPED_TRACE(what);
        expect_valid(in, out, what);
        // Greedy algorithms stop at the target or one operation below it; bisected ones (ss,
        // fass, grid) land within 15 %.
        EXPECT_LE(double(out.triangle_count()), 1.15 * double(targets[i]));
        EXPECT_GE(double(out.triangle_count()), 0.85 * double(targets[i]));
        if (algo.connectivity) {
            EXPECT_TRUE(closed_manifold(out));
        }
        if (algo.no_flips) {
            for (size_t t = 0; t < out.triangle_count(); ++t) {
                glm::vec3 a = corner(out, t, 0), b = corner(out, t, 1), c = corner(out, t, 2);
                ASSERT_GT(glm::dot(glm::cross(b - a, c - a), a + b + c), 0.0f) << "flipped " << t;
            }
        }
        err[i] = sphere_error(out);
    }
    EXPECT_LT(err[0], err[2]) << algo.name;
    EXPECT_LE(err[1], err[2] * 1.05) << algo.name;
    EXPECT_LE(err[0], err[1] * 1.05) << algo.name;
}

TEST_P(LiKim2020, FlatGridStaysFlatAndUnflipped) {
    const Algo& algo = GetParam();
    const Primitive in = flat_grid(16);  // 512 triangles
    const std::vector<size_t> targets = {256, 64};
    auto result = algo.fn(in, targets, {});
    ASSERT_TRUE(result.ok()) << result.error().message;
    for (int i = 0; i < 2; ++i) {
        const Primitive& out = (*result)[i].primitive;
        expect_valid(in, out, algo.name);
        EXPECT_LE(double(out.triangle_count()), 1.15 * double(targets[i])) << algo.name;
        EXPECT_GT(out.triangle_count(), 0u);
        for (auto& p : out.positions) ASSERT_EQ(p.z, 0.0f) << algo.name;
        for (size_t t = 0; t < out.triangle_count(); ++t) {
            glm::vec3 a = corner(out, t, 0), b = corner(out, t, 1), c = corner(out, t, 2);
            ASSERT_GT(glm::cross(b - a, c - a).z, 0.0f) << algo.name << " flipped " << t;
        }
    }
}

INSTANTIATE_TEST_SUITE_P(All, LiKim2020, ::testing::ValuesIn(kAlgos), [](const auto& info) {
    std::string s = info.param.name;
    std::replace(s.begin(), s.end(), '-', '_');
    return s;
});

// Locked borders: the 64 border vertices of a 16 x 16 grid all survive, where they are.
TEST(LiKim2020Borders, LockedBordersKeepEveryBorderVertex) {
    const Primitive in = flat_grid(16);
    SimplifyOptions options;
    options.lock_borders = true;
    const std::vector<size_t> targets = {100};
    for (const Algo& algo : kAlgos) {
        if (!algo.connectivity) continue;
        auto result = algo.fn(in, targets, options);
        ASSERT_TRUE(result.ok());
        const Primitive& out = (*result)[0].primitive;
        std::set<std::pair<float, float>> border;
        for (auto& p : out.positions)
            if (p.x == 0.0f || p.x == 1.0f || p.y == 0.0f || p.y == 1.0f) border.insert({p.x, p.y});
        EXPECT_EQ(border.size(), 64u) << algo.name;
    }
}

// FAD removes flat-region vertices first and keeps the sharp ones: a cube with 4 x 4 faces
// brought to 12 triangles is the cube, all 8 corners kept.
TEST(LiKim2020Fad, CubeKeepsItsCorners) {
    const Primitive in = subdivided_cube(4);  // 192 triangles
    for (size_t target : {48u, 12u}) {
        const std::vector<size_t> targets = {target};
        auto result = simplify_fad(in, targets, {});
        ASSERT_TRUE(result.ok());
        const Primitive& out = (*result)[0].primitive;
        EXPECT_LE(out.triangle_count(), target);
        expect_valid(in, out, "fad cube");
        EXPECT_TRUE(closed_manifold(out));
        int corners = 0;
        for (auto& p : out.positions)
            corners += std::abs(p.x) == 1.0f && std::abs(p.y) == 1.0f && std::abs(p.z) == 1.0f;
        EXPECT_EQ(corners, 8) << "target " << target;
        // Every output vertex still on the cube's surface, every face on one of its planes.
        for (size_t t = 0; t < out.triangle_count(); ++t) {
            glm::vec3 a = corner(out, t, 0), b = corner(out, t, 1), c = corner(out, t, 2);
            glm::vec3 n = glm::normalize(glm::cross(b - a, c - a));
            EXPECT_NEAR(std::max({std::abs(n.x), std::abs(n.y), std::abs(n.z)}), 1.0f, 1e-6f);
        }
    }
    // At 12 triangles nothing but the corners is left.
    const std::vector<size_t> twelve = {12};
    auto result = simplify_fad(in, twelve, {});
    ASSERT_TRUE(result.ok());
    EXPECT_EQ((*result)[0].primitive.triangle_count(), 12u);
}

// FAD on a flat square grid: every inner vertex is flat and every border vertex but the four
// corners lies on a straight border, so it goes down to the two triangles of the square.
TEST(LiKim2020Fad, FlatGridReducesToTwoTriangles) {
    const Primitive in = flat_grid(16);
    const std::vector<size_t> targets = {2};
    auto result = simplify_fad(in, targets, {});
    ASSERT_TRUE(result.ok());
    const Primitive& out = (*result)[0].primitive;
    ASSERT_EQ(out.triangle_count(), 2u);
    std::set<std::pair<float, float>> corners;
    for (uint32_t i : out.indices) corners.insert({out.positions[i].x, out.positions[i].y});
    EXPECT_EQ(corners, (std::set<std::pair<float, float>>{{0, 0}, {0, 1}, {1, 0}, {1, 1}}));
}

// A flat grid cut into two UV charts along x = 0.5 (split vertices there): uv is an affine map of
// the position in each chart, so every output vertex must still satisfy its chart's map exactly
// (a seam vertex may only slide along the seam, interpolation stays inside a chart).
TEST(LiKim2020Seams, UvSeamsSurvive) {
    const int n = 16;
    Primitive in;
    auto uv_of = [](glm::vec3 p, int chart) {
        return chart == 0 ? glm::vec2(0.4f * p.x, p.y) : glm::vec2(0.6f + 0.4f * p.x, p.y);
    };
    std::map<std::pair<int, int>, uint32_t> ids;
    auto vertex = [&](int x, int y, int chart) {
        auto [it, inserted] = ids.try_emplace({x * 2 + chart, y}, uint32_t(in.positions.size()));
        if (inserted) {
            glm::vec3 p(float(x) / n, float(y) / n, 0.0f);
            in.positions.push_back(p);
            in.uv0.push_back(uv_of(p, chart));
        }
        return it->second;
    };
    for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
            int chart = x < n / 2 ? 0 : 1;
            uint32_t a = vertex(x, y, chart), b = vertex(x + 1, y, chart),
                     c = vertex(x + 1, y + 1, chart), d = vertex(x, y + 1, chart);
            in.indices.insert(in.indices.end(), {a, b, c, a, c, d});
        }
    const std::vector<size_t> targets = {200, 60};
    for (const Algo& algo : kAlgos) {
        if (!algo.connectivity) continue;
        auto result = algo.fn(in, targets, {});
        ASSERT_TRUE(result.ok());
        for (auto& level : *result) {
            const Primitive& out = level.primitive;
            expect_valid(in, out, algo.name);
            for (size_t t = 0; t < out.triangle_count(); ++t) {
                int chart0 = out.uv0[out.indices[t * 3]].x < 0.5f ? 0 : 1;
                for (int k = 0; k < 3; ++k) {
                    uint32_t i = out.indices[t * 3 + k];
                    int chart = out.uv0[i].x < 0.5f ? 0 : 1;
                    ASSERT_EQ(chart, chart0) << algo.name << ": face " << t << " spans charts";
                    glm::vec2 want = uv_of(out.positions[i], chart);
                    ASSERT_NEAR(out.uv0[i].x, want.x, 1e-5f) << algo.name;
                    ASSERT_NEAR(out.uv0[i].y, want.y, 1e-5f) << algo.name;
                }
            }
        }
    }
}

// The OpenMesh conversion: split seam vertices weld into one OpenMesh vertex, and the round trip
// gives back every triangle with the attributes of each corner exactly; a face OpenMesh refuses
// (third face on an edge) and one with a repeated corner are counted, not added.
TEST(LiKim2020Weld, RoundTripKeepsCornersAndCountsRefusedFaces) {
    Primitive in = flat_grid(2);  // 9 vertices, 8 triangles
    in.uv0.resize(in.positions.size());
    for (size_t i = 0; i < in.positions.size(); ++i) in.uv0[i] = glm::vec2(in.positions[i]);
    // Split vertex 4 (the centre) for the two triangles of the last quad: a UV seam there.
    in.positions.push_back(in.positions[4]);
    in.uv0.push_back({5.0f, 5.0f});
    const uint32_t split = uint32_t(in.positions.size() - 1);
    for (size_t k = 18; k < 24; ++k)
        if (in.indices[k] == 4) in.indices[k] = split;
    const size_t good = in.triangle_count();
    in.positions.push_back({0.25f, 0.0f, 1.0f});
    in.uv0.push_back({0.0f, 0.0f});
    in.indices.insert(in.indices.end(), {0, 1, uint32_t(in.positions.size() - 1)});  // 3rd on (0,1)
    in.indices.insert(in.indices.end(), {2, 2, 5});                                  // repeated

    WeldedMesh m = weld_to_openmesh(in);
    EXPECT_EQ(m.rejected_faces, 2u);
    EXPECT_EQ(m.alive_faces, good);
    EXPECT_EQ(m.mesh.n_faces(), good);
    Primitive out = to_primitive(m);
    ASSERT_EQ(out.triangle_count(), good);
    ASSERT_EQ(out.uv0.size(), out.positions.size());
    using Corner3 = std::array<float, 5>;
    auto corners_of = [](const Primitive& p, size_t t) {
        std::array<Corner3, 3> c;
        for (int k = 0; k < 3; ++k) {
            uint32_t i = p.indices[t * 3 + k];
            c[k] = {p.positions[i].x, p.positions[i].y, p.positions[i].z, p.uv0[i].x, p.uv0[i].y};
        }
        std::rotate(c.begin(), std::min_element(c.begin(), c.end()), c.end());  // same winding
        return c;
    };
    std::multiset<std::array<Corner3, 3>> want, got;
    for (size_t t = 0; t < good; ++t) want.insert(corners_of(in, t));
    for (size_t t = 0; t < good; ++t) got.insert(corners_of(out, t));
    EXPECT_EQ(got, want);
}

// Non-manifold input (three faces on one edge) does not crash: the face OpenMesh refuses is left
// out and the rest simplified.
TEST(LiKim2020Robust, NonManifoldEdgeIsSurvived) {
    Primitive in = flat_grid(8);
    uint32_t extra = uint32_t(in.positions.size());
    in.positions.push_back({0.0625f, 0.0f, 0.5f});
    in.indices.insert(in.indices.end(), {0, 1, extra});  // third face on edge (0, 1)
    const std::vector<size_t> targets = {40};
    for (const Algo& algo : kAlgos) {
        auto result = algo.fn(in, targets, {});
        ASSERT_TRUE(result.ok()) << algo.name;
        expect_valid(in, (*result)[0].primitive, algo.name);
        EXPECT_GT((*result)[0].primitive.triangle_count(), 0u);
    }
}

}  // namespace
}  // namespace hmdnode::lod_detail
