// LOD chain generation for a scene: the discrete-LOD scheme of Clark ("Hierarchical geometric
// models for visible surface algorithms", CACM 1976) with levels made by simplify() and each level
// annotated with its measured error, the symmetric Hausdorff distance to level 0 (Metro method,
// mesh_distance.cpp), as the error-driven selection of Luebke et al. ("Level of Detail for 3D
// Graphics", Morgan Kaufmann 2003, ch. 4) needs; stored as MSFT_lod.
//
// Target by error (--error): a halving ladder of triangle counts (one simplify() pass for an
// edge-collapse algorithm) brackets the count where the measured error crosses the bound, then
// bisection on the count (at most 10 steps, to 2 % of the count) finds the coarsest level found
// under it. The error is not monotonic in the count, so this is the coarsest level *found*, not a
// proven optimum. The search measures with search_samples; the level found is measured again with
// the full sample count (the figure reported) and, while that is above the bound, replaced by one
// with 2 %, 4 %, 8 %, ... more triangles, so the level written holds the bound as reported.
//
// Material boundaries: a mesh's primitives (one material each) are simplified one by one, and
// the positions two of them share are locked (SimplifyOptions::locked_positions): both sides keep
// the same boundary vertices, so no crack opens between materials at any level, at the price of
// a boundary kept at full resolution.
//
// Cost: per mesh, the simplify() calls (one per primitive, or one per primitive and bisection
// step for --error) plus one distance measurement per level, O(S log T) with S samples.
// Memory: the scene copy (the input is replaced only on success) plus the levels.
#include "hmdnode/lod/lod_chain.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <optional>
#include <set>

#include "hmdnode/core/str_cat.hpp"
#include "hmdnode/lod/progressive_mesh.hpp"
#include "position_set.hpp"
#include "thread_cpu.hpp"

