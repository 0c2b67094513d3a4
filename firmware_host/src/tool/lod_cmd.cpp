// `hmdnode lod`: LOD chains for every mesh of a glTF, .glb, OBJ, PLY or OFF file, written as a
// .glb with MSFT_lod and each level's measured error (extras.geometric_error). Input is checked
// and repaired first (lod/mesh_repair.hpp). With --progressive, also the progressive mesh
// (lod/progressive_mesh.hpp, Hoppe 1996) of each mesh, based at its smallest level and recorded by
// the same simplification run as the levels; `hmdnode pm` (pm_cmd.cpp) reads those back. All or
// nothing: every output path is checked first and the outputs are written only once all are made.
// Formats and figures: docs/lod-generation.md.
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <functional>
#include <memory>
#include <set>
#include <span>
#include <string>
#include <system_error>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "hmdnode/core/atomic_file.hpp"
#include "hmdnode/core/gltf.hpp"
#include "hmdnode/lod/lod_chain.hpp"
#include "hmdnode/lod/mesh_file.hpp"
#include "hmdnode/lod/mesh_repair.hpp"
#include "hmdnode/lod/progressive_mesh.hpp"
#include "tool/cli_errors.hpp"
#include "tool/commands.hpp"

namespace hmdnode::tool {
namespace {

struct LodArgs {
    std::string in, out, algorithm = "qem", error, report, progressive;
    std::vector<double> ratios;
    std::vector<size_t> triangles;
    size_t step = 0;
    size_t samples = MeshDistanceOptions{}.samples;
    // Measurement threads: the machine's cores, at most 2 (the two directions at once: the same
    // figures as one thread, bit for bit).
    unsigned measure_threads = std::clamp(std::thread::hardware_concurrency(), 1u, 2u);
    uint32_t seed = 1;
    // Simplification threads: the machine's cores, at most 2 (the engine uses one helper at most).
    unsigned threads = std::clamp(std::thread::hardware_concurrency(), 1u, 2u);
    bool lock_borders = false;
    bool prism_bounds = false;
    bool list_algorithms = false;
    bool no_progress = false;
};

const CliErrors errors{"lod"};

// A bar redrawn in place on a terminal; nothing when stderr is not one (logs, pipes, tests).
class ProgressBar {
  public:
    explicit ProgressBar(bool enabled) : enabled_(enabled && isatty(STDERR_FILENO)) {}
    void update(double fraction) {
        if (!enabled_) return;
        const int pct = int(std::lround(std::clamp(fraction, 0.0, 1.0) * 100.0));
        if (pct == last_) return;
        last_ = pct;
        const int width = 40, filled = pct * width / 100;
        std::fprintf(stderr, "\r[%s%s] %3d%%", std::string(size_t(filled), '#').c_str(),
                     std::string(size_t(width - filled), ' ').c_str(), pct);
        std::fflush(stderr);
    }
    void finish() {
        if (enabled_ && last_ >= 0) std::fprintf(stderr, "\r%60s\r", "");
        last_ = -1;
    }

