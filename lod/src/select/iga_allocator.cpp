// LOD allocation under a frame budget by the immune genetic algorithm of J. He, P. Wang, J. Zhu, J.
// Zeng, "Application and Optimization of Mesh Simplification in 3D virtual Reality Scene in a
// High-performance Environment" (venue and year not stated in our copy; docs/references.md),
// section 2.2 (3), eqs. (13)-(18). The paper applies it to collision distances; here the problem is
// the greedy allocator's (T. A. Funkhouser, C. H. Sequin, "Adaptive display algorithm for
// interactive frame rates during visualization of complex virtual environments", SIGGRAPH 1993):
// choose a level per drawn object, no finer than the selector's, that minimises the visible error
// left, f = sum_i e_i(l_i) * k_i (in tolerances), subject to base + b * sum_i triangles_i(l_i) <=
// budget.
//
// The paper's steps, and what this file does where the paper is vague (docs/lod-selection.md):
//  1) coding (eq. 14): a gene is a level in [selector's level, coarsest], i.e. eq. 14's real code
//     quantised to the level grid (levels are discrete; a real gene would be rounded anyway).
//  2) initial antibodies: the paper draws them at random. Here, for temporal stability, antibody
//     0 is last frame's levels (BudgetCandidate::previous, the memory cell carried across
//     frames), 1 every object at the selector's level, 2 the greedy allocator's answer (prior
//     knowledge, so the IGA never returns worse than the greedy), the rest antibody 0 with 5 % of
//     its genes reset at random.
//  3) vaccine: the rounded mean of the best `vaccine_donors` antibodies' genes; a vaccinated
//     child gets `vaccine_genes` of its genes from it (the paper extracts the vaccine but does not
//     say how it is injected; this is the gene injection of L. Jiao, L. Wang, "A novel genetic
//     algorithm based on immunity", IEEE Transactions on Systems, Man, and Cybernetics, Part A
//     30(5), 2000).
//  4) affinity (eq. 16): F = 1 / f^2 (M_max when f = 0), used relative to the best (f_min / f)^2
//     so that it does not overflow.
//  5) selection: the paper's probabilities are garbled ("inversely proportional to the affinity");
//     here the usual immune-GA rule: p = w * F / sum F + (1 - w) * (1 / C) / sum (1 / C), with the
//     concentration C the share of antibodies whose f is within `similar` of this one's (alike by
//     f rather than by Hamming distance: O(P^2) instead of O(P^2 n)); roulette over p.
//  6) crossover (eq. 17): arithmetic, one u per pair, genes rounded: u a + (1 - u) b and
//     (1 - u) a + u b. Mutation (eq. 18): a gene is reset to a random level of its range with
//     probability `mutations / n` (positions drawn by geometric skips: O(mutations), not O(n)).
//  Elitism: the best antibody passes to the next generation unchanged (the memory cell).
// Constraint: by repair, not penalty. Every antibody is repaired (objects coarsened, least error
// per ms saved first, until the prediction fits) and filled (refined, most error per ms first,
// while a step still fits), so every antibody is feasible whenever the coarsest levels fit, and
// none leaves room for one more step of any object. With the repair and fill this is a memetic
// algorithm: the GA decides which objects give way; the greedy orders settle the rest.
// Determinism: the generator (SplitMix64) is reseeded from IgaParams::seed on every call and the
// work is capped by generations (never by a clock), so the same candidates give the same levels.
// Stability: last frame's levels are kept unless the best antibody beats them by `keep_previous`.
// Cost: the greedy's O(n L^2 + n L log n) and O(n log n) for the orders, then O(P n L) per
// generation, at most `max_generations`.
#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>
#include <numeric>
#include <optional>

#include "hmdnode/lod/budget.hpp"

namespace hmdnode {

namespace {

// SplitMix64 (G. L. Steele, D. Lea, C. H. Flood, "Fast splittable pseudorandom number
// generators", OOPSLA 2014): the same numbers on every platform, unlike <random>'s distributions.
struct SplitMix {
    uint64_t s;
    uint64_t next() {
        uint64_t z = (s += 0x9e3779b97f4a7c15ull);
        z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
        z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
        return z ^ (z >> 31);
    }
    double uniform() { return double(next() >> 11) * 0x1.0p-53; }  // [0, 1)
    uint32_t below(uint32_t n) { return uint32_t(((next() >> 32) * uint64_t(n)) >> 32); }
    // The gap to the next position hit with probability p per position (geometric, >= 1).
    size_t skip(double p) {
        if (p >= 1.0) return 1;
        if (!(p > 0.0)) return std::numeric_limits<size_t>::max() / 2;  // never
        const double u = 1.0 - uniform();                               // (0, 1]
        const double g = std::floor(std::log(u) / std::log1p(-p));
        return g >= 1e18 ? std::numeric_limits<size_t>::max() / 2 : size_t(g) + 1;
    }
};

using Gene = IgaLodAllocator::Gene;

}  // namespace

// One allocate() call: the problem, the generator, and the algorithm's steps over the
// allocator's scratch (sized by the first frames, kept across calls).
struct IgaLodAllocator::Run {
    IgaLodAllocator& a;
    std::span<const BudgetCandidate> candidates;
    double base_ms, per_triangle_ms, budget_ms;
    std::span<int> levels;
    size_t n;      // objects
    size_t P;      // antibodies
    double slope;  // ms per triangle, >= 0
    SplitMix rng;  // seeded from IgaParams::seed on every call

