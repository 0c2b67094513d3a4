// The LOD decision per frame with the frame-budget controller: the perceptual selector for every
// object, then the greedy benefit/cost allocator (T. A. Funkhouser, C. H. Sequin, "Adaptive display
// algorithm for interactive frame rates during visualization of complex virtual environments",
// SIGGRAPH 1993) under a budget that holds back half the detail the selector wants (half-way
// between every object's coarsest level and the selector's, in triangles), for 1,000 objects of 4-6
// levels each around a turning viewer. One thread; medians and 99th percentiles of the per-frame
// time, beside the target of 0.2 ms per frame for 1,000 objects. The selector alone and the
// allocator alone are timed in the same frames.
//
// Usage: bench_lod_budget_bench [frames=2000] [--write-docs]   (--write-docs: into
// docs/results/lod-budget-bench.md)
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <string>
#include <vector>

#include "doc_table.hpp"
#include "hmdnode/lod/budget.hpp"
#include "hmdnode/lod/selector.hpp"
#include "lod_decision_scene.hpp"

using namespace hmdnode;

using bench::now_ns;
using bench::quantile;

int main(int argc, char** argv) {
    const bool write_docs = bench::wants_docs(argc, argv);
    const int frames = argc > 1 && std::string(argv[1]) != "--write-docs"
                           ? std::max(10, std::atoi(argv[1]))
                           : 2000;
    const size_t n = 1000;
    const std::vector<bench::DecisionObject> objects = bench::decision_objects(n);
    LodSelector selector(n);
    GreedyLodAllocator allocator;
    std::vector<BudgetCandidate> candidates;
    candidates.reserve(n);
    std::vector<int> levels(n);
    const double base_ms = 2.0, per_triangle_ms = 1e-5;
    std::vector<double> total_ms, select_ms, alloc_ms;
    size_t coarsened = 0, limited = 0;
    for (int f = 0; f < frames + 20; ++f) {
        const LodViewer v = bench::decision_viewer(f);
        const int64_t t0 = now_ns();
        // The budget: half-way between everything coarsest and the selector's levels.
        const double budget_ms =
            bench::decision_candidates(selector, objects, v, base_ms, per_triangle_ms, candidates);
        const int64_t t1 = now_ns();
        const BudgetAllocation a =
            allocator.allocate(candidates, base_ms, per_triangle_ms, budget_ms, levels);
        const int64_t t2 = now_ns();
        if (f < 20) continue;  // warm-up
        select_ms.push_back(double(t1 - t0) * 1e-6);
        alloc_ms.push_back(double(t2 - t1) * 1e-6);
        total_ms.push_back(double(t2 - t0) * 1e-6);
        coarsened += a.coarsened;
        limited += a.limited;
    }
    std::string out;
    char line[512];
    std::snprintf(line, sizeof line,
                  "LOD decision per frame, %zu objects of 4-6 levels, %d frames, one thread "
                  "(%s)\n",
                  n, frames, bench::build_kind());
    out += line;
    std::snprintf(line, sizeof line, "%-28s %9s %9s %9s\n", "ms per frame", "p50", "p99", "target");
    out += line;
    std::snprintf(line, sizeof line, "%-28s %9.4f %9.4f %9.2f\n", "selector + greedy allocator",
                  quantile(total_ms, 0.5), quantile(total_ms, 0.99), 0.2);
    out += line;
    std::snprintf(line, sizeof line, "%-28s %9.4f %9.4f %9s\n", "  selector alone",
                  quantile(select_ms, 0.5), quantile(select_ms, 0.99), "-");
    out += line;
    std::snprintf(line, sizeof line, "%-28s %9.4f %9.4f %9s\n", "  greedy allocator alone",
                  quantile(alloc_ms, 0.5), quantile(alloc_ms, 0.99), "-");
    out += line;
    std::snprintf(line, sizeof line,
                  "budget held detail back in %.0f %% of frames, %.0f objects coarsened per frame "
                  "(mean)\n",
                  100.0 * double(limited) / double(frames), double(coarsened) / double(frames));
    out += line;
    // The results file names the machine in its header.
    const std::string table = "```\n" + out + "```\n";
    out += "machine: " + bench::machine_facts() + "\n";
    std::fputs(out.c_str(), stdout);
    if (write_docs &&
        !bench::write_result("lod-budget-bench",
                             "LOD decision per frame with the frame-budget controller",
                             bench::command_line(argc, argv), table))
        return 1;
    return 0;
}