namespace hmdnode {
namespace {

using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point t0) {
    return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

using lod_detail::thread_cpu_ms;

// All primitives of a mesh as one triangle soup, for the distance measurement.
struct Soup {
    std::vector<glm::vec3> positions;
    std::vector<uint32_t> indices;
    TriangleMeshView view() const { return {positions, indices}; }
};

Soup soup_of(const std::vector<Primitive>& primitives) {
    Soup s;
    for (const Primitive& p : primitives) {
        const uint32_t base = uint32_t(s.positions.size());
        s.positions.insert(s.positions.end(), p.positions.begin(), p.positions.end());
        for (uint32_t i : p.indices) s.indices.push_back(base + i);
    }
    return s;
}

struct BuiltLevel {
    std::vector<Primitive> primitives;
    size_t target = 0;
    double estimated_error = -1.0;
    double simplify_ms = 0.0;
};

// Simplifies every primitive of `mesh` to its share of each mesh-wide target (strictly
// decreasing, each below the mesh's count): a primitive's share is proportional to its count,
// at least 1; a primitive whose share is not below its own count (or its previous level's) is
// carried over unchanged. A primitive an algorithm left without a triangle keeps its previous
// level (the original for the first), with a note naming mesh and primitive: an object never
// vanishes from a level. `logs`, when given, receives per primitive the progressive mesh of the
// run that made its levels (build_progressive_mesh, the same run as simplify()'s), or nothing for a
// primitive carried over.
using PrimitiveLogs = std::vector<std::optional<ProgressiveMesh>>;
Result<std::vector<BuiltLevel>> build_levels(const Mesh& mesh, size_t mesh_index,
                                             const std::vector<size_t>& targets,
                                             const LodChainOptions& options,
                                             const std::function<void(double)>& progress,
                                             std::vector<std::string>& notes,
                                             PrimitiveLogs* logs = nullptr) {
    const size_t total = mesh.triangle_count();
    std::vector<BuiltLevel> levels(targets.size());
    for (size_t k = 0; k < targets.size(); ++k) {
        levels[k].target = targets[k];
        levels[k].primitives.resize(mesh.primitives.size());
    }
    if (logs) logs->assign(mesh.primitives.size(), std::nullopt);
    size_t done = 0;
    SimplifyOptions base = options.simplify;
    const std::vector<glm::vec3> boundary = material_boundary_positions(mesh);
    base.locked_positions.insert(base.locked_positions.end(), boundary.begin(), boundary.end());
    for (size_t p = 0; p < mesh.primitives.size(); ++p) {
        const Primitive& prim = mesh.primitives[p];
        const size_t count = prim.triangle_count();
        std::vector<int> which;  // index into list, -1: the original
        const std::vector<size_t> list = primitive_targets(mesh, p, targets, &which);
        std::vector<SimplifiedLevel> made;
        double elapsed = 0.0;
        if (!list.empty()) {
            SimplifyOptions so = base;
            so.progress = [&](double f) {
                if (progress) progress((double(done) + f * double(count)) / double(total));
            };
            const Clock::time_point t0 = Clock::now();
            Result<std::vector<SimplifiedLevel>> r = make_error("");
            if (logs) {
                Result<ProgressiveMeshBuild> b = build_progressive_mesh(
                    prim, options.algorithm, std::span<const size_t>(list), so);
                if (b.ok()) {
                    (*logs)[p] = std::move(b->mesh);
                    r = std::move(b->levels);
                } else {
                    r = b.error();
                }
            } else {
                r = simplify(prim, options.algorithm, std::span<const size_t>(list), so);
            }
            elapsed = ms_since(t0);
            if (!r.ok())
                return make_error(cat("mesh ", mesh_index, " \"", mesh.name, "\" primitive ", p,
                                      ": ", r.error().message));
            made = std::move(r).value();
            if (made.size() != list.size())
                return make_error(cat("mesh ", mesh_index, " \"", mesh.name, "\" primitive ", p,
                                      ": ", options.algorithm, " returned ", made.size(),
                                      " levels for ", list.size(), " targets"));
        }
        for (size_t k = 0; k < targets.size(); ++k) {
            BuiltLevel& lvl = levels[k];
            lvl.simplify_ms += elapsed;
            if (which[k] < 0) {
                lvl.primitives[p] = prim;
                continue;
            }
            const SimplifiedLevel& s = made[size_t(which[k])];
            if (s.primitive.triangle_count() == 0) {
                lvl.primitives[p] = k > 0 ? levels[k - 1].primitives[p] : prim;
                std::string note =
                    cat("mesh ", mesh_index, " \"", mesh.name, "\" primitive ", p, ": ",
                        options.algorithm, " left no triangle for the level of ", targets[k],
                        " triangles; the ", k > 0 ? "previous level" : "original", " kept");
                // note: the --error search builds the same level more than once.
                if (std::find(notes.begin(), notes.end(), note) == notes.end())
                    notes.push_back(std::move(note));
                continue;
            }
            lvl.primitives[p] = s.primitive;
            lvl.primitives[p].material = prim.material;
            if (s.estimated_error >= 0.0)
                lvl.estimated_error = std::max(lvl.estimated_error, s.estimated_error);
        }
        done += count;
        if (progress) progress(double(done) / double(total));
    }
    return levels;
}

// Mesh-wide triangle targets for a mesh of `count` triangles (not for max_error).
Result<std::vector<size_t>> count_targets(const LodTargets& t, size_t count, const Mesh& mesh,
                                          size_t max_levels, std::vector<std::string>& notes) {
    std::vector<size_t> out;
    for (double r : t.ratios) out.push_back(std::max<size_t>(1, size_t(std::llround(r * count))));
    for (size_t n : t.triangles) {
        if (n >= count) {
            notes.push_back(cat("mesh \"", mesh.name, "\": target ", n,
                                " triangles is not below its ", count, "; skipped"));
            continue;
        }
        out.push_back(n);
    }
    if (t.step > 0) {
        size_t floor = 1;
        if (!out.empty()) floor = *std::min_element(out.begin(), out.end());
        const size_t levels = count > floor ? (count - floor) / t.step : 0;
        if (levels > max_levels)
            return make_error(cat("--step ", t.step, " gives ", levels, " levels for mesh \"",
                                  mesh.name, "\" (", count, " triangles); at most ", max_levels));
        for (size_t k = 1; k <= levels; ++k) out.push_back(count - k * t.step);
    }
    std::sort(out.begin(), out.end(), std::greater<>());
    out.erase(std::unique(out.begin(), out.end()), out.end());
    out.erase(
        std::remove_if(out.begin(), out.end(), [&](size_t n) { return n >= count || n == 0; }),
        out.end());
    if (out.size() > max_levels)
        return make_error(
            cat(out.size(), " levels for mesh \"", mesh.name, "\"; at most ", max_levels));
    return out;
}

struct MeasuredLevel {
    BuiltLevel built;
    MeshDistance distance;
    double measure_ms = 0.0;
    double measure_cpu_ms = 0.0;
};

// Level 0 prepared for the measurement once per mesh (its BVH and samples); the preparation's
// time is charged to the first level measured with it.
struct Reference {
    mutable double unpaid_ms = 0.0;  // note: declared first, timed() sets them while ref is made
    mutable double unpaid_cpu_ms = 0.0;
    MeshDistanceReference ref;
    Reference(const Soup& base, const MeshDistanceOptions& o) : ref(timed(base, o)) {}

  private:
    MeshDistanceReference timed(const Soup& base, const MeshDistanceOptions& o) {
        const Clock::time_point t0 = Clock::now();
        const double c0 = thread_cpu_ms();
        MeshDistanceReference r(base.view(), o);
        unpaid_ms = ms_since(t0);
        unpaid_cpu_ms = thread_cpu_ms() - c0;
        return r;
    }
};

MeasuredLevel measure(BuiltLevel built, const Reference& base) {
    const Clock::time_point t0 = Clock::now();
    const double c0 = thread_cpu_ms();
    const Soup s = soup_of(built.primitives);
    const double copy_cpu_ms = thread_cpu_ms() - c0;
    MeasuredLevel m{std::move(built), base.ref.measure(s.view()), 0.0, 0.0};
    m.measure_ms = ms_since(t0) + base.unpaid_ms;
    // note: the measurement's CPU time on every thread it used, not only this one's.
    m.measure_cpu_ms = copy_cpu_ms + m.distance.cpu_ms + base.unpaid_cpu_ms;
    base.unpaid_ms = base.unpaid_cpu_ms = 0.0;
    return m;
}

// The error bound of --error, in metres or in % of the diagonal, compared in the unit it was given
// in (the figure the report prints).
struct ErrorBound {
    double value = 0.0;
    bool pct = false;
    bool holds(const MeshDistance& d) const {
        return (pct ? d.hausdorff_pct() : d.hausdorff) <= value;
    }
    std::string text() const { return pct ? cat(value, " %") : cat(value, " m"); }
};

// The coarsest level whose Hausdorff error is at most `bound`, or nothing. `logs`, when given,
// receives the progressive meshes of the run that made that level, based at it.
Result<std::vector<MeasuredLevel>> search_error(const Mesh& mesh, size_t mesh_index,
                                                const Soup& base, const ErrorBound& bound,
                                                const LodChainOptions& options,
                                                std::vector<std::string>& notes,
                                                const std::function<void(double)>& progress,
                                                PrimitiveLogs* logs) {
    const size_t count = mesh.triangle_count();
    MeshDistanceOptions quick = options.distance;
    quick.samples =
        std::min(options.search_samples, options.distance.samples ? options.distance.samples
                                                                  : std::max<size_t>(count, 4096));
    const Reference quick_ref(base, quick);
    std::optional<Reference> full_ref;  // made when the search has found a level
    std::vector<size_t> ladder;
    for (size_t t = count / 2; t >= 1 && ladder.size() < 24; t /= 2) ladder.push_back(t);
    if (ladder.empty()) {
        notes.push_back(cat("mesh \"", mesh.name, "\": too small to simplify"));
        return std::vector<MeasuredLevel>{};
    }
    auto report = [&](double f) {
        if (progress) progress(f);
    };
    PrimitiveLogs run_logs, pass_logs;  // the last run's, the one that made `pass`
    PrimitiveLogs* run_log = logs ? &run_logs : nullptr;
    Result<std::vector<BuiltLevel>> built = build_levels(
        mesh, mesh_index, ladder, options, [&](double f) { report(0.3 * f); }, notes, run_log);
    if (!built.ok()) return built.error();
    // Bracket: pass = finest failing's finer neighbour.
    std::optional<MeasuredLevel> pass;
    size_t fail_count = 0;
    for (size_t k = 0; k < ladder.size(); ++k) {
        MeasuredLevel m = measure(std::move((*built)[k]), quick_ref);
        report(0.3 + 0.2 * double(k + 1) / double(ladder.size()));
        if (bound.holds(m.distance)) {
            pass = std::move(m);
        } else {
            fail_count = ladder[k];
            break;
        }
    }
    if (logs && pass) pass_logs = std::move(run_logs);
    size_t pass_count = pass ? pass->built.target : count;
    for (int it = 0; it < 10 && fail_count > 0 && pass_count > fail_count + 1; ++it) {
        if (double(pass_count - fail_count) <= 0.02 * double(pass_count)) break;
        const size_t mid = size_t(std::llround(std::sqrt(double(pass_count) * double(fail_count))));
        if (mid <= fail_count || mid >= pass_count) break;
        Result<std::vector<BuiltLevel>> one =
            build_levels(mesh, mesh_index, {mid}, options, nullptr, notes, run_log);
        if (!one.ok()) return one.error();
        MeasuredLevel m = measure(std::move((*one)[0]), quick_ref);
        if (bound.holds(m.distance)) {
            pass = std::move(m);
            pass_count = mid;
            if (logs) pass_logs = std::move(run_logs);
        } else {
            fail_count = mid;
        }
        report(0.5 + 0.05 * double(it + 1));
    }
    if (!pass) {
        notes.push_back(cat("mesh \"", mesh.name, "\": no level below ", count,
                            " triangles has a Hausdorff error <= ", bound.text(),
                            "; no level added"));
        return std::vector<MeasuredLevel>{};
    }
    // The final figure with the full sample count. The search measured with fewer samples, which
    // can miss the farthest point: a level that passed there may not pass here. Step back to more
    // triangles (2 % more, then twice the step each time) until the reported figure holds the
    // bound.
    full_ref.emplace(base, options.distance);
    MeasuredLevel final_level = measure(std::move(pass->built), *full_ref);
    for (int back = 0; !bound.holds(final_level.distance); ++back) {
        const size_t was = pass_count;
        const double step = std::ceil(double(was) * 0.02 * std::ldexp(1.0, back));
        pass_count = was + std::max<size_t>(1, size_t(step));
        if (pass_count >= count) {
            notes.push_back(cat("mesh \"", mesh.name, "\": no level below ", count,
                                " triangles has a Hausdorff error <= ", bound.text(),
                                " measured with ", options.distance.samples,
                                " samples; no level added"));
            return std::vector<MeasuredLevel>{};
        }
        notes.push_back(
            cat("mesh \"", mesh.name, "\": the level for ", was, " triangles measures ",
                bound.pct ? final_level.distance.hausdorff_pct() : final_level.distance.hausdorff,
                bound.pct ? " %" : " m", " with ", options.distance.samples, " samples, above ",
                bound.text(), "; trying ", pass_count));
        Result<std::vector<BuiltLevel>> one =
            build_levels(mesh, mesh_index, {pass_count}, options, nullptr, notes, run_log);
        if (!one.ok()) return one.error();
        final_level = measure(std::move((*one)[0]), *full_ref);
        if (logs) pass_logs = std::move(run_logs);
    }
    if (logs) {
        // A level from the ladder was recorded past it, down to the ladder's last count.
        // A primitive the level leaves as it is has none.
        for (size_t p = 0; p < pass_logs.size(); ++p) {
            if (!pass_logs[p]) continue;
            if (primitive_targets(mesh, p, {final_level.built.target}).empty())
                pass_logs[p].reset();
            else
                pass_logs[p] = rebase_progressive_mesh(
                    *pass_logs[p], final_level.built.primitives[p].triangle_count());
        }
        *logs = std::move(pass_logs);
    }
    std::vector<MeasuredLevel> out;
    out.push_back(std::move(final_level));
    report(1.0);
    return out;
}

}  // namespace

std::string check_lod_targets(const LodTargets& t) {
    const int kinds = int(!t.ratios.empty()) + int(!t.triangles.empty()) +
                      int(t.max_error_m >= 0.0) + int(t.max_error_pct >= 0.0);
    if (kinds > 1) return "give only one of ratios, triangle counts or a maximum error";
    if (kinds == 0 && t.step == 0)
        return "no targets: give ratios, triangle counts, an error or a step";
    if (t.step > 0 && (t.max_error_m >= 0.0 || t.max_error_pct >= 0.0))
        return "--step does not combine with --error";
    for (size_t i = 0; i < t.ratios.size(); ++i) {
        if (!(t.ratios[i] > 0.0 && t.ratios[i] < 1.0))
            return cat("ratio ", t.ratios[i], " is not in (0, 1)");
        if (i > 0 && !(t.ratios[i] < t.ratios[i - 1])) return "ratios must be strictly decreasing";
    }
    for (size_t i = 0; i < t.triangles.size(); ++i) {
        if (t.triangles[i] == 0) return "a triangle count of 0";
        if (i > 0 && !(t.triangles[i] < t.triangles[i - 1]))
            return "triangle counts must be strictly decreasing";
    }
    if (t.max_error_m == 0.0 || t.max_error_pct == 0.0) return "the maximum error must be > 0";
    if (!std::isfinite(t.max_error_m) || !std::isfinite(t.max_error_pct))
        return "the maximum error must be finite";
    return {};
}

// Each primitive's share of the mesh-wide targets (lod_chain.hpp).
std::vector<size_t> primitive_targets(const Mesh& mesh, size_t primitive,
                                      const std::vector<size_t>& targets, std::vector<int>* which) {
    const size_t total = mesh.triangle_count();
    const size_t count = mesh.primitives.at(primitive).triangle_count();
    std::vector<size_t> list;
    if (which) which->assign(targets.size(), -1);
    for (size_t k = 0; k < targets.size(); ++k) {
        const double share = double(targets[k]) * double(count) / double(total);
        const size_t want = std::max<size_t>(1, size_t(std::llround(share)));
        if (want < count && (list.empty() || want < list.back())) list.push_back(want);
        if (which) (*which)[k] = list.empty() ? -1 : int(list.size() - 1);
    }
    return list;
}

// The positions (bit for bit, +0 == -0) that more than one primitive of `mesh` uses: its
// material boundaries. Locking them keeps the boundary closed, since both sides then keep the same
// boundary vertices (primitives are simplified one by one).
std::vector<glm::vec3> material_boundary_positions(const Mesh& mesh) {
    if (mesh.primitives.size() < 2) return {};
    using lod_detail::PositionSet;
    std::vector<std::pair<PositionSet::Key, uint32_t>> keys;  // position, primitive
    for (uint32_t p = 0; p < uint32_t(mesh.primitives.size()); ++p) {
        for (const glm::vec3& v : mesh.primitives[p].positions) {
            keys.emplace_back(PositionSet::key(v), p);
        }
    }
    std::sort(keys.begin(), keys.end());
    std::vector<glm::vec3> out;
    for (size_t i = 0; i < keys.size();) {
        size_t j = i + 1;
        bool shared = false;
        for (; j < keys.size() && keys[j].first == keys[i].first; ++j) {
            shared |= keys[j].second != keys[i].second;
        }
        if (shared) {
            glm::vec3 v;
            std::memcpy(&v.x, keys[i].first.data(), sizeof(float) * 3);
            out.push_back(v);
        }
        i = j;
    }
    return out;
}

namespace {

// Per source mesh: the new level meshes and their errors.
struct Chain {
    std::vector<int> level_meshes;
    std::vector<double> errors;  // level 1.. Hausdorff, mesh space
    double diameter = 0.0;
};

// The nodes that get a chain, their meshes, and the old alternates with the meshes of their levels.
struct ChainPlan {
    std::vector<int> chain_nodes;
    std::vector<int> meshes;  // distinct meshes of chain nodes, in order of first use
    std::vector<char> remove;
    std::set<int> old_level_meshes;
};

Status check_lod_options(const LodChainOptions& options) {
    const AlgorithmInfo* algo = find_simplification_algorithm(options.algorithm);
    if (!algo) {
        std::string names;
        for (const AlgorithmInfo& a : simplification_algorithms())
            names += (names.empty() ? "" : ", ") + a.name;
        return make_error(
            cat("unknown algorithm \"", options.algorithm, "\" (known: ", names, ")"));
    }
    if (std::string e = check_lod_targets(options.targets); !e.empty()) return make_error(e);
    if (options.targets.step > 0 && !algo->edge_collapse)
        return make_error(
            cat("--step needs an edge-collapse algorithm; \"", algo->name, "\" is not one"));
    if (options.progressive && !algo->edge_collapse)
        return make_error(cat("progressive meshes need an edge-collapse algorithm; \"", algo->name,
                              "\" is not one"));
    return {};
}

// Clears the chain nodes' old alternates (lod_ids, screen_coverage) in `out`.
ChainPlan plan_chains(Scene& out) {
    ChainPlan plan;
    std::set<int> alternates;
    for (const Node& n : out.nodes)
        for (int id : n.lod_ids) alternates.insert(id);
    for (size_t i = 0; i < out.nodes.size(); ++i) {
        const Node& n = out.nodes[i];
        if (n.mesh < 0 || size_t(n.mesh) >= out.meshes.size() || alternates.count(int(i))) continue;
        plan.chain_nodes.push_back(int(i));
        if (std::find(plan.meshes.begin(), plan.meshes.end(), n.mesh) == plan.meshes.end())
            plan.meshes.push_back(n.mesh);
    }

    // Old alternates go unless something else holds them (a parent, the roots, a light).
    std::vector<char>& remove = plan.remove;
    remove.assign(out.nodes.size(), 0);
    for (int id : alternates) remove[size_t(id)] = 1;
    for (int r : out.roots) remove[size_t(r)] = 0;
    for (const Node& n : out.nodes)
        for (int c : n.children) remove[size_t(c)] = 0;
    for (const Light& l : out.lights)
        if (l.node >= 0) remove[size_t(l.node)] = 0;
    for (size_t i = 0; i < out.nodes.size(); ++i)
        if (remove[i] && out.nodes[i].mesh >= 0) plan.old_level_meshes.insert(out.nodes[i].mesh);
    for (int n : plan.chain_nodes) {
        out.nodes[size_t(n)].lod_ids.clear();
        out.nodes[size_t(n)].screen_coverage.clear();
    }
    return plan;
}

// The measured levels of one mesh: searched for the error bound, or built for the counts.
Result<std::vector<MeasuredLevel>> make_levels(const Mesh& mesh, int mi, const Soup& base,
                                               const LodChainOptions& options,
                                               std::vector<std::string>& notes,
                                               const std::function<void(double)>& progress,
                                               PrimitiveLogs* log) {
    if (options.targets.max_error_m >= 0.0 || options.targets.max_error_pct >= 0.0) {
        const ErrorBound bound = options.targets.max_error_m >= 0.0
                                     ? ErrorBound{options.targets.max_error_m, false}
                                     : ErrorBound{options.targets.max_error_pct, true};
        return search_error(mesh, size_t(mi), base, bound, options, notes, progress, log);
    }
    Result<std::vector<size_t>> targets =
        count_targets(options.targets, mesh.triangle_count(), mesh, options.max_levels, notes);
    if (!targets.ok()) return targets.error();
    Result<std::vector<BuiltLevel>> built = build_levels(
        mesh, size_t(mi), *targets, options, [&](double f) { progress(0.6 * f); }, notes, log);
    if (!built.ok()) return built.error();
    const Reference reference(base, options.distance);
    std::vector<MeasuredLevel> levels;
    for (size_t k = 0; k < built->size(); ++k) {
        levels.push_back(measure(std::move((*built)[k]), reference));
        progress(0.6 + 0.4 * double(k + 1) / double(built->size()));
    }
    return levels;
}

// A level with no fewer triangles than the one before it (an algorithm stopped by seams,
// borders or its granularity) adds nothing to the chain.
std::vector<MeasuredLevel> drop_unshrinking_levels(std::vector<MeasuredLevel> levels,
                                                   const Mesh& mesh,
                                                   std::vector<std::string>& notes) {
    std::vector<MeasuredLevel> useful;
    size_t previous = mesh.triangle_count();
    for (MeasuredLevel& lvl : levels) {
        size_t tris = 0;
        for (const Primitive& p : lvl.built.primitives) tris += p.triangle_count();
        if (tris >= previous) {
            notes.push_back(cat("mesh \"", mesh.name, "\": the level for ", lvl.built.target,
                                " triangles has ", tris, ", not fewer than the level before (",
                                previous, "); dropped"));
            continue;
        }
        previous = tris;
        useful.push_back(std::move(lvl));
    }
    return useful;
}

void add_progressive_meshes(const Mesh& mesh, int mi, bool no_levels, PrimitiveLogs& logs,
                            LodChainReport& report) {
    if (no_levels) {
        report.notes.push_back(cat("mesh \"", mesh.name, "\" has no level: no progressive mesh"));
        return;
    }
    // Based at the run's last target: the last level, or, where the last levels were
    // dropped for not shrinking, the same mesh as the last level kept.
    for (size_t p = 0; p < mesh.primitives.size(); ++p) {
        if (p >= logs.size() || !logs[p]) {
            report.notes.push_back(cat("mesh \"", mesh.name, "\" primitive ", p,
                                       " is not simplified: no progressive mesh"));
            continue;
        }
        report.progressive.push_back(
            {mi, mesh.name, p, mesh.primitives.size(), std::move(*logs[p])});
    }
}

LodLevelReport level_row(const MeasuredLevel& lvl, const Mesh& m, int mesh_index, size_t k) {
    LodLevelReport row;
    row.mesh = mesh_index;
    row.mesh_name = m.name;
    row.level = int(k + 1);
    row.triangles = m.triangle_count();
    row.target = lvl.built.target;
    row.hausdorff_m = lvl.distance.hausdorff;
    row.hausdorff_pct = lvl.distance.hausdorff_pct();
    row.mean_m = lvl.distance.mean;
    row.mean_pct = lvl.distance.mean_pct();
    row.hausdorff_upper_m = lvl.distance.hausdorff_upper;
    row.hausdorff_upper_pct = lvl.distance.hausdorff_upper_pct();
    row.mean_stderr_m = lvl.distance.mean_stderr;
    row.mean_stderr_pct = lvl.distance.mean_stderr_pct();
    row.estimated_error = lvl.built.estimated_error;
    row.simplify_ms = lvl.built.simplify_ms;
    row.measure_ms = lvl.measure_ms;
    row.measure_cpu_ms = lvl.measure_cpu_ms;
    return row;
}

// The levels as meshes of `out`, their rows in the report (level 0 first) and in `chain`.
void add_level_meshes(Scene& out, const Mesh& mesh, int mi, std::vector<MeasuredLevel>& levels,
                      LodChainReport& report, Chain& chain) {
    LodLevelReport row0;
    row0.mesh = mi;
    row0.mesh_name = mesh.name;
    row0.triangles = mesh.triangle_count();
    report.levels.push_back(row0);
    for (size_t k = 0; k < levels.size(); ++k) {
        MeasuredLevel& lvl = levels[k];
        Mesh m;
        m.name = cat(mesh.name, "_lod", k + 1);
        m.primitives = std::move(lvl.built.primitives);
        report.levels.push_back(level_row(lvl, m, int(out.meshes.size()), k));
        chain.level_meshes.push_back(int(out.meshes.size()));
        chain.errors.push_back(lvl.distance.hausdorff);
        out.meshes.push_back(std::move(m));
    }
}

// The chain of mesh `mi` of `out`; progress runs from done_triangles over its triangles.
Status chain_mesh(Scene& out, int mi, const LodChainOptions& options, size_t total_triangles,
                  size_t& done_triangles, LodChainReport& report, Chain& chain) {
    const Mesh mesh = out.meshes[size_t(mi)];  // copy: out.meshes grows below
    const size_t count = mesh.triangle_count();
    auto progress = [&](double f) {
        if (options.progress && total_triangles > 0)
            options.progress((double(done_triangles) + f * double(count)) /
                             double(total_triangles));
    };
    const Soup base = soup_of(mesh.primitives);
    const double diag = bounding_box_diagonal(base.view());
    PrimitiveLogs logs;
    PrimitiveLogs* log = options.progressive ? &logs : nullptr;
    Result<std::vector<MeasuredLevel>> made =
        make_levels(mesh, mi, base, options, report.notes, progress, log);
    if (!made.ok()) return made.error();
    std::vector<MeasuredLevel> levels =
        drop_unshrinking_levels(std::move(made).value(), mesh, report.notes);
    if (options.progressive) add_progressive_meshes(mesh, mi, levels.empty(), logs, report);
    chain.diameter = diag;
    add_level_meshes(out, mesh, mi, levels, report, chain);
    done_triangles += count;
    progress(1.0);
    ++report.meshes;
    return {};
}

// New alternate nodes.
void add_alternate_nodes(Scene& out, const std::vector<int>& chain_nodes,
                         const std::vector<Chain>& chains, double screen_tolerance,
                         LodChainReport& report) {
    for (int ni : chain_nodes) {
        const Chain& chain = chains[size_t(out.nodes[size_t(ni)].mesh)];
        out.nodes[size_t(ni)].geometric_error_m = 0.0;
        if (chain.level_meshes.empty()) continue;
        std::vector<double> coverage;
        double previous = 1.0;
        for (double e : chain.errors) {
            const double c =
                std::min(previous, e > 0.0 ? chain.diameter * screen_tolerance / e : 1.0);
            coverage.push_back(std::min(1.0, c));
            previous = coverage.back();
        }
        coverage.push_back(0.0);
        std::vector<int> ids;
        for (size_t k = 0; k < chain.level_meshes.size(); ++k) {
            Node n;
            const Node& src = out.nodes[size_t(ni)];
            n.name =
                cat(src.name.empty() ? out.meshes[size_t(src.mesh)].name : src.name, "_lod", k + 1);
            n.translation = src.translation;
            n.rotation = src.rotation;
            n.scale = src.scale;
            n.mesh = chain.level_meshes[k];
            n.geometric_error_m = chain.errors[k];
            ids.push_back(int(out.nodes.size()));
            out.nodes.push_back(std::move(n));
        }
        out.nodes[size_t(ni)].lod_ids = std::move(ids);
        out.nodes[size_t(ni)].screen_coverage = std::move(coverage);
        ++report.nodes;
    }
}

// Drop the old alternates and the meshes only they used; renumber.
void drop_old_alternates(Scene& out, std::vector<char> remove,
                         const std::set<int>& old_level_meshes, LodChainReport& report) {
    remove.resize(out.nodes.size(), 0);
    std::vector<int> node_id(out.nodes.size(), -1);
    std::vector<Node> nodes;
    for (size_t i = 0; i < out.nodes.size(); ++i)
        if (!remove[i]) {
            node_id[i] = int(nodes.size());
            nodes.push_back(std::move(out.nodes[i]));
        }
    std::vector<char> mesh_used(out.meshes.size(), 0);
    for (const Node& n : nodes)
        if (n.mesh >= 0) mesh_used[size_t(n.mesh)] = 1;
    std::vector<int> mesh_id(out.meshes.size(), -1);
    std::vector<Mesh> kept_meshes;
    for (size_t m = 0; m < out.meshes.size(); ++m)
        if (mesh_used[m] || !old_level_meshes.count(int(m))) {
            mesh_id[m] = int(kept_meshes.size());
            kept_meshes.push_back(std::move(out.meshes[m]));
        }
    auto remap_list = [&](std::vector<int>& ids) {
        std::vector<int> next;
        for (int id : ids)
            if (id >= 0 && size_t(id) < node_id.size() && node_id[size_t(id)] >= 0)
                next.push_back(node_id[size_t(id)]);
        ids = std::move(next);
    };
    for (Node& n : nodes) {
        remap_list(n.children);
        remap_list(n.lod_ids);
        if (n.mesh >= 0) n.mesh = mesh_id[size_t(n.mesh)];
    }
    remap_list(out.roots);
    for (Light& l : out.lights)
        if (l.node >= 0) l.node = node_id[size_t(l.node)];
    out.nodes = std::move(nodes);
    out.meshes = std::move(kept_meshes);
    for (LodLevelReport& row : report.levels) row.mesh = mesh_id[size_t(row.mesh)];
}

}  // namespace

Result<LodChainReport> generate_lod_chains(Scene& scene, const LodChainOptions& options_in) {
    // note: one scratch for every simplify() call of this run (primitives, bisection steps), so
    // the calls after the first reuse its pages; freed when the run ends.
    SimplifyScratch scratch;
    LodChainOptions options = options_in;
    if (!options.simplify.scratch) options.simplify.scratch = &scratch;
    if (Status s = check_lod_options(options); !s.ok()) return s.error();

    Scene out = scene;
    LodChainReport report;
    ChainPlan plan = plan_chains(out);
    size_t total_triangles = 0, done_triangles = 0;
    for (int m : plan.meshes) total_triangles += out.meshes[size_t(m)].triangle_count();
    std::vector<Chain> chains(out.meshes.size());
    for (int mi : plan.meshes)
        if (Status s = chain_mesh(out, mi, options, total_triangles, done_triangles, report,
                                  chains[size_t(mi)]);
            !s.ok())
            return s.error();
    add_alternate_nodes(out, plan.chain_nodes, chains, options.screen_tolerance, report);
    drop_old_alternates(out, std::move(plan.remove), plan.old_level_meshes, report);

    scene = std::move(out);
    if (options.progress) options.progress(1.0);
    return report;
}

}  // namespace hmdnode
