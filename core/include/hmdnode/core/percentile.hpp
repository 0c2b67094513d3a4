// Percentiles: the one definition every p50/p95/p99/median of the project uses (reports, the
// frame pacer's estimates, the benches' tables, the tests).
//
// Definition: nearest rank, rounded up. The p-quantile (0 <= p <= 1) of n values is the k-th
// smallest of them, k = ceil(p * n) clamped to [1, n] (so p = 0 is the minimum, p = 1 the maximum,
// the median of an even count the lower of the two middle values). It is always one of the values,
// never an interpolation between two. p * n is taken less 1e-9 before rounding up, so that a
// product that is an integer on paper (0.07 * 100) but a hair above it in floating point still
// names that rank; a NaN p counts as 0.
//
// Cost: percentile_in_place O(n) expected (std::nth_element), no allocation, for the frame path;
// percentile copies its values once; percentile_sorted O(1).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <iterator>
#include <limits>
#include <vector>

namespace hmdnode {

// The 0-based position, in ascending order, of the p-quantile of n values (n >= 1).
inline size_t percentile_index(double p, size_t n) {
    if (n == 0 || !(p > 0.0)) return 0;
    if (p >= 1.0) return n - 1;
    const double k = std::ceil(p * double(n) - 1e-9);
    return std::clamp<size_t>(size_t(k), 1, n) - 1;
}

// The p-quantile of [first, last) (not empty), reordering that range in place (nth_element):
// for a caller's scratch on a path that must not allocate.
template <class RandomIt>
typename std::iterator_traits<RandomIt>::value_type percentile_in_place(RandomIt first,
                                                                        RandomIt last, double p) {
    const size_t k = percentile_index(p, size_t(last - first));
    std::nth_element(first, first + std::ptrdiff_t(k), last);
    return first[std::ptrdiff_t(k)];
}

// The p-quantile of values already sorted ascending (not empty).
template <class Range>
auto percentile_sorted(const Range& sorted, double p) {
    return sorted[percentile_index(p, std::size(sorted))];
}

// The p-quantile of values in any order; NaN when there are none.
inline double percentile(std::vector<double> values, double p) {
    if (values.empty()) return std::numeric_limits<double>::quiet_NaN();
    return percentile_in_place(values.begin(), values.end(), p);
}

}  // namespace hmdnode