    uint64_t tri(size_t i, Gene l) const { return candidates[i].level_triangles[l]; }
    bool fits(uint64_t t) const { return base_ms + slope * double(t) <= budget_ms; }
    double error_of(const Gene* g) const {
        double f = 0.0;
        for (size_t i = 0; i < n; ++i)
            f += candidates[i].level_errors_m[g[i]] * candidates[i].error_scale;
        return f;
    }
    static bool better(const Antibody& x, const Antibody& y) {
        return x.f < y.f || (x.f == y.f && x.triangles < y.triangles);
    }

    // Per object: its range of levels, its benefit per ms over the whole range, and the objects
    // ordered by it.
    void set_ranges() {
        a.finest_.resize(n);
        a.coarsest_.resize(n);
        a.density_.resize(n);
        a.order_.resize(n);
        for (size_t i = 0; i < n; ++i) {
            const BudgetCandidate& c = candidates[i];
            assert(!c.level_triangles.empty() &&
                   c.level_triangles.size() == c.level_errors_m.size());
            assert(c.level_triangles.size() <= std::numeric_limits<Gene>::max());
            const int L = int(c.level_triangles.size()) - 1;
            const int fin = std::clamp(c.finest, 0, L);
            a.coarsest_[i] = Gene(L);
            a.finest_[i] = Gene(fin);
            const double benefit =
                (c.level_errors_m[size_t(L)] - c.level_errors_m[size_t(fin)]) * c.error_scale;
            const double cost = slope * (double(c.level_triangles[size_t(fin)]) -
                                         double(c.level_triangles[size_t(L)]));
            a.density_[i] = cost > 0.0 ? benefit / cost : std::numeric_limits<double>::infinity();
        }
        std::iota(a.order_.begin(), a.order_.end(), 0u);
        std::sort(a.order_.begin(), a.order_.end(), [&](uint32_t x, uint32_t y) {
            return a.density_[x] < a.density_[y] || (a.density_[x] == a.density_[y] && x < y);
        });
    }

    // Repairs, fills and evaluates an antibody in place (the constraint, by repair).
    Antibody polish(Gene* g) const {
        uint64_t t = 0;
        for (size_t i = 0; i < n; ++i) t += tri(i, g[i]);
        for (size_t k = 0; k < n && !fits(t); ++k) {  // repair: least worthwhile first
            const uint32_t i = a.order_[k];
            for (; g[i] < a.coarsest_[i] && !fits(t); ++g[i])
                t = t - tri(i, g[i]) + tri(i, g[i] + 1);
        }
        for (size_t k = n; k-- > 0;) {  // fill: most worthwhile first
            const uint32_t i = a.order_[k];
            for (; g[i] > a.finest_[i]; --g[i]) {
                const uint64_t up = t - tri(i, g[i]) + tri(i, g[i] - 1);
                if (!fits(up)) break;
                t = up;
            }
        }
        return Antibody{error_of(g), t};
    }

    // Mutation (eq. 18): each gene reset to a random level of its range with probability p.
    void mutate(Gene* g, double p) {
        for (size_t j = rng.skip(p) - 1; j < n; j += rng.skip(p))
            g[j] = Gene(a.finest_[j] + rng.below(uint32_t(a.coarsest_[j] - a.finest_[j]) + 1));
    }

    // The answer: antibody g's levels into `levels`.
    BudgetAllocation finish(const Gene* g, const Antibody& ab) {
        BudgetAllocation out;
        out.triangles = ab.triangles;
        out.predicted_ms = base_ms + slope * double(ab.triangles);
        out.coarsened = 0;
        for (size_t i = 0; i < n; ++i) {
            levels[i] = g[i];
            out.coarsened += g[i] > a.finest_[i];
        }
        // Every antibody is filled: an object left coarser has no step that still fits.
        out.limited = out.coarsened > 0;
        return out;
    }

