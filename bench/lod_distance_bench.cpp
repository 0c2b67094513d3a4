// Error-measurement benchmark: what `hmdnode lod` spends measuring each level against what it
// spends simplifying, both on one thread. Per mesh (the bundled bunny, fandisk and spot, and the
// bunny split 1:4 on its own faces), qem makes the 50 %, 10 % and 1 % levels in one call (threads =
// 1) as hmdnode lod does; then level 0 is prepared once (MeshDistanceReference: BVH and samples)
// and each level measured at hmdnode lod's defaults (mesh_distance.hpp). Times are the calling
// thread's CPU time (CLOCK_THREAD_CPUTIME_ID: this machine is shared, CPU time is what the work
// costs), medians of 5 runs. Target: measuring costs at most 1x simplifying.
//
// --big N: also the bunny split 1:4 N times (N = 2: 1.1 M faces, 3: 4.4 M), with --half every
// other face of that then split 1:3 at its centroid (N = 2: 2.2 M faces; still flat and closed),
// written as a binary PLY to a scratch directory and put through `hmdnode lod` at its defaults
// under /usr/bin/time -v: wall time, the breakdown from its --report (load, repair, simplify,
// measure per level, write) and the peak resident memory.
//
// Usage: bench_lod_distance_bench [MESH_FILE...] [--big N [--half]] [--runs N] [--write-docs]
//   --write-docs writes the table to docs/results/lod-distance-bench.md (and the --big figures to
//   docs/results/lod-distance-big.md).
#include <time.h>

#include <algorithm>
#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "doc_table.hpp"
#include "hmdnode/core/obj.hpp"
#include "hmdnode/lod/mesh_distance.hpp"
#include "hmdnode/lod/mesh_file.hpp"
#include "hmdnode/lod/simplify.hpp"
#include "lod/test_meshes.hpp"
#include "lod_bench_common.hpp"

namespace fs = std::filesystem;
using namespace hmdnode;
using bench::appendf;