  private:
    bool enabled_;
    int last_ = -1;
};

// One progressive mesh to write: a primitive of a mesh the chain was made for.
struct ProgressiveOut {
    std::string path, mesh_name;
    size_t primitive = 0;
    ProgressiveMesh pm;
};

// A mesh name usable in a file name: anything but [A-Za-z0-9._-] becomes '_'.
std::string file_safe(const std::string& name) {
    std::string out = name;
    for (char& c : out)
        if (!std::isalnum(static_cast<unsigned char>(c)) && c != '.' && c != '_' && c != '-')
            c = '_';
    return out;
}

// The files of the progressive meshes generate_lod_chains recorded (LodChainReport::progressive,
// from the run that made each primitive's levels). One file: `out` itself; several: `out` less
// ".hmpm", then ".<mesh>" (".<mesh>.p<k>" for a mesh of several primitives) and ".hmpm".
std::vector<ProgressiveOut> progressive_outputs(std::vector<PrimitiveProgressiveMesh>&& pms,
                                                const std::string& out) {
    std::vector<ProgressiveOut> result;
    for (PrimitiveProgressiveMesh& p : pms) {
        ProgressiveOut o;
        o.mesh_name = p.mesh_name.empty() ? "mesh" + std::to_string(p.mesh) : p.mesh_name;
        if (p.primitives > 1) o.mesh_name += ".p" + std::to_string(p.primitive);
        o.primitive = p.primitive;
        o.pm = std::move(p.pm);
        result.push_back(std::move(o));
    }
    if (result.size() == 1) {
        result[0].path = out;
    } else {
        std::string stem = out;
        if (stem.size() > 5 && stem.compare(stem.size() - 5, 5, ".hmpm") == 0)
            stem.resize(stem.size() - 5);
        std::set<std::string> used;
        for (size_t i = 0; i < result.size(); ++i) {
            std::string name = file_safe(result[i].mesh_name);
            if (!used.insert(name).second) name += "." + std::to_string(i);  // same names
            used.insert(name);
            result[i].path = stem + "." + name + ".hmpm";
        }
    }
    return result;
}

// Every output is checked before the work starts (core's check_output_file), so that a bad path
// fails the command before anything is made. Empty when fine.
std::string check_output(const std::string& path, const char* what) {
    if (Status st = check_output_file(path); !st.ok())
        return std::string(what) + " " + st.error().message;
    return {};
}

// The outputs, written one by one only once all are made; when one fails, the ones this run wrote
// before it are removed again, so that a failed command leaves no output behind.
class Outputs {
  public:
    Status write(const std::string& path, const std::function<Status()>& writer) {
        Status s = writer();
        if (!s.ok()) {
            std::error_code ec;
            for (const std::string& w : written_) std::filesystem::remove(w, ec);
            written_.clear();
            return s;
        }
        written_.push_back(path);
        return {};
    }

