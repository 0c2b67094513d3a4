// The pass schedule's sort of its candidates by cost (pass_schedule.cpp runs the passes).
//
// Method: a stable LSD radix sort of the candidates by the top 22 bits of their float cost (sign,
// exponent, 13 mantissa bits: costs within a relative 2^-13 keep their candidate order), as far as
// a pass reads them: by the top 11 bits for all, then, bucket by bucket, by the next 11 (counting
// sorts; insertion sorts of small buckets) only up to the bucket of the pass's limit; the rest
// when a pass reads past it. Each part splits in two where the pass schedule has a helper thread;
// the order is the same either way.
//
// Cost: O(n) per pass for the first digit, O(items read + 2 048 per large bucket) for the second;
// 16 bytes per candidate (its key and two order arrays of 8 bytes, one reused).
#include <algorithm>
#include <cassert>
#include <cstring>
#include <limits>

#include "pass_schedule.hpp"

namespace hmdnode::lod_detail {

// The candidates in cost order, into order_ as (key << 32 | region class << 30 | candidate), by
// the top 22 bits of the cost (sign, exponent, 13 mantissa bits: costs within a relative 2^-13 of
// each other keep their candidate order), as far as a pass reads them: a radix sort by the top
// 11 bits (a few large buckets), then, bucket by bucket, by the next 11 (counting sorts; insertion
// sorts of small buckets), but only of the buckets up to the one holding 1.5 times the cost of the
// goal-th candidate (the pass's limit, returned; sort_rest() sorts the others if a pass reads past
// it). Each part splits in two where there is a helper: the first by halves of the candidates (the
// first half's items of a bucket before the second's), the buckets between the threads by their
// sizes. The order is that of a stable sort on one thread.
double PassSchedule::sort_candidates(bool classes, size_t goal) {
    const size_t n = candidates_.size();
    keys_.resize(n), order_.resize(n), order_tmp_.resize(n);
    const size_t cut = two_way_.has_helper() ? n / 2 : n;
    for (Half& half : halves_) half.radix.assign(kRadixBuckets, 0);
    auto count = [this, n, cut](int h) {
        uint32_t* high = halves_[h].radix.data();
        for (size_t i = h == 0 ? 0 : cut, end = h == 0 ? cut : n; i < end; ++i) {
            uint32_t key;  // note: costs are >= 0, so their bits sort as the floats do
            assert(candidates_[i].cost >= 0.0f);  // not negative, not NaN: bits in float order
            std::memcpy(&key, &candidates_[i].cost, 4);
            keys_[i] = key;
            ++high[key >> 21];
        }
    };
    two_way_.run(count);
    uint32_t* offset0 = halves_[0].radix.data();
    uint32_t* offset1 = halves_[1].radix.data();
    for (uint32_t b = 0, at = 0; b < kRadixBuckets; ++b) {
        bucket_start_[b] = at;
        const uint32_t c0 = offset0[b], c1 = offset1[b];
        offset0[b] = at, offset1[b] = at + c0;
        at += c0 + c1;
    }
    bucket_start_[kRadixBuckets] = uint32_t(n);
    auto high_pass = [this, n, cut, classes](int h) {
        uint32_t* offset = halves_[h].radix.data();
        for (size_t i = h == 0 ? 0 : cut, end = h == 0 ? cut : n; i < end; ++i) {
            const uint32_t key = keys_[i];
            uint64_t item = uint64_t(key) << 32 | i;
            if (classes) {
                const Candidate& c = candidates_[i];
                item |= uint64_t(region_class_[c.from] | region_class_[c.to]) << 30;
            }
            order_tmp_[offset[key >> 21]++] = item;
        }
    };
    two_way_.run(high_pass);
    double limit = std::numeric_limits<double>::infinity();
    uint32_t last = kRadixBuckets - 1, goal_bucket = kRadixBuckets;
    if (goal < n) {
        goal_bucket =
            uint32_t(std::upper_bound(bucket_start_.begin(), bucket_start_.end(), uint32_t(goal)) -
                     bucket_start_.begin()) -
            1;
        sort_bucket(goal_bucket, halves_[0].radix.data());
        limit = 1.5 * double(candidate_at(goal).cost);
        // note: a float cost <= limit has bits <= those of float(limit) (rounding is monotonic).
        const float bound = float(limit);
        uint32_t bits;
        std::memcpy(&bits, &bound, 4);
        last = std::max(goal_bucket, std::min(bits >> 21, kRadixBuckets - 1));
    }
    sort_buckets(0, last, goal_bucket);
    sorted_ = bucket_start_[last + 1];
    std::copy(order_tmp_.begin() + sorted_, order_tmp_.end(), order_.begin() + sorted_);
    return limit;
}

// Buckets first..last (all but `skip`) sorted into order_, split between the threads by size.
void PassSchedule::sort_buckets(uint32_t first, uint32_t last, uint32_t skip) {
    const uint32_t items = bucket_start_[last + 1] - bucket_start_[first];
    uint32_t mid = last + 1;  // note: in one piece without a helper
    if (two_way_.has_helper()) {
        mid = first;
        while (mid <= last && bucket_start_[mid] - bucket_start_[first] < items / 2) ++mid;
    }
    auto buckets = [this, first, last, mid, skip](int h) {
        uint32_t* counts = halves_[h].radix.data();
        for (uint32_t b = h == 0 ? first : mid, end = h == 0 ? mid : last + 1; b < end; ++b) {
            if (b != skip) sort_bucket(b, counts);
        }
    };
    two_way_.run(buckets);
}

// High bucket b of order_tmp_ into order_, stably by the next 11 bits of the key.
void PassSchedule::sort_bucket(uint32_t b, uint32_t* counts) {
    const uint32_t begin = bucket_start_[b], end = bucket_start_[b + 1];
    if (end - begin <= kInsertionSortItems) {
        // note: a counting sort clears and sums all 2 048 counters whatever the bucket's size,
        // and most buckets a pass reads hold a few items or none. An insertion sort is stable
        // too, so the order is the same (measured: docs/simplification.md, "Measurements behind
        // the engine's choices").
        for (uint32_t i = begin; i < end; ++i) {
            const uint64_t item = order_tmp_[i];
            const uint64_t digit = item >> 42;  // note: the high digit is the bucket's, equal
            uint32_t j = i;
            while (j > begin && (order_[j - 1] >> 42) > digit) {
                order_[j] = order_[j - 1];
                --j;
            }
            order_[j] = item;
        }
        return;
    }
    std::fill(counts, counts + kRadixBuckets, 0u);
    for (uint32_t i = begin; i < end; ++i) ++counts[(order_tmp_[i] >> 42) & (kRadixBuckets - 1)];
    for (uint32_t k = 0, at = begin; k < kRadixBuckets; ++k) {
        const uint32_t c = counts[k];
        counts[k] = at;
        at += c;
    }
    for (uint32_t i = begin; i < end; ++i) {
        const uint64_t item = order_tmp_[i];
        order_[counts[(item >> 42) & (kRadixBuckets - 1)]++] = item;
    }
}

// The buckets a pass did not expect to read (past the limit), when it does.
void PassSchedule::sort_rest() {
    // note: the first bucket starting at sorted_ (the empty ones before it are sorted already).
    const uint32_t first =
        uint32_t(std::lower_bound(bucket_start_.begin(), bucket_start_.end(), uint32_t(sorted_)) -
                 bucket_start_.begin());
    if (first < kRadixBuckets) sort_buckets(first, kRadixBuckets - 1, kRadixBuckets);
    sorted_ = order_.size();
}

}  // namespace hmdnode::lod_detail