    // Antibody 1: the selector's levels, repaired. When they fit there is nothing to search; when
    // not even every object at its coarsest fits, that is the answer (the cheapest frame).
    std::optional<BudgetAllocation> answer_without_search() {
        Gene* a1 = &a.genes_[n];
        std::copy(a.finest_.begin(), a.finest_.end(), a1);
        a.antibodies_[1] = polish(a1);
        if (fits(a.antibodies_[1].triangles) && std::equal(a.finest_.begin(), a.finest_.end(), a1))
            return finish(a1, a.antibodies_[1]);
        Gene* a2 = &a.genes_[2 * n];
        uint64_t coarsest_triangles = 0;
        for (size_t i = 0; i < n; ++i) coarsest_triangles += tri(i, a.coarsest_[i]);
        if (!fits(coarsest_triangles)) {
            std::copy(a.coarsest_.begin(), a.coarsest_.end(), a2);
            a.antibodies_[2] = Antibody{error_of(a2), coarsest_triangles};
            return finish(a2, a.antibodies_[2]);
        }
        return std::nullopt;
    }

    // The other initial antibodies (antibody 1 is answer_without_search()'s); returns antibody 0,
    // the memory cell, whose genes are also kept in warm_.
    Antibody seed_population() {
        // Antibody 2: the greedy allocator's answer (prior knowledge, as an immune algorithm's
        // vaccine is): with elitism the IGA never returns worse than the greedy.
        Gene* a2 = &a.genes_[2 * n];
        a.greedy_levels_.resize(n);
        a.greedy_.allocate(candidates, base_ms, per_triangle_ms, budget_ms, a.greedy_levels_);
        for (size_t i = 0; i < n; ++i) a2[i] = Gene(a.greedy_levels_[i]);
        a.antibodies_[2] = polish(a2);
        // Antibody 0: last frame's levels within this frame's ranges (the memory cell); objects
        // without one start at the selector's level.
        Gene* a0 = &a.genes_[0];
        for (size_t i = 0; i < n; ++i)
            a0[i] = candidates[i].previous < 0
                        ? a.finest_[i]
                        : Gene(std::clamp(candidates[i].previous, int(a.finest_[i]),
                                          int(a.coarsest_[i])));
        a.antibodies_[0] = polish(a0);
        std::copy(a0, a0 + n, a.warm_.begin());
        // The rest: antibody 0 with 5 % of its genes reset at random.
        for (size_t p = 3; p < P; ++p) {
            Gene* g = &a.genes_[p * n];
            std::copy(a0, a0 + n, g);
            mutate(g, 0.05);
            a.antibodies_[p] = polish(g);
        }
        return a.antibodies_[0];
    }

    size_t best_of() const {
        size_t b = 0;
        for (size_t p = 1; p < P; ++p)
            if (better(a.antibodies_[p], a.antibodies_[b])) b = p;
        return b;
    }

    // Vaccine: the rounded mean genes of the best `donors` antibodies.
    void make_vaccine(size_t donors) {
        std::iota(a.ranked_.begin(), a.ranked_.end(), 0u);
        std::partial_sort(a.ranked_.begin(), a.ranked_.begin() + ptrdiff_t(donors), a.ranked_.end(),
                          [&](uint32_t x, uint32_t y) {
                              return better(a.antibodies_[x], a.antibodies_[y]) ||
                                     (!better(a.antibodies_[y], a.antibodies_[x]) && x < y);
                          });
        for (size_t i = 0; i < n; ++i) {
            unsigned sum = 0;
            for (size_t d = 0; d < donors; ++d) sum += a.genes_[a.ranked_[d] * n + i];
            a.vaccine_[i] = Gene((sum + unsigned(donors / 2)) / unsigned(donors));
        }
    }

    // Selection probabilities from affinity (eq. 16, relative to the best) and concentration.
    void selection_probabilities(size_t best) {
        const IgaParams& params = a.params_;
        const double f_min = a.antibodies_[best].f;
        double sum_aff = 0.0, sum_inv_c = 0.0;
        for (size_t p = 0; p < P; ++p) {
            const double f = a.antibodies_[p].f;
            size_t alike = 0;
            for (size_t q = 0; q < P; ++q)
                alike += std::abs(a.antibodies_[q].f - f) <=
                         params.similar * std::max(f, a.antibodies_[q].f);
            a.affinity_[p] = f_min > 0.0 ? (f_min / f) * (f_min / f) : (f == 0.0 ? 1.0 : 0.0);
            a.inv_concentration_[p] = double(P) / double(std::max<size_t>(alike, 1));
            sum_aff += a.affinity_[p];
            sum_inv_c += a.inv_concentration_[p];
        }
        const double w = std::clamp(params.affinity_weight, 0.0, 1.0);
        for (size_t p = 0; p < P; ++p)
            a.select_p_[p] =
                w * a.affinity_[p] / sum_aff + (1.0 - w) * a.inv_concentration_[p] / sum_inv_c;
    }

