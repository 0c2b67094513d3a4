// `hmdnode bake`: global illumination into lightmaps (TEXCOORD_1 + MOZ_lightmap, EXR masters
// beside the output) or per-vertex light (_LIGHT_0) with the Embree path tracer (docs/baking.md).
// Progress with time left on stderr, a summary on stdout and optionally in a JSON report; the
// output .glb (and the EXRs) are written only when the whole bake succeeded, each atomically.

#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "hmdnode/bake/bake.hpp"
#include "hmdnode/bake/progress_eta.hpp"
#include "hmdnode/core/atomic_file.hpp"
#include "hmdnode/core/gltf.hpp"
#include "tool/cli_errors.hpp"
#include "tool/commands.hpp"

namespace hmdnode::tool {
namespace {

namespace fs = std::filesystem;

struct BakeArgs {
    std::string in, out, report;
    double texels_per_metre = 0.0;
    int samples = 64, bounces = -1, threads = 0;  // bounces < 0: until Russian roulette
    uint64_t seed = 1;
    bool vertex = false, no_progress = false, no_denoise = false;
    double intensity_percentile = BakeOptions{}.intensity_percentile;
    std::vector<float> sky;
};

const CliErrors errors{"bake"};

// A number option's check: a finite number in [lo, hi] (lo excluded when `open_lo`). CLI11 parses
// "nan" and "inf" as doubles; these checks turn them, and negatives, into usage errors (exit 2).
CLI::Validator number_in(double lo, bool open_lo, double hi, const std::string& what) {
    return CLI::Validator(
        [=](std::string& text) -> std::string {
            char* end = nullptr;
            const double v = std::strtod(text.c_str(), &end);
            if (text.empty() || end != text.c_str() + text.size())
                return "'" + text + "' is not a number";
            if (!std::isfinite(v) || (open_lo ? !(v > lo) : !(v >= lo)) || !(v <= hi))
                return "'" + text + "' is not " + what;
            return {};
        },
        what);
}

void run_bake(const BakeArgs& args) {
    const auto t0 = std::chrono::steady_clock::now();
    // note: the options' own checks (below) refuse every value out of range, nan and inf.
    if (!errors.check_outputs({{"--out", args.out}, {"--report", args.report}})) return;

    Result<Scene> loaded = load_gltf(args.in);
    if (!loaded) return errors.fail(loaded.error().message);
    Scene scene = std::move(*loaded);

    BakeOptions o;
    o.samples = args.samples;
    o.bounces = args.bounces;
    o.threads = args.threads;
    o.seed = args.seed;
    o.vertex = args.vertex;
    if (args.no_denoise) o.denoise_iterations = 0;
    o.intensity_percentile = args.intensity_percentile;
    if (args.sky.size() == 3) o.sky_radiance = glm::vec3(args.sky[0], args.sky[1], args.sky[2]);
    // Atlas: at the given density for every primitive without TEXCOORD_1; by default only when
    // the input has no lightmap at all (then at 32 texels per metre), so a scene that already
    // has its lightmaps (like the demo scene) keeps them and bakes its other primitives per
    // vertex.
    bool any_lightmap = false;
    for (const Material& m : scene.materials) any_lightmap |= m.lightmap.texture >= 0;
    o.texels_per_metre = args.texels_per_metre > 0.0 ? args.texels_per_metre
                         : any_lightmap              ? 0.0
                                                     : 32.0;
    const fs::path out(args.out);
    // EXR masters beside the output: OUT_STEM.lightmap<k>.exr, written to temporaries first.
    const std::string exr_final_prefix = (out.parent_path() / out.stem()).string() + ".lightmap";
    const std::string exr_tmp_prefix = exr_final_prefix + ".partial-" + std::to_string(getpid());
    if (!args.vertex) o.exr_prefix = exr_tmp_prefix;

    const bool show_progress = !args.no_progress && isatty(fileno(stderr));
    auto last = std::chrono::steady_clock::now();
    ProgressClock eta;
    bool finished = false;
    BakeProgress progress = [&](double f) {
        if (!show_progress || finished) return;
        finished = f >= 1.0;
        const auto now = std::chrono::steady_clock::now();
        const double t = std::chrono::duration<double>(now - t0).count();
        const double left = eta.seconds_left(t, f);
        if (f < 1.0 && now - last < std::chrono::milliseconds(200)) return;
        last = now;
        const int width = 30, fill = int(f * width + 0.5);
        char when[32];
        if (left >= 0.0)
            std::snprintf(when, sizeof when, "%6.1f s left", left);
        else
            std::snprintf(when, sizeof when, "%s", "  estimating ");
        std::fprintf(stderr, "\r[%s%s] %5.1f %%  %s ", std::string(fill, '#').c_str(),
                     std::string(width - fill, '.').c_str(), 100.0 * f, when);
        if (f >= 1.0) std::fprintf(stderr, "\n");
        std::fflush(stderr);
    };

    auto remove_exrs = [&](const std::string& prefix, size_t count) {
        std::error_code ec;
        for (size_t k = 0; k < count; ++k) fs::remove(prefix + std::to_string(k) + ".exr", ec);
    };
    Result<BakeReport> baked = bake_scene(scene, o, progress);
    if (!baked) {
        remove_exrs(exr_tmp_prefix, 64);
        errors.fail(baked.error().message);
        return errors.fail("nothing written to " + args.out);
    }
    const BakeReport& r = *baked;
    if (Status st = save_glb(scene, out); !st) {
        remove_exrs(exr_tmp_prefix, r.maps.size());
        return errors.fail(st.error().message);
    }
    std::vector<std::string> exrs;
    for (size_t k = 0; k < r.maps.size(); ++k) {
        if (r.maps[k].exr.empty()) continue;
        const std::string final_name = exr_final_prefix + std::to_string(k) + ".exr";
        std::error_code ec;
        fs::rename(r.maps[k].exr, final_name, ec);
        if (ec) return errors.fail("cannot rename " + r.maps[k].exr.string() + " to " + final_name);
        exrs.push_back(final_name);
    }
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

    for (const std::string& w : r.warnings) errors.warning(w);
    std::printf("baked %s -> %s\n", args.in.c_str(), args.out.c_str());
    std::printf("  %-22s %zu (%zu maps)\n", "texels", r.texels, r.maps.size());
    for (size_t k = 0; k < r.maps.size(); ++k) {
        const BakedMap& m = r.maps[k];
        std::printf(
            "    map %zu: %d x %d, %zu covered, %zu invalid, %zu dilated, intensity %.4g%s%s\n", k,
            m.width, m.height, m.covered, m.invalid, m.dilated, m.intensity,
            k < exrs.size() ? ", master " : "", k < exrs.size() ? exrs[k].c_str() : "");
    }
    std::printf("  %-22s %zu\n", "vertices", r.vertices);
    if (r.two_sided_primitives > 0)
        std::printf("  %-22s %zu (a front and a back sheet each)\n", "two-sided primitives",
                    r.two_sided_primitives);
    std::printf("  %-22s %zu\n", "triangles traced", r.triangles);
    std::printf("  %-22s %llu\n", "rays", static_cast<unsigned long long>(r.rays));
    std::printf("  %-22s %.3g\n", "rays per second", r.rays_per_second);
    std::printf("  %-22s %.2f s (tracing %.2f s, bake %.2f s)\n", "time", seconds, r.trace_seconds,
                r.seconds);

    if (!args.report.empty()) {
        nlohmann::json j;
        j["input"] = args.in;
        j["output"] = args.out;
        j["samples"] = args.samples;
        j["bounces"] = args.bounces;
        j["threads"] = args.threads;
        j["seed"] = args.seed;
        j["vertex"] = args.vertex;
        j["sky"] = {o.sky_radiance.r, o.sky_radiance.g, o.sky_radiance.b};
        j["texels"] = r.texels;
        j["vertices"] = r.vertices;
        j["two_sided_primitives"] = r.two_sided_primitives;
        j["triangles"] = r.triangles;
        j["rays"] = r.rays;
        j["rays_per_second"] = r.rays_per_second;
        j["seconds"] = seconds;
        j["trace_seconds"] = r.trace_seconds;
        j["warnings"] = r.warnings;
        nlohmann::json maps = nlohmann::json::array();
        for (size_t k = 0; k < r.maps.size(); ++k) {
            const BakedMap& m = r.maps[k];
            maps.push_back({{"texture", m.texture},
                            {"width", m.width},
                            {"height", m.height},
                            {"covered", m.covered},
                            {"invalid", m.invalid},
                            {"dilated", m.dilated},
                            {"pushed_samples", m.pushed_samples},
                            {"intensity", m.intensity},
                            {"exr", k < exrs.size() ? exrs[k] : ""}});
        }
        j["maps"] = maps;
        if (Status st = write_file_atomically(args.report, j.dump(2) + "\n"); !st)
            return errors.fail(st.error().message);
    }
}

void add_bake_command(CLI::App& app) {
    auto args = std::make_shared<BakeArgs>();
    CLI::App* bake = app.add_subcommand(
        "bake", "Bake global illumination into lightmaps or vertex colours (Embree path tracer)");
    bake->add_option("--in", args->in, "Input scene (.glb/.gltf) with lights or emissive materials")
        ->required();
    bake->add_option("--out", args->out, "Output .glb (written only on success)")->required();
    bake->add_option("--texels-per-metre", args->texels_per_metre,
                     "Build a lightmap atlas at this density for primitives without TEXCOORD_1 "
                     "(default: 32 when the input has no lightmap, else keep the input's)")
        ->check(number_in(0.0, true, 1e6, "a finite number > 0"));
    bake->add_option("--samples", args->samples, "Paths per texel / vertex sample")
        ->capture_default_str()
        ->check(CLI::Range(1, 1 << 24));
    bake->add_option("--bounces", args->bounces,
                     "Reflections of light at most (0: direct only; default: no limit, Russian "
                     "roulette ends each path); a limit that drops over 2 % of the light warns")
        ->check(CLI::NonNegativeNumber);
    bake->add_option("--threads", args->threads, "Worker threads (0: all cores)")
        ->capture_default_str()
        ->check(CLI::Range(0, 4096));
    bake->add_option("--seed", args->seed, "Random seed (same seed and inputs: same output)")
        ->capture_default_str()
        ->check(CLI::NonNegativeNumber);
    bake->add_flag("--vertex", args->vertex,
                   "Per-vertex light (_LIGHT_0) for every primitive instead of lightmaps");
    bake->add_option("--sky", args->sky, "Constant sky radiance R,G,B (default black)")
        ->delimiter(',')
        ->expected(3)
        ->check(number_in(0.0, false, 3.4e38, "a finite number >= 0"));
    bake->add_option("--report", args->report, "Write the summary as JSON here");
    bake->add_option("--intensity-percentile", args->intensity_percentile,
                     "Lightmap PNG scale = this quantile of the texels (1: the maximum; brighter "
                     "texels clamp in the PNG, not in the EXR master)")
        ->capture_default_str()
        ->check(number_in(0.0, true, 1.0, "a number in (0, 1]"));
    bake->add_flag("--no-denoise", args->no_denoise, "Skip the A-trous denoiser");
    bake->add_flag("--no-progress", args->no_progress,
                   "No progress bar (it is drawn only when stderr is a terminal)");
    bake->callback([args] { run_bake(*args); });
}

const CommandRegistration reg{45, add_bake_command};

}  // namespace
}  // namespace hmdnode::tool
