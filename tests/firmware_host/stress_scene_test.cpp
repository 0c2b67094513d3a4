// `hmdnode scene stress` with one copy: the structure of the heavy scene (instanced LOD chains
// with errors growing as triangles fall, vertex light on every vertex, the ground), and usage
// errors exit 2 without output.
#include <gtest/gtest.h>

#include <filesystem>
#include <set>
#include <string>

#include "firmware_host/command_run.hpp"
#include "hmdnode/core/gltf.hpp"

namespace fs = std::filesystem;
using hmdnode::test::run;

namespace hmdnode {
namespace {

const std::string kTool = HMDNODE_TOOL;
const std::string kData = std::string(HMDNODE_SOURCE_DIR) + "/data";

TEST(StressScene, OneCopyHasInstancedLodChainsAndVertexLight) {
    const fs::path d = hmdnode::test::fresh_temp_dir("hmdnode_stress_scene");
    const auto r = run(kTool + " scene stress --data " + kData + " --out " +
                       (d / "s.glb").string() + " --copies 2 --vertex-samples 2");
    ASSERT_EQ(r.code, 0) << r.output;
    EXPECT_NE(r.output.find("10 objects"), std::string::npos) << r.output;
    Result<Scene> s = load_gltf(d / "s.glb");
    ASSERT_TRUE(s.ok()) << s.error().message;
    const std::vector<SceneObject> objects = flatten_objects(*s);
    ASSERT_EQ(objects.size(), 11u);  // the ground and 2 x (3 bunnies, a spot, a fandisk)
    size_t full = 0, bunnies = 0;
    std::set<int> level0_meshes;
    for (const SceneObject& o : objects) {
        full += o.levels[0].triangles;
        if (o.name == "ground") {
            EXPECT_EQ(o.levels.size(), 1u);
            continue;
        }
        if (o.name.rfind("bunny_", 0) == 0) ++bunnies;
        level0_meshes.insert(o.levels[0].mesh);
        ASSERT_GE(o.levels.size(), 4u) << o.name;
        EXPECT_EQ(o.levels[0].geometric_error_m, 0.0);
        for (size_t k = 1; k < o.levels.size(); ++k) {
            EXPECT_LT(o.levels[k].triangles, o.levels[k - 1].triangles) << o.name << " L" << k;
            EXPECT_GT(o.levels[k].geometric_error_m, o.levels[k - 1].geometric_error_m)
                << o.name << " L" << k;
        }
        EXPECT_GT(o.bounds_radius, 0.1) << o.name;
        EXPECT_GE(glm::length(glm::dvec2(o.bounds_center.x, o.bounds_center.z)), 1.0) << o.name;
    }
    EXPECT_EQ(bunnies, 6u);
    EXPECT_EQ(level0_meshes.size(), 3u);  // copies share their models' meshes
    EXPECT_EQ(full, 2 * (3 * 69451 + 5856 + 12946) + 2u);
    for (const Mesh& m : s->meshes)
        for (const Primitive& p : m.primitives) {
            ASSERT_EQ(p.light.size(), p.positions.size()) << m.name;
            for (const glm::vec3& e : p.light) EXPECT_TRUE(e.x >= 0.0f && e.y >= 0.0f) << m.name;
        }
}

TEST(StressScene, UsageErrorsExitTwoAndWriteNothing) {
    const fs::path d = hmdnode::test::fresh_temp_dir("hmdnode_stress_scene_usage");
    const auto r = run(kTool + " scene stress --data " + kData + " --out " +
                       (d / "s.glb").string() + " --copies 0");
    EXPECT_EQ(r.code, 2) << r.output;
    const auto missing = run(kTool + " scene stress --data " + (d / "nothing").string() +
                             " --out " + (d / "s.glb").string() + " --copies 1");
    EXPECT_EQ(missing.code, 1) << missing.output;
    EXPECT_NE(missing.output.find("stanford-bunny.obj"), std::string::npos) << missing.output;
    EXPECT_FALSE(fs::exists(d / "s.glb"));
}

}  // namespace
}  // namespace hmdnode
