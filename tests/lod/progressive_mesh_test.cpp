// Progressive meshes: recording, the file round trip, refinement equal to the engine's snapshots,
// and corrupt files.
#include "hmdnode/lod/progressive_mesh.hpp"
#include "hmdnode/lod/simplify.hpp"

#include <array>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include <unistd.h>

#include <gtest/gtest.h>

namespace hmdnode {
namespace {

// A bumpy grid with every attribute and a UV seam down x = 0.5 (left and right charts in uv1).
Primitive seamed_bumpy_grid(int n) {
    Primitive p;
    std::map<std::array<int, 3>, uint32_t> ids;
    auto vertex = [&](int i, int j, int right) {
        auto [it, added] =
            ids.emplace(std::array<int, 3>{i, j, right}, uint32_t(p.positions.size()));
        if (added) {
            const float x = float(i) / float(n), y = float(j) / float(n);
            p.positions.emplace_back(x, y, 0.1f * std::sin(5.0f * x) * std::cos(4.0f * y));
            p.normals.push_back(glm::normalize(
                glm::vec3(-0.5f * std::cos(5.0f * x), 0.4f * std::sin(4.0f * y), 1.0f)));
            p.uv0.emplace_back(x, y);
            p.uv1.emplace_back(right ? 0.55f + 0.9f * (x - 0.5f) : 0.9f * x, y);
            p.colors.emplace_back(x, y, 0.5f, 1.0f);
        }
        return it->second;
    };
    for (int j = 0; j < n; ++j) {
        for (int i = 0; i < n; ++i) {
            const int right = i >= n / 2;
            const uint32_t a = vertex(i, j, right), b = vertex(i + 1, j, right),
                           c = vertex(i + 1, j + 1, right), d = vertex(i, j + 1, right);
            p.indices.insert(p.indices.end(), {a, b, c, a, c, d});
        }
    }
    p.material = 2;
    return p;
}

void expect_same(const Primitive& a, const Primitive& b, const std::string& what) {
    ASSERT_EQ(a.positions.size(), b.positions.size()) << what;
    ASSERT_EQ(a.indices, b.indices) << what;
    // Bit for bit: memcmp, not a tolerance.
    EXPECT_EQ(std::memcmp(a.positions.data(), b.positions.data(), a.positions.size() * 12), 0)
        << what;
    ASSERT_EQ(a.normals.size(), b.normals.size()) << what;
    EXPECT_EQ(std::memcmp(a.normals.data(), b.normals.data(), a.normals.size() * 12), 0) << what;
    ASSERT_EQ(a.uv0.size(), b.uv0.size()) << what;
    EXPECT_EQ(std::memcmp(a.uv0.data(), b.uv0.data(), a.uv0.size() * 8), 0) << what;
    ASSERT_EQ(a.uv1.size(), b.uv1.size()) << what;
    EXPECT_EQ(std::memcmp(a.uv1.data(), b.uv1.data(), a.uv1.size() * 8), 0) << what;
    ASSERT_EQ(a.colors.size(), b.colors.size()) << what;
    EXPECT_EQ(std::memcmp(a.colors.data(), b.colors.data(), a.colors.size() * 16), 0) << what;
    EXPECT_EQ(a.material, b.material) << what;
}

TEST(ProgressiveMesh, RoundTripRefinesToEverySnapshotAndToTheFullMesh) {
    const Primitive in = seamed_bumpy_grid(16);  // 512 triangles
    const size_t targets[] = {400, 250, 100, 30};
    for (const char* algorithm : {"qem", "curvature-qem", "formula1", "melax"}) {
        Result<ProgressiveMeshBuild> built = build_progressive_mesh(in, algorithm, targets);
        ASSERT_TRUE(built.ok()) << built.error().message;
        const std::vector<uint8_t> bytes = encode_progressive_mesh(built->mesh);
        Result<ProgressiveMesh> pm = decode_progressive_mesh(bytes);
        ASSERT_TRUE(pm.ok()) << pm.error().message;
        EXPECT_EQ(encode_progressive_mesh(*pm), bytes);
        EXPECT_EQ(pm->full_triangles(), in.triangle_count());
        EXPECT_EQ(pm->base_triangles(), built->levels.back().primitive.triangle_count());
        for (size_t l = 0; l < 4; ++l) {
            expect_same(refine(*pm, targets[l]), built->levels[l].primitive,
                        std::string(algorithm) + " level " + std::to_string(l));
        }
        // The input has no duplicate vertices: the full refinement is the input itself.
        expect_same(refine(*pm, in.triangle_count()), in, std::string(algorithm) + " full");
        expect_same(refine(*pm, 1), built->levels.back().primitive,
                    std::string(algorithm) + " base");
    }
}

// From 8 192 faces on, a pass's collapses run region by region (the second region's records are
// appended after the first's): the progressive mesh still refines to every snapshot, which are the
// levels simplify() makes with or without its helper thread.
TEST(ProgressiveMesh, TwoRegionPassesRefineToEverySnapshot) {
    const Primitive in = seamed_bumpy_grid(128);  // 32 768 triangles
    const size_t targets[] = {12000, 3000, 300};
    for (const char* algorithm : {"qem", "curvature-qem"}) {
        SimplifyOptions helper;
        helper.threads = 2;
        Result<ProgressiveMeshBuild> built = build_progressive_mesh(in, algorithm, targets, helper);
        ASSERT_TRUE(built.ok()) << built.error().message;
        SimplifyOptions one_thread;
        one_thread.threads = 1;
        Result<std::vector<SimplifiedLevel>> direct = simplify(in, algorithm, targets, helper);
        Result<std::vector<SimplifiedLevel>> single = simplify(in, algorithm, targets, one_thread);
        ASSERT_TRUE(direct.ok()) << direct.error().message;
        ASSERT_TRUE(single.ok()) << single.error().message;
        for (size_t l = 0; l < 3; ++l) {
            const std::string what = std::string(algorithm) + " level " + std::to_string(l);
            expect_same(refine(built->mesh, targets[l]), built->levels[l].primitive, what);
            expect_same((*direct)[l].primitive, built->levels[l].primitive, what + " simplify");
            expect_same((*single)[l].primitive, built->levels[l].primitive, what + " 1 thread");
        }
        expect_same(refine(built->mesh, in.triangle_count()), in, std::string(algorithm) + " full");
    }
}

// Melax runs strictly greedy, so one run's collapse sequence does not depend on its targets: the
// progressive mesh refined to any count equals simplify() asked for that count alone.
TEST(ProgressiveMesh, RefineToAnyCountEqualsSimplifyForThatCount) {
    const Primitive in = seamed_bumpy_grid(12);  // 288 triangles
    const size_t base[] = {20};
    Result<ProgressiveMeshBuild> built = build_progressive_mesh(in, "melax", base);
    ASSERT_TRUE(built.ok()) << built.error().message;
    for (size_t count : {250, 171, 100, 57, 21}) {
        const size_t targets[] = {count};
        Result<std::vector<SimplifiedLevel>> direct = simplify(in, "melax", targets);
        ASSERT_TRUE(direct.ok()) << direct.error().message;
        expect_same(refine(built->mesh, count), direct->front().primitive,
                    "count " + std::to_string(count));
    }
}

// Rebased at a snapshot, the progressive mesh is the same mesh from there on: its base is that
// snapshot, every finer count refines as before, and it survives the file round trip.
TEST(ProgressiveMesh, RebaseStartsAtASnapshotAndRefinesAsBefore) {
    const Primitive in = seamed_bumpy_grid(16);  // 512 triangles
    const size_t targets[] = {400, 250, 100, 30};
    for (const char* algorithm : {"qem", "melax"}) {
        Result<ProgressiveMeshBuild> built = build_progressive_mesh(in, algorithm, targets);
        ASSERT_TRUE(built.ok()) << built.error().message;
        const size_t at = built->levels[2].primitive.triangle_count();
        const ProgressiveMesh rebased = rebase_progressive_mesh(built->mesh, at);
        EXPECT_EQ(rebased.base_triangles(), at);
        EXPECT_EQ(rebased.full_triangles(), in.triangle_count());
        EXPECT_LT(rebased.splits.size(), built->mesh.splits.size());
        Result<ProgressiveMesh> back = decode_progressive_mesh(encode_progressive_mesh(rebased));
        ASSERT_TRUE(back.ok()) << back.error().message;
        for (const ProgressiveMesh* pm : {&rebased, static_cast<const ProgressiveMesh*>(&*back)}) {
            expect_same(refine(*pm, 1), built->levels[2].primitive,
                        std::string(algorithm) + " base");
            for (size_t l = 0; l < 3; ++l)
                expect_same(refine(*pm, targets[l]), built->levels[l].primitive,
                            std::string(algorithm) + " level " + std::to_string(l));
            expect_same(refine(*pm, in.triangle_count()), in, std::string(algorithm) + " full");
        }
        // At or below the base: the same mesh.
        EXPECT_EQ(encode_progressive_mesh(rebase_progressive_mesh(built->mesh, 1)),
                  encode_progressive_mesh(built->mesh));
    }
}

TEST(ProgressiveMesh, FileWriteAndRead) {
    const Primitive in = seamed_bumpy_grid(8);
    const size_t targets[] = {40};
    Result<ProgressiveMeshBuild> built = build_progressive_mesh(in, "qem", targets);
    ASSERT_TRUE(built.ok()) << built.error().message;
    const std::filesystem::path path = std::filesystem::temp_directory_path() /
                                       ("hmdnode_pm_test_" + std::to_string(::getpid()) + ".hmpm");
    ASSERT_TRUE(write_progressive_mesh(path, built->mesh).ok());
    Result<ProgressiveMesh> back = read_progressive_mesh(path);
    ASSERT_TRUE(back.ok()) << back.error().message;
    EXPECT_EQ(encode_progressive_mesh(*back), encode_progressive_mesh(built->mesh));
    std::filesystem::remove(path);
    Result<ProgressiveMesh> missing = read_progressive_mesh(path);
    ASSERT_FALSE(missing.ok());
    EXPECT_NE(missing.error().message.find(path.filename().string()), std::string::npos);
}

TEST(ProgressiveMesh, RejectsCorruptFilesNamingTheByte) {
    const Primitive in = seamed_bumpy_grid(6);
    const size_t targets[] = {20};
    Result<ProgressiveMeshBuild> built = build_progressive_mesh(in, "qem", targets);
    ASSERT_TRUE(built.ok()) << built.error().message;
    const std::vector<uint8_t> good = encode_progressive_mesh(built->mesh);
    ASSERT_TRUE(decode_progressive_mesh(good).ok());

    // Every truncation fails, naming the offset where the data ran out.
    for (size_t size = 0; size < good.size(); size += 1 + size / 7) {
        std::vector<uint8_t> bytes(good.begin(), good.begin() + size);
        Result<ProgressiveMesh> r = decode_progressive_mesh(bytes);
        ASSERT_FALSE(r.ok()) << size;
        EXPECT_NE(r.error().message.find("byte "), std::string::npos) << r.error().message;
    }
    auto with = [&](size_t offset, uint32_t value) {
        std::vector<uint8_t> bytes = good;
        for (int i = 0; i < 4; ++i) bytes[offset + i] = uint8_t(value >> (8 * i));
        return decode_progressive_mesh(bytes);
    };
    Result<ProgressiveMesh> magic = with(0, 0x12345678);
    ASSERT_FALSE(magic.ok());
    EXPECT_NE(magic.error().message.find("byte 0"), std::string::npos) << magic.error().message;
    Result<ProgressiveMesh> version = with(4, 99);
    ASSERT_FALSE(version.ok());
    EXPECT_NE(version.error().message.find("byte 4: version 99"), std::string::npos)
        << version.error().message;
    // The first base face's first wedge: header 44 bytes, base positions 16 bytes each, base
    // wedges 8 + 4 * (3 + 2 + 2 + 4) bytes each, then the face id.
    const ProgressiveMesh& pm = built->mesh;
    const size_t face_wedge = 44 + 16 * pm.base_positions.size() + 52 * pm.base_wedges.size() + 4;
    Result<ProgressiveMesh> wedge = with(face_wedge, 0xFFFFFFF0u);
    ASSERT_FALSE(wedge.ok());
    EXPECT_NE(wedge.error().message.find("byte " + std::to_string(face_wedge) + ":"),
              std::string::npos)
        << wedge.error().message;
    // A face id added twice.
    const size_t second_face = 44 + 16 * pm.base_positions.size() + 52 * pm.base_wedges.size() + 16;
    Result<ProgressiveMesh> twice = with(second_face, pm.base_faces[0].id);
    ASSERT_FALSE(twice.ok());
    EXPECT_NE(twice.error().message.find("byte " + std::to_string(second_face) + ": face"),
              std::string::npos)
        << twice.error().message;
    // Trailing bytes.
    std::vector<uint8_t> longer = good;
    longer.push_back(0);
    Result<ProgressiveMesh> trailing = decode_progressive_mesh(longer);
    ASSERT_FALSE(trailing.ok());
    EXPECT_NE(trailing.error().message.find("byte " + std::to_string(good.size())),
              std::string::npos)
        << trailing.error().message;
}

TEST(ProgressiveMesh, OnlyForEdgeCollapseAlgorithms) {
    const Primitive in = seamed_bumpy_grid(4);
    const size_t targets[] = {10};
    EXPECT_FALSE(build_progressive_mesh(in, "no-such", targets).ok());
    const size_t bad[] = {10, 20};
    EXPECT_FALSE(build_progressive_mesh(in, "qem", bad).ok());
    // Every algorithm the table marks as an edge collapse builds one, and no other does.
    for (const AlgorithmInfo& info : simplification_algorithms()) {
        EXPECT_EQ(build_progressive_mesh(in, info.name, targets).ok(), info.edge_collapse)
            << info.name;
    }
}

}  // namespace
}  // namespace hmdnode
