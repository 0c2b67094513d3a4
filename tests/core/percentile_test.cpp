// The one percentile definition (core/percentile.hpp): nearest rank, rounded up, k = ceil(p n)
// clamped to [1, n]; the in-place form gives the same as the copying and the sorted forms.
#include "hmdnode/core/percentile.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

namespace hmdnode {
namespace {

TEST(Percentile, IsTheKthSmallestWithKTheCeilingOfPTimesN) {
    std::vector<double> v;
    for (int i = 100; i >= 1; --i) v.push_back(i);  // 1..100, in reverse
    EXPECT_EQ(percentile(v, 0.0), 1);
    EXPECT_EQ(percentile(v, 0.5), 50);
    EXPECT_EQ(percentile(v, 0.95), 95);
    EXPECT_EQ(percentile(v, 0.99), 99);
    EXPECT_EQ(percentile(v, 1.0), 100);
    EXPECT_EQ(percentile(v, 0.07), 7);    // 0.07 * 100 is 7.000000000000001 in doubles
    EXPECT_EQ(percentile(v, 0.951), 96);  // ceil(95.1)
}

TEST(Percentile, MedianOfAnEvenCountIsTheLowerMiddleValue) {
    EXPECT_EQ(percentile({4, 1, 3, 2}, 0.5), 2);
    EXPECT_EQ(percentile({5, 1, 3}, 0.5), 3);
    EXPECT_EQ(percentile({7}, 0.95), 7);
}

TEST(Percentile, IndexClampsPAndHandlesNaN) {
    EXPECT_EQ(percentile_index(-1.0, 10), 0u);
    EXPECT_EQ(percentile_index(2.0, 10), 9u);
    EXPECT_EQ(percentile_index(std::nan(""), 10), 0u);
    EXPECT_EQ(percentile_index(0.1, 10), 0u);   // k = 1
    EXPECT_EQ(percentile_index(0.11, 10), 1u);  // k = 2
}

TEST(Percentile, NoValuesIsNaN) {
    EXPECT_TRUE(std::isnan(percentile({}, 0.5)));
}

TEST(Percentile, InPlaceAndSortedFormsAgreeWithTheCopy) {
    std::vector<int64_t> v;
    for (int i = 0; i < 37; ++i) v.push_back((i * 17) % 37);
    std::vector<int64_t> sorted = v;
    std::sort(sorted.begin(), sorted.end());
    for (double p : {0.0, 0.25, 0.5, 0.9, 0.95, 0.98, 1.0}) {
        std::vector<int64_t> scratch = v;
        EXPECT_EQ(percentile_in_place(scratch.begin(), scratch.end(), p),
                  percentile_sorted(sorted, p))
            << p;
    }
}

}  // namespace
}  // namespace hmdnode