    // Roulette over the selection probabilities.
    size_t pick() {
        double u = rng.uniform(), acc = 0.0;
        for (size_t p = 0; p < P; ++p)
            if (u < (acc += a.select_p_[p])) return p;
        return P - 1;
    }

    // Children c and c + 1 (when c + 1 < P): two selected parents, crossed (eq. 17), then each
    // child mutated, perhaps vaccinated, and polished.
    void breed(size_t c, double pm) {
        const IgaParams& params = a.params_;
        const Gene* pa = &a.genes_[pick() * n];
        const Gene* pb = &a.genes_[pick() * n];
        Gene* ca = &a.children_[c * n];
        Gene* cb = c + 1 < P ? &a.children_[(c + 1) * n] : nullptr;
        if (rng.uniform() < params.crossover_p) {
            const double u = rng.uniform();
            for (size_t i = 0; i < n; ++i) {
                const double x = pa[i], y = pb[i];
                ca[i] = Gene(std::lround(u * x + (1.0 - u) * y));
                if (cb) cb[i] = Gene(std::lround((1.0 - u) * x + u * y));
            }
        } else {
            std::copy(pa, pa + n, ca);
            if (cb) std::copy(pb, pb + n, cb);
        }
        for (size_t k = c; k < std::min(c + 2, P); ++k) {
            Gene* g = &a.children_[k * n];
            mutate(g, pm);
            if (rng.uniform() < params.vaccine_p)
                for (size_t j = rng.skip(params.vaccine_genes) - 1; j < n;
                     j += rng.skip(params.vaccine_genes))
                    g[j] = a.vaccine_[j];
            a.child_antibodies_[k] = polish(g);
        }
    }

    // Generations until the cap or a stall; returns the best antibody's index.
    size_t search() {
        const IgaParams& params = a.params_;
        size_t best = best_of();
        const double pm = std::min(1.0, params.mutations / double(n));
        const size_t donors = std::clamp(size_t(std::max(1, params.vaccine_donors)), size_t(1), P);
        a.select_p_.resize(P);
        a.affinity_.resize(P);
        a.inv_concentration_.resize(P);
        a.ranked_.resize(P);
        a.vaccine_.resize(n);
        int stall = 0;
        for (int gen = 0; gen < params.max_generations && stall < params.stall_generations; ++gen) {
            ++a.generations_;
            make_vaccine(donors);
            selection_probabilities(best);
            // Child 0: the elite, unchanged. The rest: pairs of selected parents.
            std::copy(&a.genes_[best * n], &a.genes_[best * n] + n, &a.children_[0]);
            a.child_antibodies_[0] = a.antibodies_[best];
            for (size_t c = 1; c < P; c += 2) breed(c, pm);
            a.genes_.swap(a.children_);
            a.antibodies_.swap(a.child_antibodies_);
            const size_t next = best_of();
            stall = better(a.antibodies_[next], a.child_antibodies_[best]) ? 0 : stall + 1;
            best = next;
        }
        return best;
    }
};

BudgetAllocation IgaLodAllocator::allocate(std::span<const BudgetCandidate> candidates,
                                           double base_ms, double per_triangle_ms, double budget_ms,
                                           std::span<int> levels) {
    assert(levels.size() == candidates.size());
    const size_t n = candidates.size();
    Run run{.a = *this,
            .candidates = candidates,
            .base_ms = base_ms,
            .per_triangle_ms = per_triangle_ms,
            .budget_ms = budget_ms,
            .levels = levels,
            .n = n,
            .P = size_t(std::max(4, params_.population)),
            .slope = std::max(0.0, per_triangle_ms),
            .rng = SplitMix{params_.seed}};
    generations_ = 0;
    if (n == 0) {
        BudgetAllocation out;
        out.predicted_ms = base_ms;
        return out;
    }
    run.set_ranges();

    genes_.resize(run.P * n);
    children_.resize(run.P * n);
    warm_.resize(n);
    antibodies_.resize(run.P);
    child_antibodies_.resize(run.P);
    if (std::optional<BudgetAllocation> answer = run.answer_without_search()) return *answer;
    bool any_previous = false;
    for (size_t i = 0; i < n; ++i) any_previous |= candidates[i].previous >= 0;
    const Antibody warm = run.seed_population();
    const size_t best = run.search();
    // Last frame's levels stay unless clearly beaten: level changes cost a cross-fade each.
    if (any_previous && warm.f <= antibodies_[best].f * (1.0 + params_.keep_previous))
        return run.finish(warm_.data(), warm);
    return run.finish(&genes_[best * n], antibodies_[best]);
}

}  // namespace hmdnode
