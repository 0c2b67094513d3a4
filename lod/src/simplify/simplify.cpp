// simplify(): the table of algorithms (name -> entry point) and the checks of its arguments.
// Each algorithm is in its own file; lod/src/simplify/algorithms.hpp declares the entry points. The
// sources below are short author-year forms (`hmdnode lod --list-algorithms` prints them); each
// algorithm file opens with its full citation, and docs/references.md lists them all.
//
// Cost: O(V + F) for the checks, then the algorithm's.
#include "hmdnode/lod/simplify.hpp"

#include <chrono>
#include <cmath>
#include <string>

#include "algorithms.hpp"
#include "collapse_engine.hpp"
#include "hmdnode/lod/attribute_transfer.hpp"
#include "scratch.hpp"

namespace hmdnode {
namespace {

struct Entry {
    AlgorithmInfo info;
    lod_detail::AlgorithmFn fn;
    // The edge-collapse costs' factories (run on the engine, also for progressive meshes and
    // AlgorithmInfo::edge_collapse); nullptr for the others, which have `fn`.
    std::unique_ptr<lod_detail::CollapseCost> (*make_cost)() = nullptr;
};

const std::vector<Entry>& table() {
    static const std::vector<Entry> entries = {
        {{"qem", "Garland-Heckbert quadric error metric, optimal placement",
          "Garland & Heckbert 1997; He et al. eq. (1)-(5)"},
         nullptr,
         lod_detail::make_qem_cost},
        {{"curvature-qem", "QEM weighted by absolute curvature |k1|+|k2| and edge length",
          "He et al. eq. (7)-(12)"},
         nullptr,
         lod_detail::make_curvature_qem_cost},
        {{"formula1", "edge length / dot of the two face normals, half-edge collapse",
          "Lazanyi 2003, Formula 1"},
         nullptr,
         lod_detail::make_formula1_cost},
        {{"melax", "Melax: |u-v| * max_f min_n (1 - f.n)/2, half-edge collapse",
          "Lazanyi 2003, Formula 2 (Melax 1998)"},
         nullptr,
         lod_detail::make_melax_cost},
        {{"ss", "spherical scanning: vertices within a sphere merged, radius found for the target",
          "Li & Kim 2020 sec. III.IV (SS)"},
         lod_detail::simplify_ss},
        {{"fad", "face angle dependency: flattest vertices removed first (half-edge collapse)",
          "Li & Kim 2020 sec. III.II (FAD)"},
         lod_detail::simplify_fad},
        {{"vt", "vertex triplex: smallest triangles aggregated into their circumcentres",
          "Li & Kim 2020 sec. III.I (VT)"},
         lod_detail::simplify_vt},
        {{"ivdd", "intervertex distance: shortest edges to midpoints, small triangles to centres",
          "Li & Kim 2020 sec. III.III (IVDD)"},
         lod_detail::simplify_ivdd},
        {{"vtd", "vertex triplex distance: hybrid of VT and IVDD, by shortest triangle edge",
          "Li & Kim 2020 sec. III.V.I (VTD)"},
         lod_detail::simplify_vtd},
        {{"fass", "face angle spherical scanning: FAD under 30 degrees, then SS to the target",
          "Li & Kim 2020 sec. III.V.II (FASS)"},
         lod_detail::simplify_fass},
        {{"grid", "uniform-grid vertex clustering, cell size found for the target",
          "Rossignac & Borrel 1993"},
         lod_detail::simplify_grid},
        {{"openmesh-quadric", "OpenMesh Decimater with ModQuadric + ModNormalFlipping (baseline)",
          "Garland & Heckbert 1997 as in OpenMesh"},
         lod_detail::simplify_openmesh_quadric},
    };
    return entries;
}

}  // namespace

const std::vector<AlgorithmInfo>& simplification_algorithms() {
    static const std::vector<AlgorithmInfo> infos = [] {
        std::vector<AlgorithmInfo> out;
        for (const Entry& e : table()) {
            out.push_back(e.info);
            out.back().edge_collapse = e.make_cost != nullptr;
        }
        return out;
    }();
    return infos;
}

const AlgorithmInfo* find_simplification_algorithm(std::string_view name) {
    for (const AlgorithmInfo& info : simplification_algorithms()) {
        if (info.name == name) return &info;
    }
    return nullptr;
}

namespace lod_detail {

std::unique_ptr<CollapseCost> make_collapse_cost(std::string_view algorithm) {
    for (const Entry& e : table()) {
        if (e.info.name == algorithm) return e.make_cost ? e.make_cost() : nullptr;
    }
    return nullptr;
}

// The checks simplify() and build_progressive_mesh() share: the entry points' contract.
Status check_simplify_arguments(const Primitive& in, std::string_view algorithm,
                                std::span<const size_t> targets) {
    if (!find_simplification_algorithm(algorithm)) {
        return make_error("unknown simplification algorithm '" + std::string(algorithm) + "'");
    }
    if (in.indices.size() % 3 != 0) {
        return make_error("index count " + std::to_string(in.indices.size()) +
                          " is not a multiple of 3");
    }
    if (in.triangle_count() == 0) return make_error("the mesh has no triangles");
    const size_t n = in.positions.size();
    auto check_size = [n](size_t size, const char* name) -> Status {
        if (size != 0 && size != n) {
            return make_error(std::string(name) + " has " + std::to_string(size) + " entries for " +
                              std::to_string(n) + " positions");
        }
        return Status::success();
    };
    for (Status s : {check_size(in.normals.size(), "normals"), check_size(in.uv0.size(), "uv0"),
                     check_size(in.uv1.size(), "uv1"), check_size(in.colors.size(), "colors"),
                     check_size(in.light.size(), "light (_LIGHT_0)")}) {
        if (!s) return s;
    }
    for (size_t i = 0; i < in.indices.size(); ++i) {
        if (in.indices[i] >= n) {
            return make_error("index " + std::to_string(i) + " is " +
                              std::to_string(in.indices[i]) + ", out of range (" +
                              std::to_string(n) + " vertices)");
        }
    }
    for (size_t i = 0; i < n; ++i) {
        const glm::vec3 p = in.positions[i];
        if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
            return make_error("position " + std::to_string(i) + " is not finite");
        }
    }
    if (targets.empty()) return make_error("no target triangle count");
    for (size_t i = 0; i < targets.size(); ++i) {
        if (targets[i] == 0) return make_error("target " + std::to_string(i) + " is zero");
        if (targets[i] >= in.triangle_count()) {
            return make_error("target " + std::to_string(i) + " (" + std::to_string(targets[i]) +
                              " triangles) is not below the input's " +
                              std::to_string(in.triangle_count()));
        }
        if (i > 0 && targets[i] >= targets[i - 1]) {
            return make_error("targets are not strictly decreasing at " + std::to_string(i) + " (" +
                              std::to_string(targets[i - 1]) + " then " +
                              std::to_string(targets[i]) + ")");
        }
    }
    return Status::success();
}

Status carry_light_to_levels(const Primitive& in, std::vector<SimplifiedLevel>& levels) {
    for (size_t k = 0; k < levels.size(); ++k)
        if (Status s = carry_vertex_light(in, levels[k].primitive); !s)
            return make_error("level " + std::to_string(k) + ": " + s.error().message);
    return Status::success();
}

}  // namespace lod_detail

