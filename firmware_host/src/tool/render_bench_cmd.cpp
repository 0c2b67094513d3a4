// hmdnode render-bench: a trace's frames rendered off-screen at the node's levels and at full
// detail from the same poses; render time, triangles, PSNR and SSIM (docs/lod-selection.md).
#include <cstdio>
#include <memory>
#include <string>

#include "cli/cli_checks.hpp"
#include "hmdnode/firmware_host/render_bench.hpp"
#include "tool/cli_errors.hpp"
#include "tool/commands.hpp"

namespace hmdnode::tool {
namespace {

const CliErrors errors{"render-bench"};

void add_render_bench_command(CLI::App& app) {
    auto opt = std::make_shared<RenderBenchOptions>();
    auto frames = std::make_shared<std::string>("100:1100");
    auto lod = std::make_shared<std::string>("auto");
    auto allocator = std::make_shared<std::string>("threshold");
    auto compare = std::make_shared<std::string>();
    auto eye_tracker = std::make_shared<std::string>("none");
    CLI::App* c = app.add_subcommand(
        "render-bench",
        "Render a trace's frames off-screen at the node's levels (and at full detail from the "
        "same poses): render time, triangles, PSNR and SSIM; JSON report and SVG plot");
    c->add_option("--scene", opt->scene, "Scene (.glb/.gltf)")->required();
    c->add_option("--trace", opt->trace, "Trace in hmdnode CSV")->required();
    c->add_option("--frames", *frames,
                  "Rendered frames FIRST:END of the replay (END exclusive; default 100:1100)");
    c->add_option("--eye-width", opt->eye_width, "Pixels per eye")->check(CLI::Range(11, 16384));
    c->add_option("--eye-height", opt->eye_height, "Pixels per eye")->check(CLI::Range(11, 16384));
    c->add_option("--refresh", opt->refresh_hz, "Display refresh rate (Hz)")
        ->check(CLI::Range(1.0, 1000.0));
    c->add_option("--lod", *lod,
                  "Levels drawn: auto (the node's selector and allocator), full (level 0) or "
                  "level=N");
    c->add_option("--allocator", *allocator,
                  "LOD allocator of the replay: threshold, greedy or iga")
        ->check(CLI::IsMember({"threshold", "greedy", "iga"}));
    c->add_option("--lod-tolerance-px", opt->tolerance_px, "LOD pixel tolerance at the gaze point")
        ->check(CLI::NonNegativeNumber);
    c->add_option("--msaa", opt->msaa_samples,
                  "Samples per pixel of the LOD and the full-detail frames: 1, or 4 (MSAA), so "
                  "that the comparison measures geometry rather than aliasing")
        ->check(CLI::IsMember({1, 4}));
    c->add_option("--compare", *compare,
                  "full: also render full detail from each pose and compare (PSNR, SSIM)")
        ->check(CLI::IsMember({"full"}));
    c->add_option("--images", opt->images_dir,
                  "Directory for PNGs of the frames (lod_NNNNN.png, full_NNNNN.png)");
    c->add_option("--images-every", opt->images_every, "Write every Nth frame's images")
        ->check(CLI::PositiveNumber);
    cli::add_eye_tracker_option(c, eye_tracker);
    c->add_option("--report", opt->report, "JSON report to write")->required();
    c->add_option("--plot", opt->plot, "SVG plot to write");

    c->callback([=] {
        RenderBenchOptions o = *opt;
        long long first = 0, end = 0;
        char tail = 0;
        if (std::sscanf(frames->c_str(), "%lld:%lld%c", &first, &end, &tail) != 2 || first < 0 ||
            end <= first)
            return errors.usage("--frames \"" + *frames +
                                "\": expected FIRST:END with 0 <= FIRST < END");
        o.first_frame = first;
        o.end_frame = end;
        Result<LodMode> mode = parse_lod_mode(*lod);
        if (!mode.ok()) return errors.usage(mode.error().message);
        o.lod = *mode;
        o.allocator = *parse_lod_allocator(*allocator);  // checked by IsMember
        o.eye_tracker = *parse_eye_tracker_backend(*eye_tracker, WiringKeys::command_line());
        o.compare_full = *compare == "full";
        if (!errors.check_outputs({{"--report", o.report.string()}, {"--plot", o.plot.string()}}))
            return;
        Result<RenderBenchResult> r = run_render_bench(o);
        if (!r.ok()) return errors.fail(r.error().message);
        std::fputs(render_bench_table(o, *r).c_str(), stdout);
        std::printf("report: %s\n", o.report.c_str());
        if (!o.plot.empty()) std::printf("plot: %s\n", o.plot.c_str());
    });
}

const CommandRegistration reg{47, add_render_bench_command};

}  // namespace
}  // namespace hmdnode::tool
