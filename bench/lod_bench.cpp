// LOD generation benchmark: every registered simplify() algorithm beside meshoptimizer's
// meshopt_simplify and meshopt_simplifySloppy (and OpenMesh's Decimater with ModQuadric through the
// "openmesh-quadric" algorithm when registered), on the bunny, fandisk and spot at 50 %, 10 % and
// 1 % of their triangles: time (median of 5 runs under 0.2 s, 3 under 2 s, else 1), triangles
// reached, mean and Hausdorff error (mesh_distance.hpp, % of the bounding-box diagonal); for the
// time target, qem's time over meshopt_simplify's from interleaved pairs of runs; on meshes with
// uv0, the texture drift (uv_drift_pct()). Every
// simplify() call passes one SimplifyScratch (as generate_lod_chains does for its calls), so the
// runs after the first reuse their working memory; a call without one pays about 1.1-1.25x for
// its page faults (docs/simplification.md, "Measurements behind the engine's choices").
//
// Usage: bench_lod_bench [MESH_DIR | MESH_FILE...] [--out PREFIX] [--only a,b] [--samples N]
//                        [--write-docs] [--hashes] [--profile [--runs N]]
//                        [--once ALGO RATIO [--mesh NAME]]
//   --hashes prints a hash of every algorithm's output per mesh and target (and of the chain of
//   the three targets in one call) and nothing else: outputs before and after an engine change
//   compare by it. --profile prints qem's time per collapse phase by phase beside
//   meshopt_simplify and the measurement (print_profile()) and nothing else. --once ALGO RATIO
//   (ALGO qem or meshopt) simplifies one input (--mesh NAME: bunny by default, or fandisk, spot,
//   bunny-split, or a file's stem) once to RATIO of its triangles inside run_once_qem() /
//   run_once_meshopt(), for callgrind's --toggle-collect='run_once*', and prints one line
//   (print_once()); usage errors exit 2.
//   MESH_DIR defaults to HMDNODE_SOURCE_DIR/data/meshes; writes PREFIX.json and
//   PREFIX.svg (default ./lod_bench) and a markdown table on stdout, then the target line;
//   --write-docs also writes the tables to docs/results/lod-bench.md (every algorithm) and
//   docs/results/lod-bench-target.md (qem against meshopt_simplify), and the plot to
//   docs/lod-generation-bench.svg.
#include <meshoptimizer.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <span>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "doc_table.hpp"
#include "hmdnode/core/atomic_file.hpp"
#include "hmdnode/core/obj.hpp"
#include "hmdnode/lod/mesh_distance.hpp"
#include "hmdnode/lod/mesh_file.hpp"
#include "hmdnode/lod/simplify.hpp"
#include "lod/test_meshes.hpp"
#include "lod_bench_common.hpp"

namespace fs = std::filesystem;
using namespace hmdnode;
using bench::appendf;
using Clock = std::chrono::steady_clock;

namespace {

struct Row {
    std::string mesh, algorithm;
    double ratio = 0.0;
    size_t input = 0, target = 0, triangles = 0;
    double ms = 0.0;
    int runs = 0;
    double mean_pct = 0.0, hausdorff_pct = 0.0;
    double reported_error = -1.0;  // meshoptimizer's own result_error (relative), or the estimate
    double uv_drift_pct = -1.0;    // uv_drift_pct(); < 0: the mesh has no uv0
    std::string failure;
    // qem only: its time over meshopt_simplify's from interleaved pairs (paired_time_ratios()),
    // with its helper thread (SimplifyOptions::threads = 2) and on one thread; and the process
    // CPU time of the helper-thread runs over their wall time (2.0: both cores busy throughout).
    int pairs = 0;
    double pair_ratio_p25 = 0.0, pair_ratio_median = 0.0, pair_ratio_p75 = 0.0;
    int pairs_1t = 0;
    double pair_1t_p25 = 0.0, pair_1t_median = 0.0, pair_1t_p75 = 0.0;
    double cpu_over_wall = 0.0;
};

// The point of triangle (a, b, c) nearest p, as barycentric coordinates (Ericson, Real-Time
// Collision Detection, 5.1.5).
glm::dvec3 closest_barycentric(const glm::dvec3& p, const glm::dvec3& a, const glm::dvec3& b,
                               const glm::dvec3& c) {
    const glm::dvec3 ab = b - a, ac = c - a, ap = p - a;
    const double d1 = glm::dot(ab, ap), d2 = glm::dot(ac, ap);
    if (d1 <= 0.0 && d2 <= 0.0) return {1, 0, 0};
    const glm::dvec3 bp = p - b;
    const double d3 = glm::dot(ab, bp), d4 = glm::dot(ac, bp);
    if (d3 >= 0.0 && d4 <= d3) return {0, 1, 0};
    const double vc = d1 * d4 - d3 * d2;
    if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) {
        const double v = d1 / (d1 - d3);
        return {1 - v, v, 0};
    }
    const glm::dvec3 cp = p - c;
    const double d5 = glm::dot(ab, cp), d6 = glm::dot(ac, cp);
    if (d6 >= 0.0 && d5 <= d6) return {0, 0, 1};
    const double vb = d5 * d2 - d1 * d6;
    if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) {
        const double w = d2 / (d2 - d6);
        return {1 - w, 0, w};
    }
    const double va = d3 * d6 - d5 * d4;
    if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0) {
        const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return {0, 1 - w, w};
    }
    const double denom = 1.0 / (va + vb + vc);
    const double v = vb * denom, w = vc * denom;
    return {1 - v - w, v, w};
}