  private:
    std::vector<std::string> written_;
};

void list_algorithms() {
    std::printf("%-18s %-13s %s\n", "algorithm", "edge collapse",
                "summary (source; full citations: docs/references.md)");
    for (const AlgorithmInfo& a : simplification_algorithms())
        std::printf("%-18s %-13s %s (%s)\n", a.name.c_str(), a.edge_collapse ? "yes" : "no",
                    a.summary.c_str(), a.source.c_str());
}

// The --report JSON. Throws what nlohmann::json throws (invalid UTF-8 in a name).
std::string report_json(const LodArgs& args, const LodChainOptions& options,
                        const RepairReport& repair, const LodChainReport& report,
                        const std::vector<ProgressiveOut>& progressive, double total_ms,
                        const nlohmann::json& timing) {
    nlohmann::json j;
    j["input"] = args.in;
    j["output"] = args.out;
    j["algorithm"] = args.algorithm;
    j["targets"] = {{"ratios", options.targets.ratios},
                    {"triangles", options.targets.triangles},
                    {"max_error_m", options.targets.max_error_m},
                    {"max_error_pct", options.targets.max_error_pct},
                    {"step", options.targets.step}};
    j["lock_borders"] = args.lock_borders;
    j["samples"] = args.samples;
    j["repair"] = {{"degenerate_faces", repair.degenerate_faces},
                   {"duplicate_faces", repair.duplicate_faces},
                   {"non_manifold_faces", repair.non_manifold_faces},
                   {"reoriented_faces", repair.reoriented_faces},
                   {"unreferenced_vertices", repair.unreferenced_vertices},
                   {"messages", repair.messages}};
    nlohmann::json levels = nlohmann::json::array();
    for (const LodLevelReport& l : report.levels)
        levels.push_back({{"mesh", l.mesh},
                          {"mesh_name", l.mesh_name},
                          {"level", l.level},
                          {"triangles", l.triangles},
                          {"target", l.target},
                          {"error_m", l.hausdorff_m},
                          {"error_pct_diag", l.hausdorff_pct},
                          {"mean_m", l.mean_m},
                          {"mean_pct_diag", l.mean_pct},
                          {"error_upper_m", l.hausdorff_upper_m},
                          {"error_upper_pct_diag", l.hausdorff_upper_pct},
                          {"mean_stderr_m", l.mean_stderr_m},
                          {"mean_stderr_pct_diag", l.mean_stderr_pct},
                          {"estimated_error", l.estimated_error},
                          {"simplify_ms", l.simplify_ms},
                          {"measure_ms", l.measure_ms},
                          {"measure_cpu_ms", l.measure_cpu_ms}});
    j["levels"] = std::move(levels);
    j["notes"] = report.notes;
    nlohmann::json pms = nlohmann::json::array();
    for (const ProgressiveOut& p : progressive)
        pms.push_back({{"file", p.path},
                       {"mesh_name", p.mesh_name},
                       {"primitive", p.primitive},
                       {"base_triangles", p.pm.base_triangles()},
                       {"full_triangles", p.pm.full_triangles()},
                       {"vertex_splits", p.pm.splits.size()}});
    j["progressive"] = std::move(pms);
    j["total_ms"] = total_ms;
    j["timing_ms"] = timing;
    return j.dump(2) + "\n";
}

void run_lod(const LodArgs& args) {
    using Clock = std::chrono::steady_clock;
    const Clock::time_point t0 = Clock::now();
    if (args.list_algorithms) {
        list_algorithms();
        return;
    }
    if (args.in.empty() || args.out.empty()) return errors.usage("--in and --out are required");

    LodChainOptions options;
    options.algorithm = args.algorithm;
    options.targets.ratios = args.ratios;
    options.targets.triangles = args.triangles;
    options.targets.step = args.step;
    if (!args.error.empty()) {
        std::string e = args.error;
        const bool pct = !e.empty() && e.back() == '%';
        if (pct) e.pop_back();
        char* end = nullptr;
        const double v = std::strtod(e.c_str(), &end);
        if (e.empty() || *end || !(v > 0.0) || !std::isfinite(v))
            return errors.usage("--error \"" + args.error +
                                "\": give a positive number of metres, or a percentage of the "
                                "bounding-box diagonal like 0.5%");
        (pct ? options.targets.max_error_pct : options.targets.max_error_m) = v;
    }
    if (options.targets.ratios.empty() && options.targets.triangles.empty() &&
        options.targets.max_error_m < 0 && options.targets.max_error_pct < 0 &&
        options.targets.step == 0)
        options.targets.ratios = {0.5, 0.1, 0.01};
    if (std::string e = check_lod_targets(options.targets); !e.empty()) return errors.usage(e);
    const AlgorithmInfo* algo = find_simplification_algorithm(args.algorithm);
    if (!algo)
        return errors.usage("unknown algorithm \"" + args.algorithm + "\" (see --list-algorithms)");
    if (args.step > 0 && !algo->edge_collapse)
        return errors.usage("--step needs an edge-collapse algorithm; \"" + args.algorithm +
                            "\" is not one (see --list-algorithms)");
    if (!args.progressive.empty() && !algo->edge_collapse)
        return errors.usage("--progressive needs an edge-collapse algorithm; \"" + args.algorithm +
                            "\" is not one (see --list-algorithms)");
    options.simplify.lock_borders = args.lock_borders;
    options.simplify.seed = args.seed;
    options.simplify.threads = args.threads;
    options.distance.samples = args.samples;
    options.distance.seed = args.seed;
    options.distance.threads = args.measure_threads;
    options.distance.prism_bounds = args.prism_bounds;
    options.progressive = !args.progressive.empty();

    // Every output checked before the work. The progressive meshes' names are known only after
    // it (one file per mesh); they go to the directory of --progressive, checked here.
    std::vector<std::string> paths = {args.out}, flags = {"--out"};
    if (!args.report.empty()) paths.push_back(args.report), flags.push_back("--report");
    if (!args.progressive.empty())
        paths.push_back(args.progressive), flags.push_back("--progressive");
    for (size_t i = 0; i < paths.size(); ++i) {
        if (std::string e = check_output(paths[i], flags[i].c_str()); !e.empty())
            return errors.fail(e + "; nothing written");
        for (size_t k = 0; k < i; ++k) {
            std::error_code ec;
            if (std::filesystem::weakly_canonical(paths[i], ec) ==
                std::filesystem::weakly_canonical(paths[k], ec))
                return errors.fail("--out, --report and --progressive name the same file " +
                                   paths[i] + "; nothing written");
        }
    }

    // The report's breakdown: wall ms, and the process's CPU ms as "<step>_cpu" (all threads).
    nlohmann::json timing;
    Clock::time_point step = Clock::now();
    std::clock_t step_cpu = std::clock();
    auto lap = [&](const char* name) {
        timing[name] = std::chrono::duration<double, std::milli>(Clock::now() - step).count();
        timing[std::string(name) + "_cpu"] = 1e3 * double(std::clock() - step_cpu) / CLOCKS_PER_SEC;
        step = Clock::now();
        step_cpu = std::clock();
    };
    Result<Scene> scene = load_mesh_file(args.in);
    lap("load");
    if (!scene.ok()) return errors.fail(scene.error().message + "; nothing written");
    RepairReport repair;
    if (Status s = repair_scene(*scene, repair); !s.ok())
        return errors.fail(s.error().message + "; nothing written");
    lap("repair");
    for (const std::string& m : repair.messages) errors.warning(m);

    ProgressBar bar(!args.no_progress);
    options.progress = [&bar](double f) { bar.update(f); };
    step = Clock::now();
    step_cpu = std::clock();
    Result<LodChainReport> report = generate_lod_chains(*scene, options);
    lap("chains");
    bar.finish();
    if (!report.ok()) return errors.fail(report.error().message + "; nothing written");
    std::vector<ProgressiveOut> progressive =
        progressive_outputs(std::move(report->progressive), args.progressive);
    for (const std::string& n : report->notes) errors.note(n);
    for (const ProgressiveOut& p : progressive)
        if (std::error_code ec; std::filesystem::is_directory(p.path, ec))
            return errors.fail("--progressive " + p.path + ": is a directory; nothing written");

    // The report's text is made before anything is written (its serialisation can fail too).
    std::string report_text;
    const double total_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
    if (!args.report.empty()) {
        try {
            report_text =
                report_json(args, options, repair, *report, progressive, total_ms, timing);
        } catch (const std::exception& e) {
            return errors.fail("--report " + args.report + ": " + e.what() + "; nothing written");
        }
    }
    // Each file is written atomically; when one fails, those written before it are removed.
    Outputs outputs;
    Status written = outputs.write(args.out, [&] { return save_glb(*scene, args.out); });
    for (size_t i = 0; written.ok() && i < progressive.size(); ++i)
        written = outputs.write(progressive[i].path, [&] {
            return write_progressive_mesh(progressive[i].path, progressive[i].pm);
        });
    if (written.ok() && !args.report.empty())
        written = outputs.write(args.report,
                                [&] { return write_file_atomically(args.report, report_text); });
    if (!written.ok()) return errors.fail(written.error().message + "; nothing written");

    std::printf("%-24s %5s %10s %12s %9s %9s %9s %10s %10s\n", "mesh", "level", "triangles",
                "error m", "error %", "<= %", "mean %", "simplify ms", "measure ms");
    for (const LodLevelReport& l : report->levels)
        std::printf("%-24s %5d %10zu %12.6g %9.4f %9.4f %9.4f %10.1f %10.1f\n", l.mesh_name.c_str(),
                    l.level, l.triangles, l.hausdorff_m, l.hausdorff_pct, l.hausdorff_upper_pct,
                    l.mean_pct, l.simplify_ms, l.measure_ms);
    std::printf("wrote %s: %zu meshes, %zu nodes with chains (%s, %.0f ms)\n", args.out.c_str(),
                report->meshes, report->nodes, args.algorithm.c_str(), total_ms);
    for (const ProgressiveOut& p : progressive)
        std::printf(
            "wrote %s: progressive mesh of \"%s\", base %zu, full %zu triangles, %zu "
            "vertex splits\n",
            p.path.c_str(), p.mesh_name.c_str(), p.pm.base_triangles(), p.pm.full_triangles(),
            p.pm.splits.size());
}

void add_lod_command(CLI::App& app) {
    auto args = std::make_shared<LodArgs>();
    CLI::App* lod = app.add_subcommand(
        "lod", "Make LOD chains (MSFT_lod, measured error) for every mesh of a scene or mesh file");
    lod->add_option("--in", args->in, "Input: glTF, .glb, OBJ, PLY or OFF");
    lod->add_option("--out", args->out, "Output .glb (written only on success)");
    lod->add_option("--algorithm", args->algorithm, "Simplification algorithm (--list-algorithms)")
        ->capture_default_str();
    auto* ratios = lod->add_option("--ratios", args->ratios,
                                   "Fractions of each mesh's triangles, decreasing "
                                   "(default 0.5,0.1,0.01)")
                       ->delimiter(',');
    auto* tris =
        lod->add_option("--triangles", args->triangles, "Triangle counts per mesh, decreasing")
            ->delimiter(',');
    auto* error = lod->add_option("--error", args->error,
                                  "One level: the coarsest found whose measured Hausdorff error "
                                  "is <= E metres (or E% of the bounding-box diagonal)");
    ratios->excludes(tris)->excludes(error);
    tris->excludes(error);
    lod->add_option("--step", args->step,
                    "A level every N triangles (edge-collapse algorithms; down to the smallest "
                    "ratio or count, else to one triangle)");
    lod->add_flag("--lock-borders", args->lock_borders, "Keep open-border vertices in place");
    lod->add_option("--report", args->report,
                    "Write the table of levels as JSON here (all outputs are written only when "
                    "all can be)");
    lod->add_option("--samples", args->samples,
                    "Surface samples per direction for the error measurement (0: an eighth of "
                    "the sampled mesh's triangle count, at least 1024)")
        ->capture_default_str();
    lod->add_option("--measure-threads", args->measure_threads,
                    "Threads for the error measurement (0: one per hardware thread; with 2 the "
                    "two directions run at once, the same figures as with 1)")
        ->capture_default_str();
    lod->add_flag("--prism-bounds", args->prism_bounds,
                  "Bound each level's Hausdorff distance from above by the prism bound: within a "
                  "few percent of the measured maximum on smooth meshes, at two to three times "
                  "the measuring time");
    lod->add_option("--seed", args->seed, "Seed of randomised steps and of the sampling")
        ->capture_default_str();
    lod->add_option("--threads", args->threads,
                    "Simplification threads: 1 = this thread only, 2 = a helper thread for qem "
                    "and curvature-qem on meshes of 8192 faces or more (the same output); "
                    "default: the machine's cores, at most 2")
        ->check(CLI::Range(1u, 64u))
        ->capture_default_str();
    lod->add_flag("--no-progress", args->no_progress,
                  "No progress bar (it is drawn only when stderr is a terminal)");
    lod->add_option("--progressive", args->progressive,
                    "Also write each mesh's progressive mesh (.hmpm, edge-collapse algorithms), "
                    "based at its smallest level; several meshes: OUT.<mesh>.hmpm");
    lod->add_flag("--list-algorithms", args->list_algorithms, "List the algorithms and exit");
    lod->callback([args] { run_lod(*args); });
}

const CommandRegistration reg{40, add_lod_command};

}  // namespace
}  // namespace hmdnode::tool