namespace {

double median(std::vector<double> v) {
    return bench::quantile(std::move(v), 0.5);
}

Result<Primitive> load(const fs::path& file) {
    Result<Scene> scene = load_mesh_file(file);
    if (!scene.ok()) return scene.error();
    if (scene->meshes.empty() || scene->meshes[0].primitives.empty())
        return make_error(file.string() + ": no mesh");
    Primitive p;  // positions and indices: what the measurement and the split use
    p.positions = std::move(scene->meshes[0].primitives[0].positions);
    p.indices = std::move(scene->meshes[0].primitives[0].indices);
    return p;
}

// Binary little-endian PLY of positions and triangles.
bool write_ply(const fs::path& path, const Primitive& p) {
    std::ofstream out(path, std::ios::binary);
    out << "ply\nformat binary_little_endian 1.0\nelement vertex " << p.positions.size()
        << "\nproperty float x\nproperty float y\nproperty float z\nelement face "
        << p.triangle_count() << "\nproperty list uchar int vertex_indices\nend_header\n";
    out.write(reinterpret_cast<const char*>(p.positions.data()),
              std::streamsize(p.positions.size() * sizeof(glm::vec3)));
    for (size_t i = 0; i < p.indices.size(); i += 3) {
        const unsigned char n = 3;
        const int32_t f[3] = {int32_t(p.indices[i]), int32_t(p.indices[i + 1]),
                              int32_t(p.indices[i + 2])};
        out.write(reinterpret_cast<const char*>(&n), 1);
        out.write(reinterpret_cast<const char*>(f), sizeof f);
    }
    return bool(out);
}

struct Row {
    std::string mesh;
    bool prism = false;  // MeshDistanceOptions::prism_bounds
    size_t faces = 0;
    double simplify_ms = 0.0;   // one call, the three levels
    double reference_ms = 0.0;  // level 0's BVH and samples, once
    double level_ms[3] = {};    // each level's measurement
    double hausdorff[3] = {}, upper[3] = {}, mean[3] = {}, stderr_[3] = {};  // % of the diagonal
    double measure_ms() const { return reference_ms + level_ms[0] + level_ms[1] + level_ms[2]; }
};

const double kRatios[] = {0.5, 0.1, 0.01};

Row measure_mesh(const std::string& name, const Primitive& in, int runs, bool prism) {
    Row row;
    row.mesh = name;
    row.prism = prism;
    MeshDistanceOptions mo;
    mo.prism_bounds = prism;
    row.faces = in.triangle_count();
    std::vector<size_t> targets;
    for (double r : kRatios) targets.push_back(std::max<size_t>(1, size_t(r * double(row.faces))));
    SimplifyOptions so;
    so.threads = 1;
    std::vector<double> simplify_t, ref_t, level_t[3];
    std::vector<SimplifiedLevel> levels;
    for (int run = 0; run < runs; ++run) {
        double t0 = bench::thread_cpu_ms();
        Result<std::vector<SimplifiedLevel>> r = simplify(in, "qem", targets, so);
        simplify_t.push_back(bench::thread_cpu_ms() - t0);
        if (!r.ok()) {
            std::fprintf(stderr, "bench_lod_distance_bench: %s: %s\n", name.c_str(),
                         r.error().message.c_str());
            std::exit(1);
        }
        levels = std::move(r).value();
        t0 = bench::thread_cpu_ms();
        const MeshDistanceReference ref(view_of(in), mo);
        ref_t.push_back(bench::thread_cpu_ms() - t0);
        for (size_t k = 0; k < levels.size() && k < 3; ++k) {
            t0 = bench::thread_cpu_ms();
            const MeshDistance d = ref.measure(view_of(levels[k].primitive));
            level_t[k].push_back(bench::thread_cpu_ms() - t0);
            row.hausdorff[k] = d.hausdorff_pct();
            row.upper[k] = d.hausdorff_upper_pct();
            row.mean[k] = d.mean_pct();
            row.stderr_[k] = d.mean_stderr_pct();
        }
    }
    row.simplify_ms = median(simplify_t);
    row.reference_ms = median(ref_t);
    for (int k = 0; k < 3; ++k) row.level_ms[k] = median(level_t[k]);
    return row;
}

// Every other face of p (the even ones) split 1:3 at its centroid: twice the faces, the surface
// and its edges as they were (no T-junctions).
Primitive half_centroid_split(Primitive p) {
    const size_t faces = p.indices.size() / 3;
    std::vector<uint32_t> out;
    out.reserve(6 * faces);
    for (size_t f = 0; f < faces; ++f) {
        const uint32_t a = p.indices[3 * f], b = p.indices[3 * f + 1], c = p.indices[3 * f + 2];
        if (f % 2) {
            out.insert(out.end(), {a, b, c});
            continue;
        }
        const uint32_t m = uint32_t(p.positions.size());
        p.positions.push_back((p.positions[a] + p.positions[b] + p.positions[c]) / 3.0f);
        out.insert(out.end(), {a, b, m, b, c, m, c, a, m});
    }
    p.indices = std::move(out);
    return p;
}

// The --big run: the bunny split `splits` times (and with `half` every other face 1:3) through
// hmdnode lod; the table's text.
std::string big_run(const fs::path& bunny, int splits, bool half) {
    Result<Primitive> base = load(bunny);
    if (!base.ok()) {
        std::fprintf(stderr, "bench_lod_distance_bench: %s\n", base.error().message.c_str());
        std::exit(1);
    }
    Primitive big = test::subdivided_flat(std::move(*base), splits);
    if (half) big = half_centroid_split(std::move(big));
    const fs::path dir = fs::temp_directory_path() / "hmdnode_lod_big";
    fs::create_directories(dir);
    const fs::path ply = dir / "bunny-split.ply", glb = dir / "bunny-split.glb",
                   report = dir / "report.json", timing = dir / "time.txt";
    if (!write_ply(ply, big)) {
        std::fprintf(stderr, "bench_lod_distance_bench: cannot write %s\n", ply.c_str());
        std::exit(1);
    }
    const std::string cmd = "/usr/bin/time -v -o " + timing.string() +
                            " " HMDNODE_TOOL " lod --no-progress --in " + ply.string() + " --out " +
                            glb.string() + " --report " + report.string() + " > /dev/null";
    std::fprintf(stderr, "%s (%zu faces)\n", cmd.c_str(), big.triangle_count());
    if (std::system(cmd.c_str()) != 0) {
        std::fprintf(stderr, "bench_lod_distance_bench: hmdnode lod failed\n");
        std::exit(1);
    }
    double wall_s = 0.0, user_s = 0.0, sys_s = 0.0;
    long rss_kb = 0;
    std::ifstream t(timing);
    for (std::string l; std::getline(t, l);) {
        auto value = [&](const char* key) {
            const size_t at = l.find(key);
            return at == std::string::npos ? std::string() : l.substr(at + std::strlen(key));
        };
        if (std::string v = value("Maximum resident set size (kbytes): "); !v.empty())
            rss_kb = std::stol(v);
        if (std::string v = value("User time (seconds): "); !v.empty()) user_s = std::stod(v);
        if (std::string v = value("System time (seconds): "); !v.empty()) sys_s = std::stod(v);
        if (std::string v = value("Elapsed (wall clock) time (h:mm:ss or m:ss): "); !v.empty()) {
            double part = 0.0;  // [h:]m:ss.ss
            for (size_t start = 0;;) {
                const size_t colon = v.find(':', start);
                part = part * 60.0 + std::stod(v.substr(start, colon - start));
                if (colon == std::string::npos) break;
                start = colon + 1;
            }
            wall_s = part;
        }
    }
    const nlohmann::json j = nlohmann::json::parse(std::ifstream(report));
    std::string out;
    appendf(out,
            "`hmdnode lod --in bunny-split%d%s.ply --out ... --report ...` at its defaults (%zu "
            "faces, the bunny split 1:4 %d times on its own faces%s; binary PLY): %.1f s wall, "
            "%.1f s user + %.1f s system CPU, peak resident memory %.0f MB.\n\n",
            splits, half ? "h" : "", big.triangle_count(), splits,
            half ? ", then every other face 1:3 at its centroid" : "", wall_s, user_s, sys_s,
            double(rss_kb) / 1024.0);
    appendf(out, "| step | wall ms | CPU ms |\n|---|---|---|\n");
    const nlohmann::json& tm = j["timing_ms"];
    for (const char* step : {"load", "repair"})
        appendf(out, "| %s | %.0f | %.0f |\n", step, tm[step].get<double>(),
                tm[std::string(step) + "_cpu"].get<double>());
    double measure_wall = 0.0, measure_cpu = 0.0, simplify_wall = 0.0;
    std::string level_rows;
    for (const nlohmann::json& l : j["levels"]) {
        if (l["level"].get<int>() == 0) continue;
        simplify_wall = l["simplify_ms"].get<double>();
        measure_wall += l["measure_ms"].get<double>();
        measure_cpu += l["measure_cpu_ms"].get<double>();
        appendf(level_rows,
                "| measure level %d (%zu faces; Hausdorff %.4f..%.4f %%, mean %.5f ± %.5f %%) | "
                "%.0f | %.0f |\n",
                l["level"].get<int>(), l["triangles"].get<size_t>(),
                l["error_pct_diag"].get<double>(), l["error_upper_pct_diag"].get<double>(),
                l["mean_pct_diag"].get<double>(), l["mean_stderr_pct_diag"].get<double>(),
                l["measure_ms"].get<double>(), l["measure_cpu_ms"].get<double>());
    }
    // note: simplify's CPU time is the chains' less the measurement's (the measurement runs on the
    // calling thread; the rest of the chains' work is simplification and copies).
    appendf(out,
            "| simplify (qem, one call, all levels; CPU: the chains' less the measuring) | %.0f | "
            "%.0f |\n",
            simplify_wall, tm["chains_cpu"].get<double>() - measure_cpu);
    out += level_rows;
    appendf(out, "| measure, all levels | %.0f | %.0f |\n", measure_wall, measure_cpu);
    appendf(out, "| write (.glb and the rest: wall less the command's own total) | %.0f | |\n",
            wall_s * 1e3 - j["total_ms"].get<double>());
    appendf(out, "| total | %.0f | %.0f |\n", wall_s * 1e3, (user_s + sys_s) * 1e3);
    std::error_code ec;
    fs::remove_all(dir, ec);
    return out;
}

}  // namespace

