// `hmdnode render-bench` on the demo room, a few frames of the bundled trace: the report's summary
// agrees with its frames (LOD draws fewer triangles than full detail, PSNR and SSIM in range), full
// detail against itself gives the PSNR cap and SSIM 1, and usage errors exit 2 without output.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <string>

#include "firmware_host/command_run.hpp"
#include "hmdnode/core/image_quality.hpp"

namespace fs = std::filesystem;
using hmdnode::test::run;

namespace {

const std::string kTrace = std::string(HMDNODE_SOURCE_DIR) + "/data/traces/corbillon2018_user1.csv";

std::string bench(const std::string& args, const fs::path& report) {
    return std::string(HMDNODE_TOOL) + " render-bench --scene " + HMDNODE_DEMO_SCENE + " --trace " +
           kTrace + " --eye-width 96 --eye-height 108 --report " + report.string() + " " + args;
}

nlohmann::json read_json(const fs::path& p) {
    std::ifstream f(p);
    return nlohmann::json::parse(f);
}

}  // namespace

TEST(RenderBench, LodAgainstFullDetailSummaryMatchesItsFrames) {
    const fs::path dir = hmdnode::test::fresh_temp_dir("hmdnode_render_bench_auto");
    const auto r = run(bench("--frames 3:7 --compare full --plot " + (dir / "p.svg").string() +
                                 " --images " + (dir / "img").string() + " --images-every 2",
                             dir / "r.json"));
    ASSERT_EQ(r.code, 0) << r.output;
    const nlohmann::json j = read_json(dir / "r.json");
    const nlohmann::json& s = j["summary"];
    ASSERT_EQ(s["frames"], 4);
    ASSERT_EQ(j["per_frame"].size(), 4u);
    double lod_tri = 0, full_tri = 0;
    int64_t frame = 3;
    for (const auto& f : j["per_frame"]) {
        EXPECT_EQ(f["frame"], frame++);
        EXPECT_LT(f["triangles"].get<double>(), f["full_triangles"].get<double>());
        EXPECT_GT(f["render_ms"].get<double>(), 0.0);
        EXPECT_GT(f["psnr_db"].get<double>(), 10.0);
        EXPECT_LE(f["psnr_db"].get<double>(), hmdnode::kPsnrCapDb);
        EXPECT_GT(f["ssim"].get<double>(), 0.5);
        EXPECT_LE(f["ssim"].get<double>(), 1.0);
        lod_tri += f["triangles"].get<double>() / 4;
        full_tri += f["full_triangles"].get<double>() / 4;
    }
    EXPECT_NEAR(s["lod"]["triangles_mean"].get<double>(), lod_tri, 1e-6);
    EXPECT_NEAR(s["full"]["triangles_mean"].get<double>(), full_tri, 1e-6);
    EXPECT_LT(lod_tri, full_tri);
    EXPECT_NEAR(
        s["time_ratio"].get<double>(),
        s["full"]["render_ms"]["p50"].get<double>() / s["lod"]["render_ms"]["p50"].get<double>(),
        1e-9);
    EXPECT_LE(s["psnr_db"]["min"].get<double>(), s["psnr_db"]["median"].get<double>());
    EXPECT_LE(s["ssim"]["min"].get<double>(), s["ssim"]["median"].get<double>());
    EXPECT_EQ(j["lod"], "auto");
    EXPECT_TRUE(j["machine"].contains("load_1min_start"));
    EXPECT_TRUE(fs::exists(dir / "p.svg"));
    EXPECT_TRUE(fs::exists(dir / "img" / "lod_00003.png"));
    EXPECT_TRUE(fs::exists(dir / "img" / "full_00005.png"));
    EXPECT_FALSE(fs::exists(dir / "img" / "lod_00004.png"));
}

TEST(RenderBench, FullDetailAgainstItselfIsIdentical) {
    const fs::path dir = hmdnode::test::fresh_temp_dir("hmdnode_render_bench_full");
    const auto r = run(bench("--frames 0:2 --lod full --compare full", dir / "r.json"));
    ASSERT_EQ(r.code, 0) << r.output;
    const nlohmann::json s = read_json(dir / "r.json")["summary"];
    EXPECT_EQ(s["psnr_db"]["min"].get<double>(), hmdnode::kPsnrCapDb);
    EXPECT_EQ(s["ssim"]["min"].get<double>(), 1.0);
    EXPECT_EQ(s["lod"]["triangles_mean"], s["full"]["triangles_mean"]);
}

std::string read_bytes(const fs::path& p) {
    std::ifstream f(p, std::ios::binary);
    return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

// --msaa 4 renders both the LOD and the full-detail frames with four samples: full detail still
// matches itself exactly, the report names the samples, and the images are not the 1x ones (edges
// get intermediate values).
TEST(RenderBench, MsaaAppliesToBothFramesAndIsReported) {
    const fs::path dir = hmdnode::test::fresh_temp_dir("hmdnode_render_bench_msaa");
    for (int samples : {1, 4}) {
        const fs::path out = dir / std::to_string(samples);
        fs::create_directories(out);
        const auto r = run(bench("--frames 0:1 --lod full --compare full --msaa " +
                                     std::to_string(samples) + " --images " + out.string(),
                                 out / "r.json"));
        ASSERT_EQ(r.code, 0) << r.output;
        const nlohmann::json j = read_json(out / "r.json");
        EXPECT_EQ(j["msaa_samples"], samples);
        EXPECT_EQ(j["summary"]["psnr_db"]["min"].get<double>(), hmdnode::kPsnrCapDb);
    }
    const std::string one = read_bytes(dir / "1" / "full_00000.png");
    ASSERT_FALSE(one.empty());
    EXPECT_NE(one, read_bytes(dir / "4" / "full_00000.png"));
}

TEST(RenderBench, UsageErrorsExitTwoAndWriteNothing) {
    const fs::path dir = hmdnode::test::fresh_temp_dir("hmdnode_render_bench_usage");
    for (const char* bad : {"--frames 5:5", "--frames x", "--lod level=-1", "--lod coarse",
                            "--compare lod", "--msaa 2"}) {
        const auto r = run(bench(bad, dir / "r.json"));
        EXPECT_EQ(r.code, 2) << bad << ": " << r.output;
        EXPECT_FALSE(fs::exists(dir / "r.json")) << bad;
    }
    const auto r = run(bench("--frames 100000:100001", dir / "r.json"));
    EXPECT_EQ(r.code, 1) << r.output;
    EXPECT_NE(r.output.find("none in 100000:100001"), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(dir / "r.json"));
}