Result<std::vector<SimplifiedLevel>> simplify(const Primitive& in, std::string_view algorithm,
                                              std::span<const size_t> target_triangles,
                                              const SimplifyOptions& options) {
    if (Status s = lod_detail::check_simplify_arguments(in, algorithm, target_triangles); !s) {
        return s.error();
    }
    std::chrono::steady_clock::time_point t0;
    if (options.profile)
        *options.profile = SimplifyProfile{}, t0 = std::chrono::steady_clock::now();
    // note: the phases the engine timed; the rest of the call is other_ms.
    auto finish_profile = [&] {
        SimplifyProfile* p = options.profile;
        if (!p) return;
        p->total_ms =
            std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0)
                .count();
        const double timed = p->setup_ms + p->adjacency_ms + p->candidates_ms + p->sort_ms +
                             p->apply_ms + p->attributes_ms + p->snapshots_ms + p->other_ms;
        p->other_ms += std::max(0.0, p->total_ms - timed);
    };
    for (const Entry& e : table()) {
        if (e.info.name != algorithm) continue;
        Result<std::vector<SimplifiedLevel>> levels = make_error("");
        if (!e.make_cost) {
            levels = e.fn(in, target_triangles, options);
        } else {
            // note: the caller's scratch (if any) for the cost's arrays too, so it outlives the
            // cost.
            const lod_detail::ScratchScope scope(options.scratch);
            const std::unique_ptr<lod_detail::CollapseCost> cost = e.make_cost();
            levels = lod_detail::run_edge_collapse(in, target_triangles, options, *cost);
        }
        if (!levels) return levels;
        if (Status s = lod_detail::carry_light_to_levels(in, *levels); !s) return s.error();
        finish_profile();
        return levels;
    }
    return make_error("unknown simplification algorithm '" + std::string(algorithm) + "'");
}

}  // namespace hmdnode
