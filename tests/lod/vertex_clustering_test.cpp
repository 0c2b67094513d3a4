#include "hmdnode/lod/vertex_clustering.hpp"

#include <array>
#include <cmath>
#include <filesystem>
#include <set>

#include <gtest/gtest.h>

#include "hmdnode/core/obj.hpp"
#include "hmdnode/lod/simplify.hpp"

namespace hmdnode {
namespace {

// A flat square [0,1]^2 at z = 0 cut into n x n quads (2 n^2 triangles), normals +Z, uv0 = xy.
Primitive tessellated_square(int n) {
    Primitive p;
    for (int j = 0; j <= n; ++j)
        for (int i = 0; i <= n; ++i) {
            p.positions.emplace_back(float(i) / n, float(j) / n, 0.0f);
            p.normals.emplace_back(0.0f, 0.0f, 1.0f);
            p.uv0.emplace_back(float(i) / n, float(j) / n);
            p.colors.emplace_back(0.25f, 0.5f, 0.75f, 1.0f);
        }
    auto at = [n](int i, int j) { return uint32_t(j * (n + 1) + i); };
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            p.indices.insert(p.indices.end(), {at(i, j), at(i + 1, j), at(i + 1, j + 1)});
            p.indices.insert(p.indices.end(), {at(i, j), at(i + 1, j + 1), at(i, j + 1)});
        }
    p.material = 3;
    return p;
}

const Primitive& bunny() {
    static const Primitive p = [] {
        Result<Mesh> m =
            load_obj(std::filesystem::path(HMDNODE_SOURCE_DIR) / "data/meshes/stanford-bunny.obj");
        EXPECT_TRUE(m.ok()) << (m.ok() ? "" : m.error().message);
        return m.ok() ? m->primitives[0] : Primitive{};
    }();
    return p;
}

// Every index valid, no triangle with a repeated corner or zero area, no repeated triangle,
// attribute arrays complete, normals unit length.
void expect_well_formed(const Primitive& in, const Primitive& out) {
    ASSERT_EQ(out.indices.size() % 3, 0u);
    const size_t n = out.positions.size();
    EXPECT_EQ(out.normals.size(), in.normals.empty() ? 0 : n);
    EXPECT_EQ(out.uv0.size(), in.uv0.empty() ? 0 : n);
    EXPECT_EQ(out.uv1.size(), in.uv1.empty() ? 0 : n);
    EXPECT_EQ(out.colors.size(), in.colors.empty() ? 0 : n);
    EXPECT_EQ(out.light.size(), in.light.empty() ? 0 : n);
    EXPECT_EQ(out.material, in.material);
    std::set<std::array<uint32_t, 3>> tris;
    std::vector<char> used(n, 0);
    for (size_t t = 0; t < out.indices.size(); t += 3) {
        uint32_t a = out.indices[t], b = out.indices[t + 1], c = out.indices[t + 2];
        ASSERT_LT(a, n);
        ASSERT_LT(b, n);
        ASSERT_LT(c, n);
        ASSERT_TRUE(a != b && b != c && a != c) << "triangle " << t / 3;
        glm::vec3 cr =
            glm::cross(out.positions[b] - out.positions[a], out.positions[c] - out.positions[a]);
        ASSERT_GT(glm::length(cr), 0.0f) << "triangle " << t / 3;
        std::array<uint32_t, 3> key{a, b, c};
        while (key[0] > key[1] || key[0] > key[2]) key = {key[1], key[2], key[0]};
        ASSERT_TRUE(tris.insert(key).second) << "repeated triangle " << t / 3;
        used[a] = used[b] = used[c] = 1;
    }
    for (size_t i = 0; i < n; ++i) EXPECT_TRUE(used[i]) << "unreferenced vertex " << i;
    for (const glm::vec3& nn : out.normals) EXPECT_NEAR(glm::length(nn), 1.0f, 1e-4f);
}

TEST(VertexClustering, TinyCellsKeepTheMesh) {
    Primitive sq = tessellated_square(16);
    float disp = -1.0f;
    Primitive out = cluster_vertices(sq, 1e-3f, &disp);
    EXPECT_EQ(out.triangle_count(), sq.triangle_count());
    EXPECT_EQ(out.positions.size(), sq.positions.size());
    EXPECT_EQ(disp, 0.0f);
    expect_well_formed(sq, out);
}

TEST(VertexClustering, HugeCellCollapsesFlatSquareWithinCellDiagonal) {
    Primitive sq = tessellated_square(64);  // 8192 triangles
    const float cell = 0.45f;               // 3 x 3 cells over the square
    float disp = -1.0f;
    Primitive out = cluster_vertices(sq, cell, &disp);
    EXPECT_GT(out.triangle_count(), 0u);
    EXPECT_LE(out.triangle_count(), 16u);
    EXPECT_GT(disp, 0.0f);
    EXPECT_LE(disp, std::sqrt(3.0f) * cell);
    expect_well_formed(sq, out);
    for (const glm::vec3& p : out.positions)
        EXPECT_EQ(p.z, 0.0f);  // representatives are input vertices
    for (const glm::vec3& nn : out.normals) EXPECT_NEAR(nn.z, 1.0f, 1e-6f);
    for (const glm::vec4& c : out.colors) EXPECT_NEAR(c.g, 0.5f, 1e-6f);
    // The square is still covered: the kept triangles span (almost) its whole area.
    float area = 0.0f;
    for (size_t t = 0; t < out.indices.size(); t += 3) {
        const glm::vec3& a = out.positions[out.indices[t]];
        area += 0.5f * glm::length(glm::cross(out.positions[out.indices[t + 1]] - a,
                                              out.positions[out.indices[t + 2]] - a));
    }
    EXPECT_GT(area, 0.3f);
    EXPECT_LE(area, 1.0f + 1e-5f);
}

TEST(VertexClustering, CellLargerThanMeshLeavesNothing) {
    Primitive sq = tessellated_square(8);
    float disp = 0.0f;
    Primitive out = cluster_vertices(sq, 10.0f, &disp);
    EXPECT_EQ(out.triangle_count(), 0u);
    EXPECT_TRUE(out.positions.empty());
    EXPECT_LE(disp, std::sqrt(2.0f));
}

// A closed box of 8 welded corners and 12 triangles, 0.4 x 0.3 x 0.2 m (a crate of the demo
// room), light (_LIGHT_0) linear in position.
Primitive small_box() {
    Primitive p;
    for (int k = 0; k < 8; ++k) {
        const glm::vec3 v(k & 1 ? 0.4f : 0.0f, k & 2 ? 0.3f : 0.0f, k & 4 ? 0.2f : 0.0f);
        p.positions.push_back(v + glm::vec3(2.0f, 0.0f, 1.0f));
        p.normals.push_back(glm::normalize(v - glm::vec3(0.2f, 0.15f, 0.1f)));
        p.light.push_back(glm::vec3(1.0f + v.x, 2.0f - v.y, 3.0f + v.z));
    }
    p.indices = {0, 2, 3, 0, 3, 1, 4, 5, 7, 4, 7, 6, 0, 1, 5, 0, 5, 4,
                 2, 6, 7, 2, 7, 3, 0, 4, 6, 0, 6, 2, 1, 3, 7, 1, 7, 5};
    p.material = 1;
    return p;
}

// The demo room's grid failure ("mesh 16 primitive 0: no vertices"): for a target of a triangle
// or two, the grid that collapses a small box entirely (0 triangles, 1 away) was closer than any
// grid that keeps some (4 or more), so the box vanished from its level. Now every target gives a
// valid, non-empty mesh with all the input's attributes.
TEST(VertexClustering, ASmallObjectNeverVanishesFromALevel) {
    const Primitive box = small_box();
    for (size_t target = 1; target < box.triangle_count(); ++target) {
        SCOPED_TRACE(target);
        ClusteredLevel c = cluster_to_triangle_count(box, target);
        EXPECT_GT(c.primitive.triangle_count(), 0u);
        expect_well_formed(box, c.primitive);
    }
    Result<std::vector<SimplifiedLevel>> levels = simplify(box, "grid", std::vector<size_t>{6, 1});
    ASSERT_TRUE(levels.ok()) << levels.error().message;
    for (const SimplifiedLevel& l : *levels) {
        EXPECT_GT(l.primitive.triangle_count(), 0u);
        expect_well_formed(box, l.primitive);
    }
}

// Where no grid keeps a triangle, the input comes back rather than nothing: a sliver (angle at
// the first corner about 2e-7 rad) that the grid's sliver test drops at every cell size, though
// mesh repair keeps it.
TEST(VertexClustering, WhenEveryGridCollapsesTheInputComesBack) {
    Primitive alone;
    alone.positions = {{0, 0, 0}, {1, 0, 0}, {0.5f, 1e-7f, 0}};
    alone.indices = {0, 1, 2};
    ASSERT_EQ(cluster_vertices(alone, 1e-4f, nullptr).triangle_count(), 0u);
    // Two such slivers (a target must be below the input's count) and a target of one.
    Primitive two = alone;
    two.positions.push_back({0.5f, -1e-7f, 0});
    two.indices.insert(two.indices.end(), {0, 3, 1});
    ClusteredLevel c = cluster_to_triangle_count(two, 1);
    EXPECT_EQ(c.primitive.triangle_count(), 2u);
    EXPECT_EQ(c.cell_size, 0.0f);
    EXPECT_EQ(c.max_displacement_m, 0.0f);
}

TEST(VertexClustering, TriangleCountDecreasesAsCellsGrowOnBunny) {
    const Primitive& in = bunny();
    ASSERT_EQ(in.triangle_count(), 69451u);
    // Doubling cells from one origin nest the grids, so every coarser result is a re-clustering of
    // the finer one and cannot have more triangles.
    size_t previous = in.triangle_count();
    float previous_disp = 0.0f;
    for (float cell = 0.0005f; cell <= 0.05f; cell *= 2.0f) {
        float disp = 0.0f;
        Primitive out = cluster_vertices(in, cell, &disp);
        SCOPED_TRACE(cell);
        EXPECT_LE(out.triangle_count(), previous);
        EXPECT_LT(out.triangle_count(), in.triangle_count());
        EXPECT_LE(disp, std::sqrt(3.0f) * cell);
        EXPECT_GE(disp, previous_disp * 0.5f);
        expect_well_formed(in, out);
        previous = out.triangle_count();
        previous_disp = disp;
    }
    EXPECT_LT(previous, 500u);
}

TEST(VertexClustering, BisectionReachesTargetTriangleCounts) {
    const Primitive& in = bunny();
    float previous_disp = 0.0f;
    for (size_t target : {16000u, 4000u, 1000u, 300u}) {
        ClusteredLevel lvl = cluster_to_triangle_count(in, target);
        SCOPED_TRACE(target);
        double ratio = double(lvl.primitive.triangle_count()) / double(target);
        EXPECT_GT(ratio, 0.9);
        EXPECT_LT(ratio, 1.1);
        EXPECT_GT(lvl.max_displacement_m, previous_disp);
        EXPECT_LE(lvl.max_displacement_m, std::sqrt(3.0f) * lvl.cell_size);
        expect_well_formed(in, lvl.primitive);
        previous_disp = lvl.max_displacement_m;
    }
}

}  // namespace
}  // namespace hmdnode