int main(int argc, char** argv) {
    const bool write_docs = bench::wants_docs(argc, argv);
    const fs::path mesh_dir = fs::path(HMDNODE_SOURCE_DIR) / "data" / "meshes";
    std::vector<fs::path> files;
    int big = 0, runs = 5;
    bool half = false;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--big" && i + 1 < argc) {
            big = std::atoi(argv[++i]);
        } else if (a == "--half") {
            half = true;
        } else if (a == "--runs" && i + 1 < argc) {
            runs = std::max(1, std::atoi(argv[++i]));
        } else if (a == "--write-docs") {
        } else if (!a.empty() && a[0] == '-') {
            std::fprintf(stderr,
                         "usage: %s [MESH_FILE...] [--big N [--half]] [--runs N] [--write-docs]\n",
                         argv[0]);
            return 2;
        } else {
            files.push_back(a);
        }
    }
    const std::vector<bench::LodInput> inputs = bench::lod_inputs(mesh_dir, files);
    std::vector<Row> rows;
    for (const bench::LodInput& input : inputs) {
        Result<Primitive> p = load(input.file);
        if (!p.ok()) {
            std::fprintf(stderr, "bench_lod_distance_bench: %s\n", p.error().message.c_str());
            return 1;
        }
        Primitive in =
            input.splits ? test::subdivided_flat(std::move(*p), input.splits) : std::move(*p);
        std::fprintf(stderr, "%s: %zu faces\n", input.name.c_str(), in.triangle_count());
        for (bool prism : {false, true}) rows.push_back(measure_mesh(input.name, in, runs, prism));
    }
    const std::string run_text =
        "one thread, thread CPU time, medians of " + std::to_string(runs) + " runs";
    std::string out;
    appendf(
        out,
        "Measured by `build/release/bench/bench_lod_distance_bench --write-docs` (%s, %s; %s). ",
        bench::build_kind(), bench::machine_facts().c_str(), run_text.c_str());
    // The results file names the command and the machine in its header: it holds the rest.
    const size_t what_start = out.size();
    appendf(out,
            "Simplify: qem to 50/10/1 %% in one call; prepare: level 0's BVH and samples, once "
            "(charged to the 50 %% level in the worst-level column); the bracket is [sampled "
            "Hausdorff, its upper bound], %% of the diagonal; bounds: the default (Lipschitz and "
            "convex bounds) or prism (MeshDistanceOptions::prism_bounds, hmdnode lod "
            "--prism-bounds):\n\n");
    appendf(out,
            "| mesh | bounds | faces | simplify ms | prepare ms | measure 50 / 10 / 1 %% ms | all "
            "levels / "
            "simplify | worst level / simplify | Hausdorff 50 %% | Hausdorff 10 %% | Hausdorff 1 "
            "%% | mean ± stderr 10 %% |\n");
    appendf(out, "|---|---|---|---|---|---|---|---|---|---|---|---|\n");
    for (const Row& r : rows) {
        const double worst =
            std::max({r.reference_ms + r.level_ms[0], r.level_ms[1], r.level_ms[2]});
        appendf(out, "| %s | %s | %zu | %.1f | %.1f | %.1f / %.1f / %.1f | %.2fx | %.2fx |",
                r.mesh.c_str(), r.prism ? "prism" : "default", r.faces, r.simplify_ms,
                r.reference_ms, r.level_ms[0], r.level_ms[1], r.level_ms[2],
                r.measure_ms() / r.simplify_ms, worst / r.simplify_ms);
        for (int k = 0; k < 3; ++k) appendf(out, " %.4f..%.4f |", r.hausdorff[k], r.upper[k]);
        appendf(out, " %.4f ± %.4f |\n", r.mean[1], r.stderr_[1]);
    }
    std::printf("%s\n", out.c_str());
    std::string big_text;
    if (big > 0) {
        big_text = big_run(mesh_dir / "stanford-bunny.obj", big, half);
        std::printf("%s\n", big_text.c_str());
    }
    if (write_docs) {
        const std::string command = bench::command_line(argc, argv);
        if (!bench::write_result("lod-distance-bench",
                                 "What measuring a level costs against simplifying it", command,
                                 "Settings: " + run_text + ". " + out.substr(what_start)))
            return 1;
        if (big > 0 && !bench::write_result("lod-distance-big",
                                            "hmdnode lod on a mesh of a million faces and more",
                                            command, big_text))
            return 1;
    }
    return 0;
}
