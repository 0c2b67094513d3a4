// Every glTF the tools write passes the Khronos glTF-Validator with 0 errors and 0 warnings:
// `hmdnode bake` (lightmaps, and --vertex), `hmdnode lod`, `hmdnode scene demo` (the bundled
// demo scene the build generates) and `hmdnode scene stress`. The validator is the npm package
// `gltf-validator`, run by tests/tools/gltf_validate.js under Node.js; scripts/test installs it
// into build/npm when npm is there. Without `node` or the package the test says so and skips.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "firmware_host/command_run.hpp"
#include "hmdnode/bake/cornell_box.hpp"
#include "hmdnode/core/gltf.hpp"

namespace fs = std::filesystem;

namespace hmdnode {
namespace {

using hmdnode::test::CommandRun;
using hmdnode::test::run;

const std::string kTool = HMDNODE_TOOL;

// The folder holding node_modules/gltf-validator: $HMDNODE_NPM_PREFIX, else <source>/build/npm.
fs::path npm_prefix() {
    if (const char* p = std::getenv("HMDNODE_NPM_PREFIX"); p && *p) return p;
    return fs::path(HMDNODE_SOURCE_DIR) / "build" / "npm";
}

// Validates `files`; skips the calling test (returns false) when the validator cannot run.
CommandRun validate(const std::vector<fs::path>& files) {
    std::string cmd = "node " +
                      (fs::path(HMDNODE_SOURCE_DIR) / "tests/tools/gltf_validate.js").string() +
                      " --modules " + npm_prefix().string();
    for (const fs::path& f : files) {
        cmd += ' ';  // note: not " " + f.string(), which gcc 12 flags with a false -Wrestrict
        cmd += f.string();
    }
    return run(cmd);
}

bool validator_available(std::string* why) {
    if (run("command -v node").code != 0) {
        *why = "node (Node.js) is not installed";
        return false;
    }
    if (!fs::exists(npm_prefix() / "node_modules" / "gltf-validator" / "package.json")) {
        *why = "the npm package gltf-validator is not installed in " + npm_prefix().string() +
               " (scripts/test installs it when npm is present: npm install --prefix " +
               npm_prefix().string() + " gltf-validator)";
        return false;
    }
    return true;
}

#define SKIP_WITHOUT_VALIDATOR()                                                              \
    do {                                                                                      \
        std::string why;                                                                      \
        if (!validator_available(&why)) GTEST_SKIP() << "glTF-Validator: SKIPPED -- " << why; \
    } while (0)

TEST(GltfValidator, BakeOutputsAreValid) {
    SKIP_WITHOUT_VALIDATOR();
    const fs::path d = hmdnode::test::fresh_temp_dir("hmdnode_gltf_validator_bake");
    // The Cornell box: lightmaps (TEXCOORD_1 without TEXCOORD_0, MOZ_lightmap), a light quad
    // with emission above 1 baked per vertex (_LIGHT_0 above 1).
    ASSERT_TRUE(save_glb(cornell_box_scene(16.0), d / "in.glb").ok());
    ASSERT_TRUE(save_glb(cornell_box_scene(0.0), d / "plain.glb").ok());
    // `hmdnode bake` from d/IN to d/OUT with a few paths; the test stops when it fails.
    auto bake = [&](const char* in, const char* out, const std::string& extra) {
        const CommandRun r =
            run(kTool + " bake --in " + (d / in).string() + " --out " + (d / out).string() + extra +
                " --samples 4 --bounces 1 --no-progress");
        EXPECT_EQ(r.code, 0) << r.output;
        return r.code == 0;
    };
    ASSERT_TRUE(bake("in.glb", "lightmaps.glb", ""));
    ASSERT_TRUE(bake("plain.glb", "atlas.glb", " --texels-per-metre 16"));
    ASSERT_TRUE(bake("in.glb", "vertex.glb", " --vertex"));
    // Double-sided walls: split into front and back sheets (own texels / vertex light).
    Scene two_sided = cornell_box_scene(0.0);
    for (Material& m : two_sided.materials) m.double_sided = true;
    ASSERT_TRUE(save_glb(two_sided, d / "two_sided.glb").ok());
    ASSERT_TRUE(bake("two_sided.glb", "two_sided_atlas.glb", " --texels-per-metre 16"));
    ASSERT_TRUE(bake("two_sided.glb", "two_sided_vertex.glb", " --vertex"));
    CommandRun r;
    r = validate({d / "in.glb", d / "lightmaps.glb", d / "atlas.glb", d / "vertex.glb",
                  d / "two_sided_atlas.glb", d / "two_sided_vertex.glb"});
    std::printf("%s", r.output.c_str());
    EXPECT_EQ(r.code, 0) << r.output;
}

TEST(GltfValidator, LodOutputsAreValid) {
    SKIP_WITHOUT_VALIDATOR();
    const fs::path d = hmdnode::test::fresh_temp_dir("hmdnode_gltf_validator_lod");
    const fs::path spot = fs::path(HMDNODE_SOURCE_DIR) / "data/meshes/spot.obj";
    CommandRun r =
        run(kTool + " lod --in " + spot.string() + " --out " + (d / "spot.glb").string() +
            " --ratios 0.5,0.1 --samples 20000 --no-progress");
    ASSERT_EQ(r.code, 0) << r.output;
    // And a baked scene through lod (lightmaps, emission above 1).
    ASSERT_TRUE(save_glb(cornell_box_scene(16.0), d / "cornell.glb").ok());
    r = run(kTool + " lod --in " + (d / "cornell.glb").string() + " --out " +
            (d / "cornell_lod.glb").string() + " --ratios 0.5 --samples 20000 --no-progress");
    ASSERT_EQ(r.code, 0) << r.output;
    r = validate({d / "spot.glb", d / "cornell_lod.glb"});
    std::printf("%s", r.output.c_str());
    EXPECT_EQ(r.code, 0) << r.output;
}

TEST(GltfValidator, DemoSceneIsValid) {
    SKIP_WITHOUT_VALIDATOR();
    const fs::path demo = HMDNODE_DEMO_SCENE;  // written by `hmdnode scene demo` at build time
    ASSERT_TRUE(fs::exists(demo)) << demo;
    CommandRun r = validate({demo});
    std::printf("%s", r.output.c_str());
    EXPECT_EQ(r.code, 0) << r.output;
}

TEST(GltfValidator, StressSceneIsValid) {
    SKIP_WITHOUT_VALIDATOR();
    const fs::path d = hmdnode::test::fresh_temp_dir("hmdnode_gltf_validator_stress");
    CommandRun r = run(kTool + " scene stress --data " + HMDNODE_SOURCE_DIR + "/data --out " +
                       (d / "stress.glb").string() + " --copies 1 --vertex-samples 2");
    ASSERT_EQ(r.code, 0) << r.output;
    r = validate({d / "stress.glb"});
    std::printf("%s", r.output.c_str());
    EXPECT_EQ(r.code, 0) << r.output;
}

}  // namespace
}  // namespace hmdnode
