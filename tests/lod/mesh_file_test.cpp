#include "hmdnode/lod/mesh_file.hpp"

#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

namespace hmdnode {
namespace {

namespace fs = std::filesystem;

fs::path write_temp(const std::string& name, const std::string& bytes) {
    const fs::path p = fs::path(testing::TempDir()) / ("hmdnode_mesh_file_" + name);
    std::ofstream(p, std::ios::binary) << bytes;
    return p;
}

bool contains(const std::string& s, const std::string& part) {
    return s.find(part) != std::string::npos;
}

// A unit square as a quad, with normals, uv and 8-bit colour, in binary big-endian.
std::string square_ply_big_endian() {
    std::string b =
        "ply\nformat binary_big_endian 1.0\ncomment x\nelement vertex 4\n"
        "property float x\nproperty float y\nproperty float z\nproperty float nx\n"
        "property float ny\nproperty float nz\nproperty float s\nproperty float t\n"
        "property uchar red\nproperty uchar green\nproperty uchar blue\n"
        "element face 1\nproperty list uchar int vertex_indices\n"
        "element extra 1\nproperty list uchar short stuff\nend_header\n";
    auto put_be = [&](const void* p, size_t n) {
        const char* c = static_cast<const char*>(p);
        for (size_t i = 0; i < n; ++i) b.push_back(c[n - 1 - i]);
    };
    const float xy[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    for (auto& v : xy) {
        const float f[8] = {v[0], v[1], 0, 0, 0, 1, v[0], v[1]};
        for (float x : f) put_be(&x, 4);
        b += std::string("\xff\x80\x00", 3);
    }
    b.push_back(4);
    for (int32_t i : {0, 1, 2, 3}) put_be(&i, 4);
    b.push_back(2);
    for (int16_t i : {7, 8}) put_be(&i, 2);
    return b;
}

TEST(MeshFile, ReadsBinaryBigEndianPlyWithAttributes) {
    Result<Scene> s = load_mesh_file(write_temp("square.ply", square_ply_big_endian()));
    ASSERT_TRUE(s.ok()) << s.error().message;
    ASSERT_EQ(s->meshes.size(), 1u);
    ASSERT_EQ(s->nodes.size(), 1u);
    EXPECT_EQ(s->roots, std::vector<int>{0});
    const Primitive& p = s->meshes[0].primitives.at(0);
    EXPECT_EQ(p.indices, (std::vector<uint32_t>{0, 1, 2, 0, 2, 3}));
    EXPECT_EQ(p.positions[2], glm::vec3(1, 1, 0));
    EXPECT_EQ(p.normals[1], glm::vec3(0, 0, 1));
    EXPECT_EQ(p.uv0[3], glm::vec2(0, 0));  // t = 1 flipped to glTF's top-left origin
    EXPECT_FLOAT_EQ(p.colors[0].r, 1.0f);
    EXPECT_NEAR(p.colors[0].g, 128.0 / 255.0, 1e-6);
    EXPECT_EQ(p.colors[0].a, 1.0f);
}

TEST(MeshFile, ReadsAsciiPlyAndOffAndComputesNormals) {
    Result<Scene> ply = load_mesh_file(
        write_temp("tri.ply",
                   "ply\r\nformat ascii 1.0\r\nelement vertex 3\r\nproperty double x\r\n"
                   "property double y\r\nproperty double z\r\nelement face 1\r\n"
                   "property list uchar uint vertex_index\r\nend_header\r\n0 0 0\n1 0 0\n0 1 0\n"
                   "3 0 1 2\n"));
    ASSERT_TRUE(ply.ok()) << ply.error().message;
    EXPECT_EQ(ply->meshes[0].primitives[0].normals[0], glm::vec3(0, 0, 1));
    Result<Scene> off = load_mesh_file(
        write_temp("quad.off", "OFF # c\n4 1 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3 255 0 0\n"));
    ASSERT_TRUE(off.ok()) << off.error().message;
    EXPECT_EQ(off->meshes[0].primitives[0].triangle_count(), 2u);
    EXPECT_EQ(off->meshes[0].name, "hmdnode_mesh_file_quad");
}

TEST(MeshFile, ErrorsNameTheFileAndThePlace) {
    auto message = [](const std::string& name, const std::string& bytes) {
        Result<Scene> s = load_mesh_file(write_temp(name, bytes));
        return s.ok() ? std::string("ok") : s.error().message;
    };
    const std::string head =
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
        "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
    EXPECT_TRUE(
        contains(message("a.ply", head + "0 0 0\n1 0 0\n0 1 0\n3 0 1 5\n"), "out of range"));
    EXPECT_TRUE(contains(message("b.ply", head + "0 0 0\n1 0 0\n0 1\n"), "truncated"));
    EXPECT_TRUE(contains(message("c.ply", "ply\nformat weird 1.0\nend_header\n"), "weird"));
    EXPECT_TRUE(
        contains(message("d.ply", "ply\nformat ascii 1.0\nelement vertex 1\n"), "end_header"));
    EXPECT_TRUE(contains(message("e.ply",
                                 "ply\nformat ascii 1.0\nelement vertex 1\nproperty quad x\n"
                                 "end_header\n"),
                         "quad"));
    EXPECT_TRUE(contains(message("f.off", "OFF\n3 1 0\n0 0 0\n1 0 x\n"), "\"x\""));
    EXPECT_TRUE(
        contains(message("g.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n2 0 1\n"), "2 corners"));
    EXPECT_TRUE(contains(message("h.txt", "hello"), "h.txt"));
    EXPECT_TRUE(contains(message("i.obj", ""), "empty"));
}

TEST(MeshFile, EveryTruncationOfABinaryPlyFailsCleanly) {
    const std::string full = square_ply_big_endian();
    const size_t header = full.find("end_header\n") + 11;
    for (size_t n = 0; n < full.size(); ++n) {
        Result<Scene> s = load_mesh_file(write_temp("cut.ply", full.substr(0, n)));
        EXPECT_FALSE(s.ok()) << n;
        if (n > header) {
            EXPECT_TRUE(contains(s.error().message, "truncated")) << n;
        }
    }
    // Flipped bytes never crash (checked under ASan); the result is either a mesh or an error.
    for (size_t i = header; i < full.size(); ++i) {
        std::string bad = full;
        bad[i] = char(bad[i] ^ 0x5a);
        Result<Scene> s = load_mesh_file(write_temp("flip.ply", bad));
        if (s.ok()) {
            for (uint32_t idx : s->meshes[0].primitives[0].indices)
                EXPECT_LT(idx, s->meshes[0].primitives[0].positions.size());
        }
    }
}

}  // namespace
}  // namespace hmdnode
