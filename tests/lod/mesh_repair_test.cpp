#include "hmdnode/lod/mesh_repair.hpp"

#include <cmath>
#include <limits>
#include <map>

#include <gtest/gtest.h>

namespace hmdnode {
namespace {

// The unit square as two triangles, with normals and uv0.
Primitive square() {
    Primitive p;
    p.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
    p.normals.assign(4, {0, 0, 1});
    p.uv0 = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    p.indices = {0, 1, 2, 0, 2, 3};
    p.material = 2;
    return p;
}

bool contains(const std::string& s, const std::string& part) {
    return s.find(part) != std::string::npos;
}

TEST(MeshRepair, CleanMeshIsUnchanged) {
    RepairReport report;
    Result<Primitive> r = repair_primitive(square(), "sq", report);
    ASSERT_TRUE(r.ok());
    EXPECT_EQ(r->indices, square().indices);
    EXPECT_EQ(r->positions, square().positions);
    EXPECT_EQ(r->material, 2);
    EXPECT_EQ(report.total(), 0u);
    EXPECT_TRUE(report.messages.empty());
}

TEST(MeshRepair, RejectsNonFinitePositionNamingTheVertex) {
    Primitive p = square();
    p.positions[2].y = std::numeric_limits<float>::quiet_NaN();
    RepairReport report;
    Result<Primitive> r = repair_primitive(p, "mesh 0 \"a\" primitive 1", report);
    ASSERT_FALSE(r.ok());
    EXPECT_TRUE(contains(r.error().message, "mesh 0 \"a\" primitive 1")) << r.error().message;
    EXPECT_TRUE(contains(r.error().message, "vertex 2")) << r.error().message;
    p.positions[2].y = std::numeric_limits<float>::infinity();
    EXPECT_FALSE(repair_primitive(p, "x", report).ok());
}

TEST(MeshRepair, RejectsEmptyAndOutOfRange) {
    RepairReport report;
    EXPECT_TRUE(contains(repair_primitive(Primitive{}, "e", report).error().message, "empty"));
    Primitive p = square();
    p.indices[4] = 9;
    Result<Primitive> r = repair_primitive(p, "o", report);
    ASSERT_FALSE(r.ok());
    EXPECT_TRUE(contains(r.error().message, "index 4")) << r.error().message;
    EXPECT_TRUE(contains(r.error().message, "out of range")) << r.error().message;
    p = square();
    p.indices.pop_back();
    EXPECT_FALSE(repair_primitive(p, "t", report).ok());
    p = square();
    p.uv0.pop_back();
    EXPECT_FALSE(repair_primitive(p, "u", report).ok());
}

TEST(MeshRepair, DropsDegenerateAndDuplicateFaces) {
    Primitive p = square();
    // repeated corner, zero area (collinear), the first face again, the first face reversed
    p.positions.push_back({2, 0, 0});
    p.normals.push_back({0, 0, 1});
    p.uv0.push_back({2, 0});
    p.indices.insert(p.indices.end(), {0, 0, 1, 0, 1, 4, 1, 2, 0, 2, 1, 0});
    RepairReport report;
    Result<Primitive> r = repair_primitive(p, "d", report);
    ASSERT_TRUE(r.ok());
    EXPECT_EQ(r->indices, square().indices);
    EXPECT_EQ(report.degenerate_faces, 2u);
    EXPECT_EQ(report.duplicate_faces, 2u);
    EXPECT_EQ(report.unreferenced_vertices, 1u);  // vertex 4 was only in the sliver
    EXPECT_EQ(r->positions.size(), 4u);
    EXPECT_EQ(r->uv0.size(), 4u);
    EXPECT_EQ(report.messages.size(), 3u);
}

TEST(MeshRepair, DropsUnreferencedVerticesAndRemaps) {
    Primitive p = square();
    p.positions.insert(p.positions.begin(), glm::vec3(5, 5, 5));
    p.normals.insert(p.normals.begin(), glm::vec3(1, 0, 0));
    p.uv0.insert(p.uv0.begin(), glm::vec2(9, 9));
    for (uint32_t& i : p.indices) ++i;
    RepairReport report;
    Result<Primitive> r = repair_primitive(p, "u", report);
    ASSERT_TRUE(r.ok());
    EXPECT_EQ(report.unreferenced_vertices, 1u);
    EXPECT_EQ(r->indices, square().indices);
    EXPECT_EQ(r->uv0, square().uv0);
    EXPECT_EQ(r->normals, square().normals);
}

TEST(MeshRepair, LeavesAtMostTwoConsistentFacesPerEdge) {
    // Three fins on the edge (0,1): the third is dropped.
    Primitive p;
    p.positions = {{0, 0, 0}, {1, 0, 0}, {0.5f, 1, 0}, {0.5f, -1, 0}, {0.5f, 0, 1}};
    p.indices = {0, 1, 2, 1, 0, 3, 0, 1, 4};
    RepairReport report;
    Result<Primitive> r = repair_primitive(p, "fin", report);
    ASSERT_TRUE(r.ok());
    EXPECT_EQ(r->triangle_count(), 2u);
    EXPECT_EQ(report.non_manifold_faces, 1u);
    // Every edge of the result has at most two faces, used once in each direction.
    std::map<std::pair<uint32_t, uint32_t>, int> directed;
    for (size_t i = 0; i < r->indices.size(); i += 3)
        for (int e = 0; e < 3; ++e) ++directed[{r->indices[i + e], r->indices[i + (e + 1) % 3]}];
    for (auto& [edge, count] : directed) EXPECT_EQ(count, 1);
}

TEST(MeshRepair, FlipsAFaceAgainstItsNeighbour) {
    Primitive p = square();
    p.indices = {0, 1, 2, 0, 3, 2};  // the second face reversed
    // face 0 uses 2->0; face 1 uses 3->2, 2->0 again: inconsistent, flipped to 0,2,3.
    RepairReport report;
    Result<Primitive> r = repair_primitive(p, "f", report);
    ASSERT_TRUE(r.ok());
    EXPECT_EQ(report.reoriented_faces, 1u);
    EXPECT_EQ(r->indices, (std::vector<uint32_t>{0, 1, 2, 0, 2, 3}));
}

TEST(MeshRepair, WeldsSplitVerticesForConnectivity) {
    // The same square with vertex 0 split in two (a UV seam): the copies share a position, so a
    // face repeated on the other copy is a duplicate.
    Primitive p = square();
    p.positions.push_back(p.positions[0]);
    p.normals.push_back(p.normals[0]);
    p.uv0.push_back({0.5f, 0.5f});
    p.indices.insert(p.indices.end(), {4, 1, 2});
    RepairReport report;
    Result<Primitive> r = repair_primitive(p, "w", report);
    ASSERT_TRUE(r.ok());
    EXPECT_EQ(report.duplicate_faces, 1u);
    EXPECT_EQ(r->triangle_count(), 2u);
}

TEST(MeshRepair, SceneErrorLeavesSceneUnchanged) {
    Scene s;
    s.meshes.push_back({"good", {square()}});
    Primitive bad = square();
    bad.positions[1].x = std::numeric_limits<float>::quiet_NaN();
    s.meshes.push_back({"bad", {square(), bad}});
    RepairReport report;
    Status st = repair_scene(s, report);
    ASSERT_FALSE(st.ok());
    EXPECT_TRUE(contains(st.error().message, "mesh 1 \"bad\" primitive 1")) << st.error().message;
    EXPECT_EQ(s.meshes[1].primitives.size(), 2u);
    s.meshes.pop_back();
    s.meshes[0].primitives[0].indices.insert(s.meshes[0].primitives[0].indices.end(), {0, 0, 1});
    ASSERT_TRUE(repair_scene(s, report).ok());
    EXPECT_EQ(report.degenerate_faces, 1u);
    EXPECT_EQ(s.meshes[0].primitives[0].triangle_count(), 2u);
}

TEST(MeshRepair, WeldsNegativeZeroLikePositiveZero) {
    // Three faces on the edge (0,0,0)-(1,0,0); the third names its end at (-0,0,0). simplify()
    // welds -0 and +0 into one position, so repair must see a third face there and drop it.
    Primitive p;
    p.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {-0.0f, 0, 0}};
    p.indices = {0, 1, 2, 1, 0, 3, 5, 1, 4};
    ASSERT_TRUE(std::signbit(p.positions[5].x));
    RepairReport report;
    Result<Primitive> r = repair_primitive(p, "z", report);
    ASSERT_TRUE(r.ok());
    EXPECT_EQ(report.non_manifold_faces, 1u);
    EXPECT_EQ(r->triangle_count(), 2u);
}

}  // namespace
}  // namespace hmdnode
