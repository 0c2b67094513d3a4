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

BudgetAllocation IgaLodAllocator::allocate(std::span<const BudgetCandidate> candidates,
                                           double base_ms, double per_triangle_ms, double budget_ms,
                                           std::span<int> levels) {
    assert(levels.size() == candidates.size());
    const size_t n = candidates.size();
    const size_t P = size_t(std::max(4, params_.population));
    const double slope = std::max(0.0, per_triangle_ms);
    generations_ = 0;
    BudgetAllocation out;
    out.predicted_ms = base_ms;
    if (n == 0) return out;

    // Per object: its range of levels and its benefit per ms over the whole range.
    finest_.resize(n);
    coarsest_.resize(n);
    density_.resize(n);
    order_.resize(n);
    for (size_t i = 0; i < n; ++i) {
        const BudgetCandidate& c = candidates[i];
        assert(!c.level_triangles.empty() && c.level_triangles.size() == c.level_errors_m.size());
        assert(c.level_triangles.size() <= std::numeric_limits<Gene>::max());
        const int L = int(c.level_triangles.size()) - 1;
        const int fin = std::clamp(c.finest, 0, L);
        coarsest_[i] = Gene(L);
        finest_[i] = Gene(fin);
        const double benefit =
            (c.level_errors_m[size_t(L)] - c.level_errors_m[size_t(fin)]) * c.error_scale;
        const double cost =
            slope * (double(c.level_triangles[size_t(fin)]) - double(c.level_triangles[size_t(L)]));
        density_[i] = cost > 0.0 ? benefit / cost : std::numeric_limits<double>::infinity();
    }
    std::iota(order_.begin(), order_.end(), 0u);
    std::sort(order_.begin(), order_.end(), [&](uint32_t a, uint32_t b) {
        return density_[a] < density_[b] || (density_[a] == density_[b] && a < b);
    });

    const auto tri = [&](size_t i, Gene l) { return candidates[i].level_triangles[l]; };
    const auto fits = [&](uint64_t t) { return base_ms + slope * double(t) <= budget_ms; };
    // Repair, fill and evaluate an antibody in place.
    const auto polish = [&](Gene* g) -> Antibody {
        uint64_t t = 0;
        for (size_t i = 0; i < n; ++i) t += tri(i, g[i]);
        for (size_t k = 0; k < n && !fits(t); ++k) {  // repair: least worthwhile first
            const uint32_t i = order_[k];
            for (; g[i] < coarsest_[i] && !fits(t); ++g[i]) t = t - tri(i, g[i]) + tri(i, g[i] + 1);
        }
        for (size_t k = n; k-- > 0;) {  // fill: most worthwhile first
            const uint32_t i = order_[k];
            for (; g[i] > finest_[i]; --g[i]) {
                const uint64_t up = t - tri(i, g[i]) + tri(i, g[i] - 1);
                if (!fits(up)) break;
                t = up;
            }
        }
        double f = 0.0;
        for (size_t i = 0; i < n; ++i)
            f += candidates[i].level_errors_m[g[i]] * candidates[i].error_scale;
        return Antibody{f, t};
    };
    const auto mutate = [&](Gene* g, double p, SplitMix& rng) {
        for (size_t j = rng.skip(p) - 1; j < n; j += rng.skip(p))
            g[j] = Gene(finest_[j] + rng.below(uint32_t(coarsest_[j] - finest_[j]) + 1));
    };
    const auto finish = [&](const Gene* g, const Antibody& a) {
        out.triangles = a.triangles;
        out.predicted_ms = base_ms + slope * double(a.triangles);
        out.coarsened = 0;
        for (size_t i = 0; i < n; ++i) {
            levels[i] = g[i];
            out.coarsened += g[i] > finest_[i];
        }
        // Every antibody is filled: an object left coarser has no step that still fits.
        out.limited = out.coarsened > 0;
        return out;
    };

    SplitMix rng{params_.seed};
    genes_.resize(P * n);
    children_.resize(P * n);
    warm_.resize(n);
    antibodies_.resize(P);
    child_antibodies_.resize(P);
    // Antibody 1: the selector's levels, repaired. When they fit there is nothing to search; when
    // not even every object at its coarsest fits, that is the answer (the cheapest frame).
    Gene* a1 = &genes_[n];
    std::copy(finest_.begin(), finest_.end(), a1);
    antibodies_[1] = polish(a1);
    bool any_previous = false;
    for (size_t i = 0; i < n; ++i) any_previous |= candidates[i].previous >= 0;
    if (fits(antibodies_[1].triangles) && std::equal(finest_.begin(), finest_.end(), a1))
        return finish(a1, antibodies_[1]);
    Gene* a2 = &genes_[2 * n];
    uint64_t coarsest_triangles = 0;
    for (size_t i = 0; i < n; ++i) coarsest_triangles += tri(i, coarsest_[i]);
    if (!fits(coarsest_triangles)) {
        std::copy(coarsest_.begin(), coarsest_.end(), a2);
        antibodies_[2] = Antibody{0.0, coarsest_triangles};
        for (size_t i = 0; i < n; ++i)
            antibodies_[2].f += candidates[i].level_errors_m[a2[i]] * candidates[i].error_scale;
        return finish(a2, antibodies_[2]);
    }
    // Antibody 2: the greedy allocator's answer (prior knowledge, as an immune algorithm's vaccine
    // is): with elitism the IGA never returns worse than the greedy.
    greedy_levels_.resize(n);
    greedy_.allocate(candidates, base_ms, per_triangle_ms, budget_ms, greedy_levels_);
    for (size_t i = 0; i < n; ++i) a2[i] = Gene(greedy_levels_[i]);
    antibodies_[2] = polish(a2);
    // Antibody 0: last frame's levels within this frame's ranges (the memory cell); objects
    // without one start at the selector's level.
    Gene* a0 = &genes_[0];
    for (size_t i = 0; i < n; ++i)
        a0[i] = candidates[i].previous < 0
                    ? finest_[i]
                    : Gene(std::clamp(candidates[i].previous, int(finest_[i]), int(coarsest_[i])));
    antibodies_[0] = polish(a0);
    std::copy(a0, a0 + n, warm_.begin());
    const Antibody warm = antibodies_[0];
    for (size_t p = 3; p < P; ++p) {
        Gene* g = &genes_[p * n];
        std::copy(a0, a0 + n, g);
        mutate(g, 0.05, rng);
        antibodies_[p] = polish(g);
    }

    const auto better = [](const Antibody& a, const Antibody& b) {
        return a.f < b.f || (a.f == b.f && a.triangles < b.triangles);
    };
    const auto best_of = [&]() {
        size_t b = 0;
        for (size_t p = 1; p < P; ++p)
            if (better(antibodies_[p], antibodies_[b])) b = p;
        return b;
    };
    size_t best = best_of();
    const double pm = std::min(1.0, params_.mutations / double(n));
    const size_t donors = std::clamp(size_t(std::max(1, params_.vaccine_donors)), size_t(1), P);
    select_p_.resize(P);
    affinity_.resize(P);
    inv_concentration_.resize(P);
    ranked_.resize(P);
    vaccine_.resize(n);
    int stall = 0;
    for (int gen = 0; gen < params_.max_generations && stall < params_.stall_generations; ++gen) {
        ++generations_;
        // Vaccine: the rounded mean genes of the best antibodies.
        std::iota(ranked_.begin(), ranked_.end(), 0u);
        std::partial_sort(ranked_.begin(), ranked_.begin() + ptrdiff_t(donors), ranked_.end(),
                          [&](uint32_t a, uint32_t b) {
                              return better(antibodies_[a], antibodies_[b]) ||
                                     (!better(antibodies_[b], antibodies_[a]) && a < b);
                          });
        for (size_t i = 0; i < n; ++i) {
            unsigned sum = 0;
            for (size_t d = 0; d < donors; ++d) sum += genes_[ranked_[d] * n + i];
            vaccine_[i] = Gene((sum + unsigned(donors / 2)) / unsigned(donors));
        }
        // Selection probabilities from affinity (eq. 16, relative to the best) and concentration.
        const double f_min = antibodies_[best].f;
        double sum_aff = 0.0, sum_inv_c = 0.0;
        for (size_t p = 0; p < P; ++p) {
            const double f = antibodies_[p].f;
            size_t alike = 0;
            for (size_t q = 0; q < P; ++q)
                alike += std::abs(antibodies_[q].f - f) <=
                         params_.similar * std::max(f, antibodies_[q].f);
            affinity_[p] = f_min > 0.0 ? (f_min / f) * (f_min / f) : (f == 0.0 ? 1.0 : 0.0);
            inv_concentration_[p] = double(P) / double(std::max<size_t>(alike, 1));
            sum_aff += affinity_[p];
            sum_inv_c += inv_concentration_[p];
        }
        const double w = std::clamp(params_.affinity_weight, 0.0, 1.0);
        for (size_t p = 0; p < P; ++p)
            select_p_[p] =
                w * affinity_[p] / sum_aff + (1.0 - w) * inv_concentration_[p] / sum_inv_c;
        const auto pick = [&]() {
            double u = rng.uniform(), acc = 0.0;
            for (size_t p = 0; p < P; ++p)
                if (u < (acc += select_p_[p])) return p;
            return P - 1;
        };
        // Child 0: the elite, unchanged. The rest: pairs of selected parents, crossed and mutated.
        std::copy(&genes_[best * n], &genes_[best * n] + n, &children_[0]);
        child_antibodies_[0] = antibodies_[best];
        for (size_t c = 1; c < P; c += 2) {
            const Gene* pa = &genes_[pick() * n];
            const Gene* pb = &genes_[pick() * n];
            Gene* ca = &children_[c * n];
            Gene* cb = c + 1 < P ? &children_[(c + 1) * n] : nullptr;
            if (rng.uniform() < params_.crossover_p) {
                const double u = rng.uniform();
                for (size_t i = 0; i < n; ++i) {
                    const double a = pa[i], b = pb[i];
                    ca[i] = Gene(std::lround(u * a + (1.0 - u) * b));
                    if (cb) cb[i] = Gene(std::lround((1.0 - u) * a + u * b));
                }
            } else {
                std::copy(pa, pa + n, ca);
                if (cb) std::copy(pb, pb + n, cb);
            }
            for (size_t k = c; k < std::min(c + 2, P); ++k) {
                Gene* g = &children_[k * n];
                mutate(g, pm, rng);
                if (rng.uniform() < params_.vaccine_p)
                    for (size_t j = rng.skip(params_.vaccine_genes) - 1; j < n;
                         j += rng.skip(params_.vaccine_genes))
                        g[j] = vaccine_[j];
                child_antibodies_[k] = polish(g);
            }
        }
        genes_.swap(children_);
        antibodies_.swap(child_antibodies_);
        const size_t next = best_of();
        stall = better(antibodies_[next], child_antibodies_[best]) ? 0 : stall + 1;
        best = next;
    }
    // Last frame's levels stay unless clearly beaten: level changes cost a cross-fade each.
    if (any_previous && warm.f <= antibodies_[best].f * (1.0 + params_.keep_previous))
        return finish(warm_.data(), warm);
    return finish(&genes_[best * n], antibodies_[best]);
}

}  // namespace hmdnode
