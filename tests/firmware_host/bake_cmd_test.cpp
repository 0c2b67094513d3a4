// `hmdnode bake` as a user runs it: outputs, summary and report, determinism across thread
// counts, the EXR master, vertex mode, the atlas for inputs without TEXCOORD_1, and errors that
// leave nothing written.
#include <gtest/gtest.h>

#include <sys/wait.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "firmware_host/command_run.hpp"
#include "hmdnode/bake/cornell_box.hpp"
#include "hmdnode/bake/lightmap_encode.hpp"
#include "hmdnode/core/atomic_file.hpp"
#include "hmdnode/core/gltf.hpp"

namespace fs = std::filesystem;

namespace hmdnode {
namespace {

using hmdnode::test::CommandRun;
using hmdnode::test::run;

fs::path temp_dir(const std::string& name) {
    return hmdnode::test::fresh_temp_dir("hmdnode_bake_cmd_test_" + name);
}

const std::string kTool = HMDNODE_TOOL;

std::string bake_cmd(const fs::path& in, const fs::path& out, const std::string& extra) {
    return kTool + " bake --in " + in.string() + " --out " + out.string() + " " + extra;
}

TEST(BakeCmd, BakesTheCornellBoxWithSummaryReportAndExr) {
    const fs::path d = temp_dir("cornell");
    ASSERT_TRUE(save_glb(cornell_box_scene(24.0), d / "in.glb").ok());
    CommandRun r =
        run(bake_cmd(d / "in.glb", d / "out.glb",
                     "--samples 8 --bounces 2 --threads 2 --seed 5 --intensity-percentile 1 "
                     "--report " +
                         (d / "r.json").string()));
    ASSERT_EQ(r.code, 0) << r.output;
    for (const char* part : {"texels", "rays per second", "time", "vertices"})
        EXPECT_NE(r.output.find(part), std::string::npos) << part << "\n" << r.output;
    Result<Scene> out = load_gltf(d / "out.glb");
    ASSERT_TRUE(out.ok()) << out.error().message;
    ASSERT_EQ(out->textures.size(), 1u);
    EXPECT_GT(out->materials[0].lightmap.intensity, 0.0f);
    EXPECT_EQ(out->materials[0].emissive_factor, glm::vec3(0.0f));
    EXPECT_EQ(out->materials[3].emissive_factor, glm::vec3(17.0f, 12.0f, 4.0f));
    // The light's primitive (no lightmap) got vertex light, no colours.
    EXPECT_EQ(out->meshes[0].primitives[3].light.size(), 4u);
    EXPECT_TRUE(out->meshes[0].primitives[3].colors.empty());

    std::ifstream f(d / "r.json");
    nlohmann::json j = nlohmann::json::parse(f);
    EXPECT_GT(j["texels"].get<size_t>(), 1000u);
    EXPECT_GT(j["rays"].get<uint64_t>(), j["texels"].get<uint64_t>() * 8);
    EXPECT_GT(j["rays_per_second"].get<double>(), 0.0);
    ASSERT_EQ(j["maps"].size(), 1u);
    const std::string exr = j["maps"][0]["exr"].get<std::string>();
    EXPECT_EQ(fs::path(exr), d / "out.lightmap0.exr");
    // The EXR master holds linear E; the PNG in the glTF is the same map, RGBM-encoded with the
    // range `intensity`: E = rgb/255 * a/255 * intensity within half a step of rgb.
    Result<HdrImage> master = read_exr(exr);
    ASSERT_TRUE(master.ok()) << master.error().message;
    ASSERT_EQ(master->width, out->textures[0].width);
    ASSERT_EQ(master->height, out->textures[0].height);
    const float intensity = out->materials[0].lightmap.intensity;
    EXPECT_EQ(out->materials[0].lightmap.encoding, LightmapEncoding::Rgbm);
    size_t compared = 0;
    for (size_t i = 0; i < master->rgb.size(); ++i)
        for (int c = 0; c < 3; ++c) {
            const float m = out->textures[0].rgba8[4 * i + 3] / 255.0f * intensity;
            const float png = out->textures[0].rgba8[4 * i + c] / 255.0f * m;
            EXPECT_NEAR(png, master->rgb[i][c], 0.51f / 255.0f * m + 1e-6f);
            ++compared;
        }
    EXPECT_GT(compared, 0u);
    // No temporaries left beside the output.
    for (const fs::directory_entry& e : fs::directory_iterator(d))
        EXPECT_EQ(e.path().string().find("partial"), std::string::npos) << e.path();
}

TEST(BakeCmd, SameSeedSameBytesForAnyThreadCount) {
    const fs::path d = temp_dir("determinism");
    ASSERT_TRUE(save_glb(cornell_box_scene(16.0), d / "in.glb").ok());
    const std::string opts = "--samples 4 --bounces 2 --seed 9 --no-progress --threads ";
    ASSERT_EQ(run(bake_cmd(d / "in.glb", d / "a.glb", opts + "1")).code, 0);
    ASSERT_EQ(run(bake_cmd(d / "in.glb", d / "b.glb", opts + "2")).code, 0);
    Result<std::string> a = read_file(d / "a.glb"), b = read_file(d / "b.glb");
    ASSERT_TRUE(a.ok() && b.ok());
    EXPECT_TRUE(*a == *b) << "outputs differ between 1 and 2 threads";
    ASSERT_EQ(
        run(bake_cmd(d / "in.glb", d / "c.glb", "--samples 4 --bounces 2 --seed 10 --threads 2"))
            .code,
        0);
    Result<std::string> c = read_file(d / "c.glb");
    EXPECT_FALSE(*a == *c) << "another seed gives another bake";
}

TEST(BakeCmd, VertexModeWritesLightAndNoLightmaps) {
    const fs::path d = temp_dir("vertex");
    ASSERT_TRUE(save_glb(cornell_box_scene(16.0), d / "in.glb").ok());
    CommandRun r = run(bake_cmd(d / "in.glb", d / "out.glb", "--vertex --samples 4 --bounces 1"));
    ASSERT_EQ(r.code, 0) << r.output;
    Result<Scene> out = load_gltf(d / "out.glb");
    ASSERT_TRUE(out.ok());
    for (const Material& m : out->materials) EXPECT_LT(m.lightmap.texture, 0);
    for (const Primitive& p : out->meshes[0].primitives) {
        ASSERT_EQ(p.light.size(), p.positions.size());
        EXPECT_TRUE(p.colors.empty());
        // Every primitive receives light (single vertices of the least-squares fit may clamp
        // to 0 at room corners), and no value is negative or not finite.
        float sum = 0.0f;
        for (const glm::vec3& c : p.light) {
            for (int k = 0; k < 3; ++k) EXPECT_TRUE(c[k] >= 0.0f && std::isfinite(c[k]));
            sum += c.r + c.g + c.b;
        }
        EXPECT_GT(sum, 0.0f);
    }
}

TEST(BakeCmd, BuildsAnAtlasForAnInputWithoutLightmaps) {
    const fs::path d = temp_dir("atlas");
    ASSERT_TRUE(save_glb(cornell_box_scene(0.0), d / "in.glb").ok());
    CommandRun r =
        run(bake_cmd(d / "in.glb", d / "out.glb", "--texels-per-metre 16 --samples 4 --bounces 1"));
    ASSERT_EQ(r.code, 0) << r.output;
    Result<Scene> out = load_gltf(d / "out.glb");
    ASSERT_TRUE(out.ok());
    ASSERT_GE(out->textures.size(), 1u);
    for (const Primitive& p : out->meshes[0].primitives)
        EXPECT_EQ(p.uv1.size(), p.positions.size());
}

TEST(BakeCmd, ErrorsWriteNothing) {
    const fs::path d = temp_dir("errors");
    // No light, no emission, no sky.
    Scene dark = cornell_box_scene(16.0);
    dark.materials[3].emissive_factor = glm::vec3(0.0f);
    ASSERT_TRUE(save_glb(dark, d / "dark.glb").ok());
    CommandRun r = run(bake_cmd(d / "dark.glb", d / "out.glb", "--samples 2"));
    EXPECT_NE(r.code, 0);
    EXPECT_NE(r.output.find("nothing to bake"), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(d / "out.glb"));
    // ... but a sky is enough.
    r = run(bake_cmd(d / "dark.glb", d / "out.glb", "--samples 2 --bounces 0 --sky 0.5,0.5,0.5"));
    EXPECT_EQ(r.code, 0) << r.output;
    EXPECT_TRUE(fs::exists(d / "out.lightmap0.exr"));
    fs::remove(d / "out.glb");
    fs::remove(d / "out.lightmap0.exr");
    // A malformed --sky.
    r = run(bake_cmd(d / "dark.glb", d / "out.glb", "--sky 1,2"));
    EXPECT_NE(r.code, 0);
    EXPECT_FALSE(fs::exists(d / "out.glb"));
    // A missing input is named.
    r = run(bake_cmd(d / "missing.glb", d / "out.glb", ""));
    EXPECT_NE(r.code, 0);
    EXPECT_NE(r.output.find("missing.glb"), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(d / "out.glb"));
    for (const fs::directory_entry& e : fs::directory_iterator(d))
        EXPECT_EQ(e.path().extension(), ".glb") << e.path();
}

// Every numeric option rejects nan, inf and values out of range as a usage error (exit 2), with
// the option named, before any work; nothing is written.
TEST(BakeCmd, NumericOptionsRejectNanInfAndNegatives) {
    const fs::path d = temp_dir("numbers");
    ASSERT_TRUE(save_glb(cornell_box_scene(16.0), d / "in.glb").ok());
    const std::vector<std::pair<std::string, std::string>> bad = {
        {"--texels-per-metre nan", "--texels-per-metre"},
        {"--texels-per-metre inf", "--texels-per-metre"},
        {"--texels-per-metre -4", "--texels-per-metre"},
        {"--texels-per-metre 0", "--texels-per-metre"},
        {"--samples 0", "--samples"},
        {"--samples -3", "--samples"},
        {"--samples nan", "--samples"},
        {"--bounces -1", "--bounces"},
        {"--bounces nan", "--bounces"},
        {"--threads -2", "--threads"},
        {"--seed -1", "--seed"},
        {"--sky nan,1,1", "--sky"},
        {"--sky 1,inf,1", "--sky"},
        {"--sky 1,1,-0.5", "--sky"},
        {"--intensity-percentile nan", "--intensity-percentile"},
        {"--intensity-percentile 0", "--intensity-percentile"},
        {"--intensity-percentile 1.5", "--intensity-percentile"},
        {"--intensity-percentile -inf", "--intensity-percentile"},
    };
    for (const auto& [opt, name] : bad) {
        fs::remove(d / "out.glb");
        CommandRun r = run(bake_cmd(d / "in.glb", d / "out.glb", opt + " --no-progress"));
        EXPECT_EQ(r.code, 2) << opt << "\n" << r.output;
        EXPECT_NE(r.output.find(name), std::string::npos) << opt << "\n" << r.output;
        EXPECT_FALSE(fs::exists(d / "out.glb")) << opt;
    }
}

// The output's folder is checked before the bake: a missing or read-only folder fails at once
// (the input is not even read: a missing input is not what the message names).
TEST(BakeCmd, OutputFolderIsCheckedBeforeAnyWork) {
    const fs::path d = temp_dir("outdir");
    CommandRun r = run(bake_cmd(d / "missing_input.glb", d / "no_such_folder" / "out.glb", ""));
    EXPECT_EQ(r.code, 1) << r.output;
    EXPECT_NE(r.output.find("no_such_folder does not exist"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("nothing written"), std::string::npos) << r.output;
    EXPECT_EQ(r.output.find("missing_input"), std::string::npos) << r.output;
    r = run(bake_cmd(d / "missing_input.glb", d / "out.glb",
                     "--report " + (d / "nowhere" / "r.json").string()));
    EXPECT_EQ(r.code, 1) << r.output;
    EXPECT_NE(r.output.find("--report"), std::string::npos) << r.output;
    r = run(bake_cmd(d / "missing_input.glb", d, ""));  // --out is a folder
    EXPECT_EQ(r.code, 1) << r.output;
    EXPECT_NE(r.output.find("is a directory"), std::string::npos) << r.output;
}

// A negative light intensity is an error naming the light; an emissive material that no mesh
// uses is a warning (and, as the only light, nothing to bake); KHR_materials_emissive_strength
// multiplies the emission the bake sees.
TEST(BakeCmd, LightInputChecks) {
    const fs::path d = temp_dir("lights");
    Scene neg = cornell_box_scene(16.0);
    Light l;
    l.name = "negative_bulb";
    l.intensity = -5.0f;
    l.node = 0;
    neg.lights.push_back(l);
    ASSERT_TRUE(save_glb(neg, d / "neg.glb").ok());
    CommandRun r = run(bake_cmd(d / "neg.glb", d / "out.glb", "--samples 2 --no-progress"));
    EXPECT_EQ(r.code, 1) << r.output;
    EXPECT_NE(r.output.find("negative_bulb"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("intensity"), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(d / "out.glb"));

    // The light quad's material, emissive, but the quad now uses a plain one.
    Scene unused = cornell_box_scene(16.0);
    Material spare = unused.materials[3];
    spare.name = "spare_glow";
    unused.materials.push_back(spare);
    unused.materials[3].emissive_factor = glm::vec3(0.0f);
    ASSERT_TRUE(save_glb(unused, d / "unused.glb").ok());
    r = run(bake_cmd(d / "unused.glb", d / "out.glb", "--samples 2 --no-progress"));
    EXPECT_EQ(r.code, 1) << r.output;
    EXPECT_NE(r.output.find("nothing to bake"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("'spare_glow' is emissive but no mesh"), std::string::npos) << r.output;
    r = run(bake_cmd(d / "unused.glb", d / "out.glb",
                     "--samples 2 --bounces 0 --sky 1,1,1 --no-progress"));
    EXPECT_EQ(r.code, 0) << r.output;
    EXPECT_NE(r.output.find("warning: material 4 'spare_glow' is emissive but no mesh"),
              std::string::npos)
        << r.output;
}

}  // namespace
}  // namespace hmdnode
