// Greedy benefit/cost LOD allocation under a frame budget: Funkhouser & Sequin, "Adaptive display
// algorithm for interactive frame rates during visualization of complex virtual environments",
// SIGGRAPH 1993. Every drawn object starts at its coarsest level; then the upgrade with the most
// benefit per predicted millisecond is applied while the predicted render still fits the budget.
// Benefit: the visible error an upgrade removes, in perceptual tolerances (the selector's
// projected error over its tolerance, so a near or gazed-at object gains more from the same
// level); cost: its extra triangles times the fitted per-triangle cost. An object's candidate is
// the best ratio over every finer level up to the selector's (the upper hull of its
// benefit/cost curve, so a cheap step does not hide a better one behind it). An upgrade that no
// longer fits is replaced by the object's best one that does, and dropped when none does.
// Cost: one heap entry per object at a time; O(n L^2 + n L log n) for n objects of L levels.
#include <algorithm>
#include <cassert>
#include <limits>

#include "hmdnode/lod/budget.hpp"

namespace hmdnode {

BudgetAllocation GreedyLodAllocator::allocate(std::span<const BudgetCandidate> candidates,
                                              double base_ms, double per_triangle_ms,
                                              double budget_ms, std::span<int> levels) {
    assert(levels.size() == candidates.size());
    BudgetAllocation out;
    heap_.clear();
    for (size_t i = 0; i < candidates.size(); ++i) {
        const BudgetCandidate& c = candidates[i];
        assert(!c.level_triangles.empty() && c.level_triangles.size() == c.level_errors_m.size());
        levels[i] = int(c.level_triangles.size()) - 1;
        out.triangles += c.level_triangles.back();
    }
    const double slope = std::max(0.0, per_triangle_ms);
    const auto less = [](const Step& a, const Step& b) {  // a max-heap on ratio, then lower index
        return a.ratio < b.ratio || (a.ratio == b.ratio && a.object > b.object);
    };
    double used = base_ms + slope * double(out.triangles);

    // The best upgrade of object i from its current level costing at most `room` ms.
    auto best_step = [&](uint32_t i, double room) -> bool {
        const BudgetCandidate& c = candidates[i];
        const int from = levels[i];
        const double e_from = c.level_errors_m[size_t(from)] * c.error_scale;
        const double t_from = double(c.level_triangles[size_t(from)]);
        Step best{-1.0, i, -1};
        double best_benefit = 0.0;
        for (int to = from - 1; to >= c.finest; --to) {
            const double benefit = e_from - c.level_errors_m[size_t(to)] * c.error_scale;
            const double cost = slope * (double(c.level_triangles[size_t(to)]) - t_from);
            if (cost > room) continue;
            const double ratio =
                cost > 0.0 ? benefit / cost : std::numeric_limits<double>::infinity();
            if (ratio > best.ratio || (ratio == best.ratio && benefit > best_benefit)) {
                best = Step{ratio, i, to};
                best_benefit = benefit;
            }
        }
        if (best.to < 0) return false;
        heap_.push_back(best);
        std::push_heap(heap_.begin(), heap_.end(), less);
        return true;
    };
    const double unlimited = std::numeric_limits<double>::infinity();
    for (uint32_t i = 0; i < uint32_t(candidates.size()); ++i) best_step(i, unlimited);
    while (!heap_.empty()) {
        std::pop_heap(heap_.begin(), heap_.end(), less);
        const Step s = heap_.back();
        heap_.pop_back();
        const BudgetCandidate& c = candidates[s.object];
        const uint64_t t_from = c.level_triangles[size_t(levels[s.object])];
        const uint64_t t_to = c.level_triangles[size_t(s.to)];
        const double cost = slope * (double(t_to) - double(t_from));
        if (used + cost <= budget_ms) {
            used += cost;
            out.triangles = out.triangles - t_from + t_to;
            levels[s.object] = s.to;
            best_step(s.object, unlimited);
        } else {
            out.limited = true;
            best_step(s.object, budget_ms - used);
        }
    }
    for (size_t i = 0; i < candidates.size(); ++i)
        out.coarsened += levels[i] > candidates[i].finest;
    out.predicted_ms = base_ms + slope * double(out.triangles);
    return out;
}

}  // namespace hmdnode