// Texture drift: at samples on the output's faces (the centroid and three interior points each,
// weighted by area), |uv0 interpolated on the output - uv0 at the nearest point of the input
// surface|, area-weighted mean, in % of the input's uv0 range (the larger side of its bounding
// box). Where input faces of different charts are equally near (a seam), the nearest uv0 of them
// counts. Brute force over the input's faces (the spot: about a second). -1 without uv0.
double uv_drift_pct(const Primitive& in, const Primitive& out) {
    if (in.uv0.empty() || out.uv0.size() != out.positions.size()) return -1.0;
    glm::dvec2 lo(1e300), hi(-1e300);
    for (const glm::vec2& t : in.uv0)
        lo = glm::min(lo, glm::dvec2(t)), hi = glm::max(hi, glm::dvec2(t));
    const double range = std::max(hi.x - lo.x, hi.y - lo.y);
    glm::dvec3 blo(1e300), bhi(-1e300);
    for (const glm::vec3& p : in.positions)
        blo = glm::min(blo, glm::dvec3(p)), bhi = glm::max(bhi, glm::dvec3(p));
    const double tie = 1e-6 * glm::length(bhi - blo);
    const size_t nf = in.triangle_count();
    std::vector<double> dist(nf);
    std::vector<glm::dvec3> at(nf);
    const glm::dvec3 samples[] = {{1.0 / 3, 1.0 / 3, 1.0 / 3},
                                  {2.0 / 3, 1.0 / 6, 1.0 / 6},
                                  {1.0 / 6, 2.0 / 3, 1.0 / 6},
                                  {1.0 / 6, 1.0 / 6, 2.0 / 3}};
    double sum = 0.0, area_sum = 0.0;
    for (size_t f = 0; f < out.triangle_count(); ++f) {
        const uint32_t i0 = out.indices[3 * f], i1 = out.indices[3 * f + 1],
                       i2 = out.indices[3 * f + 2];
        const glm::dvec3 a = out.positions[i0], b = out.positions[i1], c = out.positions[i2];
        const double area = 0.5 * glm::length(glm::cross(b - a, c - a));
        if (!(area > 0.0)) continue;
        for (const glm::dvec3& l : samples) {
            const glm::dvec3 p = l.x * a + l.y * b + l.z * c;
            const glm::dvec2 uv = l.x * glm::dvec2(out.uv0[i0]) + l.y * glm::dvec2(out.uv0[i1]) +
                                  l.z * glm::dvec2(out.uv0[i2]);
            double best = 1e300;
            for (size_t g = 0; g < nf; ++g) {
                const glm::dvec3 ga = in.positions[in.indices[3 * g]],
                                 gb = in.positions[in.indices[3 * g + 1]],
                                 gc = in.positions[in.indices[3 * g + 2]];
                at[g] = closest_barycentric(p, ga, gb, gc);
                dist[g] = glm::length(p - (at[g].x * ga + at[g].y * gb + at[g].z * gc));
                best = std::min(best, dist[g]);
            }
            double drift = 1e300;
            for (size_t g = 0; g < nf; ++g) {
                if (dist[g] > best + tie) continue;
                const glm::dvec2 guv = at[g].x * glm::dvec2(in.uv0[in.indices[3 * g]]) +
                                       at[g].y * glm::dvec2(in.uv0[in.indices[3 * g + 1]]) +
                                       at[g].z * glm::dvec2(in.uv0[in.indices[3 * g + 2]]);
                drift = std::min(drift, glm::length(uv - guv));
            }
            sum += 0.25 * area * drift;
        }
        area_sum += area;
    }
    return area_sum > 0.0 && range > 0.0 ? 100.0 * sum / area_sum / range : -1.0;
}

double median(std::vector<double> v) {
    return bench::quantile(std::move(v), 0.5);
}

// Runs `fn` (returns the output) with the repeat policy; the output of the last run is kept.
template <class F>
auto timed(F&& fn, double& out_ms, int& out_runs) {
    std::vector<double> times;
    auto t0 = Clock::now();
    auto result = fn();
    times.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
    const int extra = times[0] < 200.0 ? 4 : times[0] < 2000.0 ? 2 : 0;
    for (int i = 0; i < extra; ++i) {
        t0 = Clock::now();
        result = fn();
        times.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
    }
    out_ms = median(times);
    out_runs = int(times.size());
    return result;
}

// meshopt_simplify to `target` triangles (target_error 1.0: only the count limits) into `dst`
// (sized for the input's indices); returns the index count written.
size_t run_meshopt_simplify(const Primitive& in, size_t target, std::vector<uint32_t>& dst,
                            float& result_error) {
    return meshopt_simplify(dst.data(), in.indices.data(), in.indices.size(), &in.positions[0].x,
                            in.positions.size(), sizeof(glm::vec3), target * 3, 1.0f, 0,
                            &result_error);
}

using bench::quantile;

