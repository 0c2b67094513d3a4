// The simplifiers' two-way split (lod/src/two_way.hpp): run(f) calls f(1) on the helper thread and
// f(0) on the caller and returns only when both are done; without a helper both run on the caller,
// 0 then 1. Many rounds in a row each see their own captures (the job is copied per round), runs
// after the helper fell asleep still hand over, and the helper keeps off its caller's core.
#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#ifdef __linux__
#include <sched.h>
#endif

#include "../../lod/src/two_way.hpp"

namespace hmdnode::lod_detail {
namespace {

TEST(TwoWay, HelperRunsTheSecondHalfAndRunWaitsForIt) {
    TwoWay split(true);
    ASSERT_TRUE(split.has_helper());
    const std::thread::id caller = std::this_thread::get_id();
    std::array<std::thread::id, 2> ran_on{};
    std::vector<uint64_t> sums(2000, 0);
    for (uint32_t round = 0; round < 1000; ++round) {
        uint64_t* out = sums.data() + 2 * round;
        std::thread::id* ids = ran_on.data();
        auto job = [out, ids, round](int half) {
            // note: enough work that the caller finishes its half long before a lazy helper would
            uint64_t s = 0;
            for (uint32_t i = 0; i < 2000; ++i) s += (round + 1) * (i + 1) + uint32_t(half);
            out[half] = s;
            ids[half] = std::this_thread::get_id();
        };
        split.run(job);
        // note: both halves wrote before run() returned (no wait here).
        const uint64_t expect = uint64_t(round + 1) * 2000 * 2001 / 2;
        ASSERT_EQ(out[0], expect) << "round " << round;
        ASSERT_EQ(out[1], expect + 2000) << "round " << round;
    }
    EXPECT_EQ(ran_on[0], caller);
    EXPECT_NE(ran_on[1], caller);
}

TEST(TwoWay, WithoutHelperBothHalvesRunOnTheCallerInOrder) {
    TwoWay split(false);
    EXPECT_FALSE(split.has_helper());
    std::vector<int> order;
    std::vector<std::thread::id> ids;
    auto job = [&order, &ids](int half) {
        order.push_back(half);
        ids.push_back(std::this_thread::get_id());
    };
    split.run(job);
    split.run(job);
    EXPECT_EQ(order, (std::vector<int>{0, 1, 0, 1}));
    for (const std::thread::id& id : ids) EXPECT_EQ(id, std::this_thread::get_id());
}

TEST(TwoWay, RunsAfterTheHelperFellAsleep) {
    // note: the threads spin for about a millisecond between runs, then sleep on a futex.
    TwoWay split(true);
    std::array<int, 2> seen{};
    for (int round = 1; round <= 5; ++round) {
        std::this_thread::sleep_for(std::chrono::milliseconds(3));
        int* out = seen.data();
        auto job = [out, round](int half) { out[half] = round * 10 + half; };
        split.run(job);
        ASSERT_EQ(seen[0], round * 10);
        ASSERT_EQ(seen[1], round * 10 + 1);
    }
}

#ifdef __linux__
TEST(TwoWay, HelperKeepsOffTheCoreItsCallerWasOn) {
    cpu_set_t allowed;
    CPU_ZERO(&allowed);
    ASSERT_EQ(sched_getaffinity(0, sizeof allowed, &allowed), 0);
    if (CPU_COUNT(&allowed) < 2) GTEST_SKIP() << "one core";
    TwoWay split(true);
    int helper_cores = -1;
    int* out = &helper_cores;
    auto job = [out](int half) {
        if (half != 1) return;
        cpu_set_t set;
        CPU_ZERO(&set);
        if (sched_getaffinity(0, sizeof set, &set) == 0) *out = CPU_COUNT(&set);
    };
    split.run(job);
    EXPECT_EQ(helper_cores, CPU_COUNT(&allowed) - 1);
}
#endif

TEST(TwoWay, EndsItsHelperWhenDestroyed) {
    std::atomic<int> calls{0};
    for (int i = 0; i < 50; ++i) {
        TwoWay split(true);
        std::atomic<int>* c = &calls;
        auto job = [c](int) { c->fetch_add(1, std::memory_order_relaxed); };
        split.run(job);
    }  // note: each destructor joins its thread; a hang here fails by the test timeout
    EXPECT_EQ(calls.load(), 100);
}

}  // namespace
}  // namespace hmdnode::lod_detail
