#include "hmdnode/core/obj.hpp"

#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

namespace hmdnode {
namespace {

namespace fs = std::filesystem;

class ObjTest : public ::testing::Test {
  protected:
    void SetUp() override {
        dir_ = fs::temp_directory_path() /
               ("hmdnode_obj_test_" +
                std::to_string(::testing::UnitTest::GetInstance()->random_seed()) + "_" +
                ::testing::UnitTest::GetInstance()->current_test_info()->name());
        fs::create_directories(dir_);
    }
    void TearDown() override { fs::remove_all(dir_); }

    fs::path write(const std::string& name, const std::string& text) {
        fs::path p = dir_ / name;
        std::ofstream(p, std::ios::binary) << text;
        return p;
    }

    fs::path dir_;
};

TEST_F(ObjTest, ReadsQuadWithUvAndNormalsAndTriangulatesFan) {
    fs::path p = write("quad.obj",
                       "# a unit quad\n"
                       "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
                       "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
                       "vn 0 0 2\n"
                       "f 1/1/1 2/2/1 3/3/1 4/4/1\n");
    Result<Mesh> m = load_obj(p);
    ASSERT_TRUE(m.ok()) << m.error().message;
    EXPECT_EQ(m->name, "quad");
    ASSERT_EQ(m->primitives.size(), 1u);
    const Primitive& pr = m->primitives[0];
    EXPECT_EQ(pr.positions.size(), 4u);
    EXPECT_EQ(pr.triangle_count(), 2u);
    EXPECT_EQ(pr.indices, (std::vector<uint32_t>{0, 1, 2, 0, 2, 3}));
    ASSERT_EQ(pr.uv0.size(), 4u);
    // OBJ v = 0 is the bottom of the image; glTF's v = 0 is the top.
    EXPECT_FLOAT_EQ(pr.uv0[0].y, 1.0f);
    EXPECT_FLOAT_EQ(pr.uv0[2].y, 0.0f);
    ASSERT_EQ(pr.normals.size(), 4u);
    EXPECT_FLOAT_EQ(pr.normals[1].z, 1.0f);  // renormalised
    EXPECT_EQ(pr.material, -1);
}

TEST_F(ObjTest, AcceptsEveryCornerFormAndNegativeIndices) {
    fs::path p = write("forms.obj",
                       "v 0 0 0\nv 1 0 0\nv 0 1 0\n"
                       "vt 0.5 0.5\nvn 0 0 1\n"
                       "f 1 2 3\n"
                       "f 1/1 2/1 3/1\n"
                       "f 1//1 2//1 3//1\n"
                       "f -3/-1/-1 -2/-1/-1 -1/-1/-1\n");
    Result<Mesh> m = load_obj(p);
    ASSERT_TRUE(m.ok()) << m.error().message;
    const Primitive& pr = m->primitives[0];
    EXPECT_EQ(pr.triangle_count(), 4u);
    // Distinct (v, vt, vn) triples: 3 bare + 3 with vt + 3 with vn + 3 with both.
    EXPECT_EQ(pr.positions.size(), 12u);
    // The last face, written with relative indices, reuses the triples of the same absolute ones.
    EXPECT_EQ(pr.indices[9], 9u);
    EXPECT_EQ(pr.indices[11], 11u);
    EXPECT_EQ(pr.positions[pr.indices[10]], glm::vec3(1, 0, 0));
}

TEST_F(ObjTest, DeduplicatesSharedCorners) {
    fs::path p = write("strip.obj",
                       "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 0 0\n"
                       "f 1 2 3\nf 1 3 4\nf 2 5 3\n");
    Result<Mesh> m = load_obj(p);
    ASSERT_TRUE(m.ok()) << m.error().message;
    EXPECT_EQ(m->primitives[0].positions.size(), 5u);
    EXPECT_EQ(m->primitives[0].triangle_count(), 3u);
    EXPECT_TRUE(m->primitives[0].uv0.empty());
}

TEST_F(ObjTest, ComputesAreaWeightedNormalsWhenFileHasNone) {
    // A fold: a big triangle facing +Z and a small one facing +X share the edge (0,0,0)-(0,1,0).
    fs::path p = write("fold.obj",
                       "v 0 0 0\nv 0 1 0\nv -3 0 0\nv 0 0 1\n"
                       "f 1 2 3\n"    // cross((0,1,0),(-3,0,0)) = (0,0,3): area 1.5
                       "f 1 4 2\n");  // cross((0,0,1),(0,1,0)) = (-1,0,0), area 0.5
    Result<Mesh> m = load_obj(p);
    ASSERT_TRUE(m.ok()) << m.error().message;
    const Primitive& pr = m->primitives[0];
    ASSERT_EQ(pr.normals.size(), 4u);
    glm::vec3 expected = glm::normalize(glm::vec3(-1, 0, 3));
    glm::vec3 n0 = pr.normals[pr.indices[0]];
    EXPECT_NEAR(n0.x, expected.x, 1e-6);
    EXPECT_NEAR(n0.z, expected.z, 1e-6);
    EXPECT_NEAR(pr.normals[pr.indices[2]].z, 1.0f, 1e-6);   // only on the big face
    EXPECT_NEAR(pr.normals[pr.indices[4]].x, -1.0f, 1e-6);  // only on the small face
}

TEST_F(ObjTest, ErrorsNameFileAndLine) {
    struct Case {
        const char* text;
        const char* needle;
    } cases[] = {
        {"v 0 0 0\nv 1 0 x\nf 1 1 1\n", ":2: bad number 'x'"},
        {"v 0 0 0\nv 1 0 0\nv 0 1 0\n\nf 1 2 4\n", ":5: vertex index 4 out of range"},
        {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -4\n", ":4: vertex index -4 out of range"},
        {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", ":4: vertex index 0 out of range"},
        {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1 2/1 3/1\n",
         ":4: texture coordinate index 1 out of range"},
        {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1//2 2//1 3//1\n", ":4: normal index 2 out of range"},
        {"v 0 0 0\nv 1 0 0\nf 1 2\n", ":3: a face needs at least three corners"},
        {"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1/1/1 2 3\n", ":4: bad face corner"},
        {"v 0 0 0\nv 1 0 0\nv 0 1 0\n", ": no faces"},
    };
    for (const Case& c : cases) {
        fs::path p = write("bad.obj", c.text);
        Result<Mesh> m = load_obj(p);
        ASSERT_FALSE(m.ok()) << c.text;
        EXPECT_NE(m.error().message.find(p.string()), std::string::npos) << m.error().message;
        EXPECT_NE(m.error().message.find(c.needle), std::string::npos) << m.error().message;
    }
    Result<Mesh> missing = load_obj(dir_ / "missing.obj");
    ASSERT_FALSE(missing.ok());
    EXPECT_NE(missing.error().message.find("missing.obj"), std::string::npos);
}

TEST_F(ObjTest, LoadsBundledMeshes) {
    Result<Mesh> bunny = load_obj(fs::path(HMDNODE_SOURCE_DIR) / "data/meshes/stanford-bunny.obj");
    ASSERT_TRUE(bunny.ok()) << bunny.error().message;
    EXPECT_EQ(bunny->triangle_count(), 69451u);
    // 35947 `v` lines, of which 34834 are used by faces: unused positions are not emitted.
    EXPECT_EQ(bunny->primitives[0].positions.size(), 34834u);
    for (const glm::vec3& n : bunny->primitives[0].normals) ASSERT_NEAR(glm::length(n), 1.0f, 1e-4);

    Result<Mesh> spot = load_obj(fs::path(HMDNODE_SOURCE_DIR) / "data/meshes/spot.obj");
    ASSERT_TRUE(spot.ok()) << spot.error().message;
    EXPECT_EQ(spot->triangle_count(), 5856u);
    EXPECT_EQ(spot->primitives[0].uv0.size(), spot->primitives[0].positions.size());
}

}  // namespace
}  // namespace hmdnode