double time_ms(const std::function<void()>& fn) {
    const auto t0 = Clock::now();
    fn();
    return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

double cpu_ms() {
    timespec t{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
    return double(t.tv_sec) * 1e3 + double(t.tv_nsec) * 1e-6;
}

struct Paired {
    int pairs = 0;
    double p25 = 0.0, median = 0.0, p75 = 0.0;
    double a_cpu_over_wall = 0.0;  // process CPU time over wall time while `a` ran
};

// The time target's figure: `a` and `b` run in interleaved pairs (A B, then B A, and so on, so that
// a drift of the machine's speed weighs on both alike), and the ratios a/b of the pairs give the
// median and quartiles. note: on a shared VM the speed of both cores changes by up to 1.5x within
// seconds; separate medians taken a minute apart (the table's) can then differ by that much for
// the same code.
Paired paired_time_ratios(const std::function<void()>& a, const std::function<void()>& b,
                          int pairs) {
    std::vector<double> ratios;
    double a_wall = 0.0, a_cpu = 0.0;
    auto run_a = [&] {
        const double c0 = cpu_ms();
        const double t = time_ms(a);
        a_cpu += cpu_ms() - c0;
        a_wall += t;
        return t;
    };
    for (int i = 0; i < pairs; ++i) {
        double ta, tb;
        if (i % 2 == 0) {
            ta = run_a(), tb = time_ms(b);
        } else {
            tb = time_ms(b), ta = run_a();
        }
        if (tb > 0.0) ratios.push_back(ta / tb);
    }
    Paired p;
    p.pairs = int(ratios.size());
    p.p25 = quantile(ratios, 0.25);
    p.median = quantile(ratios, 0.5);
    p.p75 = quantile(ratios, 0.75);
    p.a_cpu_over_wall = a_wall > 0.0 ? a_cpu / a_wall : 0.0;
    return p;
}

std::string fixed(double v, int digits) {
    char b[64];
    std::snprintf(b, sizeof b, "%.*f", digits, v);
    return b;
}

const char* kColors[] = {"#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b",
                         "#e377c2", "#7f7f7f", "#bcbd22", "#17becf", "#000000", "#aec7e8",
                         "#ffbb78", "#98df8a", "#ff9896", "#c5b0d5"};

// error (mean % of diagonal) vs triangles, log-log, one panel per mesh, one series per algorithm.
std::string svg_plot(const std::vector<Row>& rows, const std::vector<std::string>& meshes,
                     const std::vector<std::string>& algorithms) {
    const double pw = 360, ph = 300, ml = 60, mt = 40, mb = 50, legend_w = 200;
    const double width = ml + meshes.size() * (pw + ml) + legend_w, height = mt + ph + mb;
    std::ostringstream s;
    s << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << width << "\" height=\"" << height
      << "\" font-family=\"sans-serif\" font-size=\"11\">\n<rect width=\"100%\" height=\"100%\" "
         "fill=\"white\"/>\n";
    for (size_t mi = 0; mi < meshes.size(); ++mi) {
        const double x0 = ml + mi * (pw + ml), y0 = mt;
        double tmin = 1e30, tmax = 1, emin = 1e30, emax = 1e-30;
        for (const Row& r : rows)
            if (r.mesh == meshes[mi] && r.failure.empty() && r.triangles > 0 && r.mean_pct > 0) {
                tmin = std::min(tmin, double(r.triangles));
                tmax = std::max(tmax, double(r.triangles));
                emin = std::min(emin, r.mean_pct);
                emax = std::max(emax, r.mean_pct);
            }
        if (tmin > tmax) continue;
        const double lt0 = std::floor(std::log10(tmin)), lt1 = std::ceil(std::log10(tmax));
        const double le0 = std::floor(std::log10(emin)), le1 = std::ceil(std::log10(emax));
        auto X = [&](double t) {
            return x0 + (std::log10(t) - lt0) / std::max(1e-9, lt1 - lt0) * pw;
        };
        auto Y = [&](double e) {
            return y0 + ph - (std::log10(e) - le0) / std::max(1e-9, le1 - le0) * ph;
        };
        s << "<rect x=\"" << x0 << "\" y=\"" << y0 << "\" width=\"" << pw << "\" height=\"" << ph
          << "\" fill=\"none\" stroke=\"#444\"/>\n";
        s << "<text x=\"" << x0 + pw / 2 << "\" y=\"" << y0 - 12
          << "\" text-anchor=\"middle\" font-size=\"14\">" << meshes[mi] << "</text>\n";
        for (double d = lt0; d <= lt1; d += 1.0)
            s << "<line x1=\"" << X(std::pow(10, d)) << "\" y1=\"" << y0 << "\" x2=\""
              << X(std::pow(10, d)) << "\" y2=\"" << y0 + ph << "\" stroke=\"#ddd\"/><text x=\""
              << X(std::pow(10, d)) << "\" y=\"" << y0 + ph + 14 << "\" text-anchor=\"middle\">1e"
              << int(d) << "</text>\n";
        for (double d = le0; d <= le1; d += 1.0)
            s << "<line x1=\"" << x0 << "\" y1=\"" << Y(std::pow(10, d)) << "\" x2=\"" << x0 + pw
              << "\" y2=\"" << Y(std::pow(10, d)) << "\" stroke=\"#ddd\"/><text x=\"" << x0 - 4
              << "\" y=\"" << Y(std::pow(10, d)) + 4 << "\" text-anchor=\"end\">1e" << int(d)
              << "%</text>\n";
        s << "<text x=\"" << x0 + pw / 2 << "\" y=\"" << y0 + ph + 32
          << "\" text-anchor=\"middle\">triangles</text>\n";
        s << "<text x=\"" << x0 - 45 << "\" y=\"" << y0 + ph / 2 << "\" transform=\"rotate(-90 "
          << x0 - 45 << " " << y0 + ph / 2
          << ")\" text-anchor=\"middle\">mean error, % of diagonal</text>\n";
        for (size_t ai = 0; ai < algorithms.size(); ++ai) {
            std::vector<const Row*> pts;
            for (const Row& r : rows)
                if (r.mesh == meshes[mi] && r.algorithm == algorithms[ai] && r.failure.empty() &&
                    r.triangles > 0 && r.mean_pct > 0)
                    pts.push_back(&r);
            std::sort(pts.begin(), pts.end(),
                      [](const Row* a, const Row* b) { return a->triangles < b->triangles; });
            const char* color = kColors[ai % std::size(kColors)];
            if (pts.size() > 1) {
                s << "<polyline fill=\"none\" stroke=\"" << color << "\" points=\"";
                for (const Row* r : pts)
                    s << X(double(r->triangles)) << "," << Y(r->mean_pct) << " ";
                s << "\"/>\n";
            }
            for (const Row* r : pts)
                s << "<circle cx=\"" << X(double(r->triangles)) << "\" cy=\"" << Y(r->mean_pct)
                  << "\" r=\"3\" fill=\"" << color << "\"/>\n";
        }
    }
    const double lx = ml + meshes.size() * (pw + ml);
    for (size_t ai = 0; ai < algorithms.size(); ++ai) {
        const double y = mt + 10 + ai * 16;
        s << "<rect x=\"" << lx << "\" y=\"" << y - 8 << "\" width=\"10\" height=\"10\" fill=\""
          << kColors[ai % std::size(kColors)] << "\"/><text x=\"" << lx + 16 << "\" y=\"" << y
          << "\">" << algorithms[ai] << "</text>\n";
    }
    s << "</svg>\n";
    return s.str();
}

// FNV-1a over the bytes of every array of a primitive (and the material): the --hashes check that
// a change to the engine left its outputs as they were.
uint64_t primitive_hash(const Primitive& p) {
    uint64_t h = 0xcbf29ce484222325ull;
    auto add = [&](const void* data, size_t bytes) {
        const auto* b = static_cast<const unsigned char*>(data);
        for (size_t i = 0; i < bytes; ++i) h = (h ^ b[i]) * 0x100000001b3ull;
        const uint64_t n = bytes;  // the length too, so that arrays cannot trade bytes
        for (int i = 0; i < 8; ++i) h = (h ^ ((n >> (8 * i)) & 0xff)) * 0x100000001b3ull;
    };
    add(p.positions.data(), p.positions.size() * sizeof(glm::vec3));
    add(p.normals.data(), p.normals.size() * sizeof(glm::vec3));
    add(p.uv0.data(), p.uv0.size() * sizeof(glm::vec2));
    add(p.uv1.data(), p.uv1.size() * sizeof(glm::vec2));
    add(p.colors.data(), p.colors.size() * sizeof(glm::vec4));
    add(p.light.data(), p.light.size() * sizeof(glm::vec3));
    add(p.indices.data(), p.indices.size() * sizeof(uint32_t));
    add(&p.material, sizeof p.material);
    return h;
}

// The mesh of `input` (OBJ through load_obj, as the bundled meshes always were; PLY, OFF and glTF
// through load_mesh_file: the first primitive of the first mesh), split when it asks for it;
// false (and a message) when it cannot be read.
bool load_input(const bench::LodInput& input, Primitive& in) {
    if (input.file.extension() == ".obj") {
        Result<Mesh> mesh = load_obj(input.file);
        if (!mesh.ok()) {
            std::fprintf(stderr, "bench_lod_bench: %s\n", mesh.error().message.c_str());
            return false;
        }
        in = std::move(mesh->primitives[0]);
    } else {
        Result<Scene> scene = load_mesh_file(input.file);
        if (!scene.ok()) {
            std::fprintf(stderr, "bench_lod_bench: %s\n", scene.error().message.c_str());
            return false;
        }
        if (scene->meshes.empty() || scene->meshes[0].primitives.empty()) {
            std::fprintf(stderr, "bench_lod_bench: %s: no mesh\n", input.file.c_str());
            return false;
        }
        in = std::move(scene->meshes[0].primitives[0]);
    }
    if (input.splits > 0) {  // positions and indices only: the split makes no attributes
        Primitive base;
        base.positions = std::move(in.positions);
        base.indices = std::move(in.indices);
        in = test::subdivided_flat(std::move(base), input.splits);
    }
    return true;
}

// --hashes: the hash of every algorithm's output on every input, each target on its own and the
// three in one call (as hmdnode lod makes a chain), one line each; no timing, no measurement.
int print_hashes(const std::vector<bench::LodInput>& files,
                 const std::vector<std::string>& algorithms, std::span<const double> ratios) {
    for (const bench::LodInput& input : files) {
        Primitive in;
        if (!load_input(input, in)) return 1;
        std::vector<size_t> all;
        for (double ratio : ratios)
            all.push_back(
                std::max<size_t>(1, size_t(std::llround(ratio * double(in.triangle_count())))));
        for (const std::string& algo : algorithms) {
            if (algo.rfind("meshopt_", 0) == 0) continue;
            if (input.splits > 0 && algo != "qem" && algo != "curvature-qem") continue;
            auto print = [&](const std::string& what, std::span<const size_t> targets) {
                const Result<std::vector<SimplifiedLevel>> r = simplify(in, algo, targets);
                if (!r.ok()) {
                    std::printf("%s %s %s: %s\n", input.name.c_str(), algo.c_str(), what.c_str(),
                                r.error().message.c_str());
                    return;
                }
                for (size_t k = 0; k < r->size(); ++k)
                    std::printf("%s %s %s level %zu: %zu triangles, hash %016llx\n",
                                input.name.c_str(), algo.c_str(), what.c_str(), k,
                                (*r)[k].primitive.triangle_count(),
                                (unsigned long long)primitive_hash((*r)[k].primitive));
                std::fflush(stdout);
            };
            for (size_t k = 0; k < all.size(); ++k)
                print("target " + std::to_string(all[k]), std::span(&all[k], 1));
            print("chain", all);
        }
    }
    return 0;
}

// --profile: where the time goes, phase by phase, beside meshopt_simplify: qem on one thread
// (SimplifyOptions::profile; one SimplifyScratch for its calls), each target on its own, the
// median of `runs` runs of each phase; meshopt_simplify as a whole (meshoptimizer exposes no
// phases; 0.18 has no attribute-aware variant), median of `runs`; and the measurement of qem's
// level at hmdnode lod's defaults (prepare: level 0's BVH and samples; measure: the level), one
// thread. Times per collapse: qem's collapses for qem and the measurement, the faces removed / 2
// for meshopt_simplify (a collapse removes two faces of a closed mesh). Wall time: print-only, for
// a quiet machine.
int print_profile(const std::vector<bench::LodInput>& files, std::span<const double> ratios,
                  int runs) {
    using Field = double SimplifyProfile::*;
    const std::pair<const char*, Field> phases[] = {{"setup", &SimplifyProfile::setup_ms},
                                                    {"adjacency", &SimplifyProfile::adjacency_ms},
                                                    {"candidates", &SimplifyProfile::candidates_ms},
                                                    {"sort", &SimplifyProfile::sort_ms},
                                                    {"apply", &SimplifyProfile::apply_ms},
                                                    {"attributes", &SimplifyProfile::attributes_ms},
                                                    {"snapshots", &SimplifyProfile::snapshots_ms},
                                                    {"other", &SimplifyProfile::other_ms}};
    std::string out;
    appendf(out,
            "Profile (ns per collapse, medians of %d runs; qem on one thread, meshopt_simplify as "
            "a whole; measurement of qem's level at hmdnode lod's defaults, one thread):\n\n",
            runs);
    appendf(out, "| mesh | target | qem collapses |");
    for (const auto& ph : phases) appendf(out, " %s |", ph.first);
    appendf(out,
            " qem total | meshopt_simplify | qem / meshopt | measure: prepare | measure: level "
            "|\n|---|---|---|");
    for (size_t i = 0; i < std::size(phases) + 5; ++i) appendf(out, "---|");
    appendf(out, "\n");
    SimplifyScratch scratch;
    for (const bench::LodInput& input : files) {
        Primitive in;
        if (!load_input(input, in)) return 1;
        std::fprintf(stderr, "%s: %zu triangles\n", input.name.c_str(), in.triangle_count());
        for (double ratio : ratios) {
            const size_t target =
                std::max<size_t>(1, size_t(std::llround(ratio * double(in.triangle_count()))));
            const size_t targets[] = {target};
            SimplifyOptions o;
            o.threads = 1;
            o.scratch = &scratch;
            SimplifyProfile profile;
            o.profile = &profile;
            std::vector<std::vector<double>> t(std::size(phases) + 1);
            Primitive level;
            for (int r = 0; r < runs; ++r) {
                Result<std::vector<SimplifiedLevel>> res = simplify(in, "qem", targets, o);
                if (!res.ok()) {
                    std::fprintf(stderr, "bench_lod_bench: %s\n", res.error().message.c_str());
                    return 1;
                }
                level = std::move((*res)[0].primitive);
                for (size_t k = 0; k < std::size(phases); ++k)
                    t[k].push_back(profile.*phases[k].second);
                t.back().push_back(profile.total_ms);
            }
            const double collapses = double(std::max<size_t>(1, profile.collapses));
            std::vector<uint32_t> dst(in.indices.size());
            float result_error = 0.0f;
            std::vector<double> mo, prep, meas;
            size_t mo_faces = 0;
            for (int r = 0; r < runs; ++r)
                mo.push_back(time_ms(
                    [&] { mo_faces = run_meshopt_simplify(in, target, dst, result_error) / 3; }));
            for (int r = 0; r < runs; ++r) {
                std::optional<MeshDistanceReference> ref;
                prep.push_back(time_ms([&] { ref.emplace(view_of(in)); }));
                meas.push_back(time_ms([&] { (void)ref->measure(view_of(level)); }));
            }
            const double mo_collapses = std::max(1.0, double(in.triangle_count() - mo_faces) / 2.0);
            const double ns = 1e6;  // ms to ns
            appendf(out, "| %s | %.0f %% (%zu) | %zu |", input.name.c_str(), ratio * 100, target,
                    profile.collapses);
            for (size_t k = 0; k < std::size(phases); ++k)
                appendf(out, " %.1f |", median(t[k]) * ns / collapses);
            const double q = median(t.back()) * ns / collapses, m = median(mo) * ns / mo_collapses;
            appendf(out, " %.1f | %.1f | %.2f | %.1f | %.1f |\n", q, m, m > 0 ? q / m : 0.0,
                    median(prep) * ns / collapses, median(meas) * ns / collapses);
        }
    }
    std::fputs(out.c_str(), stdout);
    return 0;
}

// --once: one simplification of one input to one ratio, for an instruction count
// (valgrind --tool=callgrind --toggle-collect='run_once*'): the work of the call and nothing else
// sits inside run_once_qem() / run_once_meshopt(). qem runs on one thread with a SimplifyScratch
// that one call outside the count has already used (the bench's steady state, as its rows and
// --profile run); meshopt_simplify as run_meshopt_simplify() calls it. Prints the triangles, the
// collapses (qem's own count; meshopt: faces removed / 2, as --profile counts them) and the
// output's hash (primitive_hash(), as --hashes prints it; meshopt: of its index buffer).
}  // namespace

// note: outside the anonymous namespace, so that callgrind sees their names as run_once_...
[[gnu::noinline]] Result<std::vector<SimplifiedLevel>> run_once_qem(const Primitive& in,
                                                                    size_t target,
                                                                    const SimplifyOptions& o) {
    const size_t targets[] = {target};
    return simplify(in, "qem", targets, o);
}

[[gnu::noinline]] size_t run_once_meshopt(const Primitive& in, size_t target,
                                          std::vector<uint32_t>& dst) {
    float result_error = 0.0f;
    return run_meshopt_simplify(in, target, dst, result_error);
}

namespace {

int print_once(const std::vector<bench::LodInput>& files, const std::string& mesh,
               const std::string& algo, double ratio) {
    const auto input = std::find_if(files.begin(), files.end(),
                                    [&](const bench::LodInput& f) { return f.name == mesh; });
    if (input == files.end()) {
        std::string names;
        for (const bench::LodInput& f : files) names += (names.empty() ? "" : ", ") + f.name;
        std::fprintf(stderr, "bench_lod_bench: --mesh: no input named '%s' (%s)\n", mesh.c_str(),
                     names.c_str());
        return 2;
    }
    Primitive in;
    if (!load_input(*input, in)) return 1;
    const size_t faces = in.triangle_count();
    const size_t target = std::max<size_t>(1, size_t(std::llround(ratio * double(faces))));
    size_t triangles = 0;
    double collapses = 0.0;
    uint64_t hash = 0;
    if (algo == "qem") {
        SimplifyScratch scratch;
        SimplifyStats stats;
        SimplifyOptions o;
        o.threads = 1;
        o.scratch = &scratch;
        o.stats = &stats;
        const size_t targets[] = {target};
        (void)simplify(in, "qem", targets, o);  // note: outside the count, warms the scratch
        Result<std::vector<SimplifiedLevel>> r = run_once_qem(in, target, o);
        if (!r.ok()) {
            std::fprintf(stderr, "bench_lod_bench: %s\n", r.error().message.c_str());
            return 1;
        }
        triangles = (*r)[0].primitive.triangle_count();
        collapses = double(stats.collapses);
        hash = primitive_hash((*r)[0].primitive);
    } else {
        std::vector<uint32_t> dst(in.indices.size());
        dst.resize(run_once_meshopt(in, target, dst));
        triangles = dst.size() / 3;
        collapses = double(faces - triangles) / 2.0;
        Primitive out;
        out.indices = std::move(dst);
        hash = primitive_hash(out);
    }
    std::printf("%s %s %g %%: %zu -> %zu triangles (target %zu), %.1f collapses, hash %016llx\n",
                input->name.c_str(), algo.c_str(), ratio * 100, faces, triangles, target, collapses,
                (unsigned long long)hash);
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
    const bool write_docs = bench::wants_docs(argc, argv);
    std::string only_arg;
    fs::path mesh_dir = fs::path(HMDNODE_SOURCE_DIR) / "data" / "meshes";
    std::vector<fs::path> mesh_files;  // mesh paths given as arguments: instead of the bundled set
    std::string prefix = "lod_bench";
    std::vector<std::string> only;
    bool hashes = false;
    std::string once_algo, once_mesh = "bunny";  // --once ALGO RATIO [--mesh NAME]
    double once_ratio = 0.0;
    int profile_runs = 0, runs_arg = 0;  // --profile and its --runs
    // note: the quality figures keep the dense measurement they were always made with (300 000
    // samples per direction on every hardware thread), not hmdnode lod's one-per-triangle default.
    MeshDistanceOptions distance;
    distance.samples = 300'000;
    distance.threads = 0;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--out" && i + 1 < argc) {
            prefix = argv[++i];
        } else if (a == "--only" && i + 1 < argc) {
            only_arg = argv[++i];
            std::stringstream ss(only_arg);
            for (std::string n; std::getline(ss, n, ',');) only.push_back(n);
        } else if (a == "--samples" && i + 1 < argc) {
            distance.samples = size_t(std::stoull(argv[++i]));
        } else if (a == "--write-docs") {
            continue;
        } else if (a == "--hashes") {
            hashes = true;
        } else if (a == "--profile") {
            profile_runs = 5;
        } else if (a == "--once") {
            if (i + 2 >= argc) {
                std::fprintf(stderr, "bench_lod_bench: --once: needs ALGO RATIO\n");
                return 2;
            }
            once_algo = argv[++i];
            if (once_algo == "meshopt_simplify") once_algo = "meshopt";
            if (once_algo != "qem" && once_algo != "meshopt") {
                std::fprintf(stderr, "bench_lod_bench: --once: unknown ALGO '%s' (qem, meshopt)\n",
                             once_algo.c_str());
                return 2;
            }
            char* end = nullptr;
            once_ratio = std::strtod(argv[++i], &end);
            if (end == argv[i] || *end != '\0' || !(once_ratio > 0.0 && once_ratio <= 1.0)) {
                std::fprintf(stderr, "bench_lod_bench: --once: RATIO '%s' is not in (0, 1]\n",
                             argv[i]);
                return 2;
            }
        } else if (a == "--mesh") {
            if (i + 1 >= argc) {
                std::fprintf(stderr, "bench_lod_bench: --mesh: needs NAME\n");
                return 2;
            }
            once_mesh = argv[++i];
        } else if (a == "--runs" && i + 1 < argc) {
            runs_arg = std::max(1, std::atoi(argv[++i]));
        } else if (a == "--help" || a == "-h") {
            std::printf(
                "usage: %s [MESH_DIR | MESH_FILE...] [--out PREFIX] [--only a,b] [--samples N] "
                "[--write-docs] [--hashes] [--profile [--runs N]] [--once ALGO RATIO [--mesh "
                "NAME]]\n",
                argv[0]);
            return 0;
        } else if (fs::is_directory(a)) {
            mesh_dir = a;
        } else {
            mesh_files.push_back(a);
        }
    }
    // (name, file, flat splits): the bundled meshes and bunny-split, or the files given.
    const std::vector<bench::LodInput> files = bench::lod_inputs(mesh_dir, mesh_files);
    const double ratios[] = {0.5, 0.1, 0.01};

    std::vector<std::string> algorithms;
    for (const AlgorithmInfo& a : simplification_algorithms())
        if (only.empty() || std::count(only.begin(), only.end(), a.name))
            algorithms.push_back(a.name);
    for (const char* m : {"meshopt_simplify", "meshopt_simplifySloppy"})
        if (only.empty() || std::count(only.begin(), only.end(), m)) algorithms.push_back(m);
    if (!once_algo.empty()) return print_once(files, once_mesh, once_algo, once_ratio);
    if (hashes) return print_hashes(files, algorithms, ratios);
    if (profile_runs > 0)
        return print_profile(files, ratios, runs_arg > 0 ? runs_arg : profile_runs);

    std::vector<Row> rows;
    std::vector<std::string> meshes;
    auto find = [&](const std::string& mesh, const std::string& algo, double ratio) -> Row* {
        for (Row& r : rows)
            if (r.mesh == mesh && r.algorithm == algo && r.ratio == ratio && r.failure.empty())
                return &r;
        return nullptr;
    };
    // note: where meshopt_simplify stops above the target (it keeps the spot's UV seams), qem
    // again at the count it reached, so that the error ratios can also compare equal counts.
    struct EqualCount {
        std::string mesh;
        double ratio;
        size_t triangles;
        double mean_pct, hausdorff_pct;
    };
    std::vector<EqualCount> equal_counts;
    SimplifyScratch scratch;  // note: reused by every simplify() call, see the header
    SimplifyOptions defaults;
    defaults.scratch = &scratch;
    for (const bench::LodInput& input : files) {
        const std::string& name = input.name;
        Primitive in;
        if (!load_input(input, in)) return 1;
        meshes.push_back(name);
        const size_t count = in.triangle_count();
        std::fprintf(stderr, "%s: %zu triangles, %zu vertices\n", name.c_str(), count,
                     in.positions.size());
        for (const std::string& algo : algorithms) {
            // note: on the split mesh (four times the bunny's faces) only qem and meshoptimizer's
            // two unless named: the other algorithms take minutes there.
            if (input.splits > 0 && only.empty() && algo != "qem" && algo.rfind("meshopt_", 0) != 0)
                continue;
            for (double ratio : ratios) {
                Row row;
                row.mesh = name;
                row.algorithm = algo;
                row.ratio = ratio;
                row.input = count;
                row.target = std::max<size_t>(1, size_t(std::llround(ratio * double(count))));
                Primitive out;
                if (algo.rfind("meshopt_", 0) == 0) {
                    const bool sloppy = algo == "meshopt_simplifySloppy";
                    std::vector<uint32_t> dst(in.indices.size());
                    float result_error = 0.0f;
                    const size_t n = timed(
                        [&] {
                            return sloppy
                                       ? meshopt_simplifySloppy(
                                             dst.data(), in.indices.data(), in.indices.size(),
                                             &in.positions[0].x, in.positions.size(),
                                             sizeof(glm::vec3), row.target * 3, 1.0f, &result_error)
                                       : run_meshopt_simplify(in, row.target, dst, result_error);
                        },
                        row.ms, row.runs);
                    dst.resize(n);
                    out.positions = in.positions;
                    out.uv0 = in.uv0;  // meshoptimizer keeps the input's vertices
                    out.indices = std::move(dst);
                    row.reported_error = result_error;
                } else {
                    const size_t targets[] = {row.target};
                    Result<std::vector<SimplifiedLevel>> r = timed(
                        [&] { return simplify(in, algo, targets, defaults); }, row.ms, row.runs);
                    if (!r.ok()) {
                        row.failure = r.error().message;
                        rows.push_back(row);
                        std::fprintf(stderr, "  %s %.0f%%: %s\n", algo.c_str(), ratio * 100,
                                     row.failure.c_str());
                        continue;
                    }
                    out = std::move((*r)[0].primitive);
                    row.reported_error = (*r)[0].estimated_error;
                }
                row.triangles = out.triangle_count();
                if (row.triangles > 0) {
                    const MeshDistance d = measure_mesh_distance(in, out, distance);
                    row.mean_pct = d.mean_pct();
                    row.hausdorff_pct = d.hausdorff_pct();
                    row.uv_drift_pct = uv_drift_pct(in, out);
                } else {
                    row.failure = "no triangles";
                }
                std::fprintf(stderr, "  %-24s %4.0f%%: %7zu tris %9.1f ms mean %.4f%% haus %.4f%%",
                             algo.c_str(), ratio * 100, row.triangles, row.ms, row.mean_pct,
                             row.hausdorff_pct);
                if (row.uv_drift_pct >= 0.0) {
                    std::fprintf(stderr, " uv drift %.4f%%", row.uv_drift_pct);
                }
                std::fprintf(stderr, "\n");
                rows.push_back(row);
            }
        }
        for (double ratio : ratios) {
            Row* q = find(name, "qem", ratio);
            const Row* o = find(name, "meshopt_simplify", ratio);
            if (!q || !o) continue;
            // The paired time ratio: up to 31 pairs, about 1.5 s per mesh and target.
            const size_t qem_targets[] = {q->target};
            std::vector<uint32_t> dst(in.indices.size());
            float result_error = 0.0f;
            const int pairs = std::clamp(int(1500.0 / std::max(1e-3, q->ms + o->ms)), 7, 31);
            auto meshopt = [&] { (void)run_meshopt_simplify(in, o->target, dst, result_error); };
            SimplifyOptions two_threads = defaults;
            two_threads.threads = 2;
            const Paired helper = paired_time_ratios(
                [&] { (void)simplify(in, "qem", qem_targets, two_threads); }, meshopt, pairs);
            SimplifyOptions one_thread = defaults;
            one_thread.threads = 1;
            const Paired single = paired_time_ratios(
                [&] { (void)simplify(in, "qem", qem_targets, one_thread); }, meshopt, pairs);
            q->pairs = helper.pairs, q->pair_ratio_p25 = helper.p25;
            q->pair_ratio_median = helper.median, q->pair_ratio_p75 = helper.p75;
            q->cpu_over_wall = helper.a_cpu_over_wall;
            q->pairs_1t = single.pairs, q->pair_1t_p25 = single.p25;
            q->pair_1t_median = single.median, q->pair_1t_p75 = single.p75;
            if (o->triangles <= o->target) continue;
            const size_t targets[] = {o->triangles};
            const Result<std::vector<SimplifiedLevel>> r = simplify(in, "qem", targets, defaults);
            if (!r.ok()) continue;
            const MeshDistance d = measure_mesh_distance(in, (*r)[0].primitive, distance);
            equal_counts.push_back(
                {name, ratio, (*r)[0].primitive.triangle_count(), d.mean_pct(), d.hausdorff_pct()});
        }
    }

    // Markdown tables: printed, and with --write-docs also written to docs/results/ (their
    // headers name the command and the machine).
    const std::string command = "build/release/bench/bench_lod_bench" +
                                (only.empty() ? "" : " --only " + only_arg) + " --write-docs";
    const std::string settings =
        "one run; times are medians, see above; errors against the original";
    std::string out;
    appendf(out, "Measured by `%s` (%s):\n\n", command.c_str(), settings.c_str());
    const size_t table_start = out.size();
    appendf(
        out,
        "| mesh | algorithm | target | triangles | time ms | mean %% diag | Hausdorff %% diag |\n");
    appendf(out, "|---|---|---|---|---|---|---|\n");
    for (const Row& r : rows) {
        if (!r.failure.empty()) {
            appendf(out, "| %s | %s | %.0f %% | - | - | failed: %s | |\n", r.mesh.c_str(),
                    r.algorithm.c_str(), r.ratio * 100, r.failure.c_str());
            continue;
        }
        appendf(out, "| %s | %s | %.0f %% (%zu) | %zu | %s | %s | %s |\n", r.mesh.c_str(),
                r.algorithm.c_str(), r.ratio * 100, r.target, r.triangles,
                fixed(r.ms, r.ms < 10 ? 2 : 1).c_str(), fixed(r.mean_pct, 4).c_str(),
                fixed(r.hausdorff_pct, 3).c_str());
    }

    // Target line: qem against meshopt_simplify.
    const size_t target_start = out.size() + 1;  // after the blank line
    appendf(out,
            "\nTarget: qem no slower than meshopt_simplify, mean <= 0.7x, Hausdorff <= 1.0x\n");
    appendf(out,
            "(time: the table's medians; paired: median and quartiles of the ratios of "
            "interleaved runs, the figure to compare with the target, on one thread and with "
            "simplify()'s helper thread (threads = 2); CPU/wall: the process's CPU time over wall "
            "time during the helper-thread runs, 2.0 = both cores busy throughout; meshopt "
            "runs on one thread)\n\n");
    appendf(out,
            "| mesh | ratio | time qem/meshopt | paired, one thread (p25-p75) | paired, helper "
            "(p25-p75) | CPU/wall | mean qem/meshopt | Hausdorff qem/meshopt |\n");
    appendf(out, "|---|---|---|---|---|---|---|---|\n");
    for (const std::string& m : meshes)
        for (double ratio : ratios) {
            const Row* q = find(m, "qem", ratio);
            const Row* o = find(m, "meshopt_simplify", ratio);
            if (!q || !o) continue;
            appendf(out,
                    "| %s | %.0f %% | %.2f | %.2f (%.2f-%.2f) | %.2f (%.2f-%.2f) | %.2f | %.2f | "
                    "%.2f |\n",
                    m.c_str(), ratio * 100, o->ms > 0 ? q->ms / o->ms : 0.0, q->pair_1t_median,
                    q->pair_1t_p25, q->pair_1t_p75, q->pair_ratio_median, q->pair_ratio_p25,
                    q->pair_ratio_p75, q->cpu_over_wall,
                    o->mean_pct > 0 ? q->mean_pct / o->mean_pct : 0.0,
                    o->hausdorff_pct > 0 ? q->hausdorff_pct / o->hausdorff_pct : 0.0);
            for (const EqualCount& e : equal_counts) {
                if (e.mesh != m || e.ratio != ratio) continue;
                appendf(out,
                        "| %s | %.0f %%, qem at meshopt's %zu faces | - | - | - | - | %.2f | "
                        "%.2f |\n",
                        m.c_str(), ratio * 100, o->triangles,
                        o->mean_pct > 0 ? e.mean_pct / o->mean_pct : 0.0,
                        o->hausdorff_pct > 0 ? e.hausdorff_pct / o->hausdorff_pct : 0.0);
            }
        }

    std::fputs(out.c_str(), stdout);
    nlohmann::json j = nlohmann::json::array();
    for (const Row& r : rows)
        j.push_back({{"mesh", r.mesh},
                     {"algorithm", r.algorithm},
                     {"ratio", r.ratio},
                     {"input_triangles", r.input},
                     {"target", r.target},
                     {"triangles", r.triangles},
                     {"time_ms", r.ms},
                     {"runs", r.runs},
                     {"mean_pct_diag", r.mean_pct},
                     {"hausdorff_pct_diag", r.hausdorff_pct},
                     {"reported_error", r.reported_error},
                     {"uv_drift_pct_range", r.uv_drift_pct},
                     {"failure", r.failure}});
    for (size_t i = 0; i < rows.size(); ++i) {
        if (rows[i].pairs == 0) continue;
        j[i]["paired_time_ratio"] = {{"pairs", rows[i].pairs},
                                     {"p25", rows[i].pair_ratio_p25},
                                     {"median", rows[i].pair_ratio_median},
                                     {"p75", rows[i].pair_ratio_p75},
                                     {"cpu_over_wall", rows[i].cpu_over_wall}};
        j[i]["paired_time_ratio_one_thread"] = {{"pairs", rows[i].pairs_1t},
                                                {"p25", rows[i].pair_1t_p25},
                                                {"median", rows[i].pair_1t_median},
                                                {"p75", rows[i].pair_1t_p75}};
    }
    std::fflush(stdout);  // the tables first, then what was written, in that order on a terminal
    const std::filesystem::path dir = std::filesystem::path(prefix).parent_path();
    std::error_code ec;
    if (!dir.empty()) std::filesystem::create_directories(dir, ec);
    for (const auto& [path, text] :
         {std::pair{prefix + ".json", j.dump(2) + "\n"},
          std::pair{prefix + ".svg", svg_plot(rows, meshes, algorithms)}}) {
        const Status written = write_file_atomically(path, text);
        if (!written.ok()) {
            std::fprintf(stderr, "bench_lod_bench: %s\n", written.error().message.c_str());
            return 1;
        }
    }
    std::fprintf(stderr, "wrote %s.json and %s.svg\n", prefix.c_str(), prefix.c_str());
    if (write_docs) {
        if (!bench::write_result(
                "lod-bench", "LOD generation: every simplifier against meshoptimizer", command,
                "Settings: wall time, median of 5 runs when a run takes under 0.2 s, of 3 under "
                "2 s, else one run; simplify() on one thread, one SimplifyScratch for all its "
                "calls; errors against the original, " +
                    std::to_string(distance.samples) + " samples per direction.\n\n" +
                    out.substr(table_start, target_start - 1 - table_start)) ||
            !bench::write_result("lod-bench-target",
                                 "LOD generation target: qem against meshopt_simplify", command,
                                 out.substr(target_start)))
            return 1;
        if (const Status s =
                write_file_atomically(HMDNODE_SOURCE_DIR "/docs/lod-generation-bench.svg",
                                      svg_plot(rows, meshes, algorithms));
            !s.ok()) {
            std::fprintf(stderr, "bench_lod_bench: %s\n", s.error().message.c_str());
            return 1;
        }
        std::fprintf(stderr, "wrote docs/lod-generation-bench.svg\n");
    }
    return 0;
}
