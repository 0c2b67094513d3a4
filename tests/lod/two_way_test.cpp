// The simplifiers' two-way split (lod/src/simplify/two_way.hpp): run(f) calls f(0) on the caller
// and f(1) on the helper thread, or on the caller when it is done with f(0) before the helper
// started f(1), and returns only when both are done; without a helper both run on the caller, 0
// then 1. Many rounds in a row each see their own captures (the job is copied per round), runs
// after the helper fell asleep still hand over, and the helper's affinity leaves out its caller's
// core. Nothing here depends on when a thread gets a core (a loaded 2-core CI box): the tests
// assert results, and which thread ran a half only where the test itself forces it.
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

#include "../../lod/src/simplify/two_way.hpp"

namespace hmdnode::lod_detail {
namespace {

TEST(TwoWay, HelperRunsTheSecondHalfAndRunWaitsForIt) {
    // note: the first half waits until the second has begun, so the caller cannot claim the
    // second (it claims only after its own): the helper must run it, whenever it gets a core. No
    // timing is asserted; the sums prove that both halves wrote before run() returned.
    TwoWay split(true);
    ASSERT_TRUE(split.has_helper());
    const std::thread::id caller = std::this_thread::get_id();
    std::array<std::thread::id, 2> ran_on{};
    std::vector<uint64_t> sums(400, 0);
    std::atomic<uint32_t> started{0};  // the last round whose second half began
    for (uint32_t round = 0; round < 200; ++round) {
        uint64_t* out = sums.data() + 2 * round;
        std::thread::id* ids = ran_on.data();
        std::atomic<uint32_t>* began = &started;
        auto job = [out, ids, round, began](int half) {
            if (half == 1) {
                began->store(round + 1, std::memory_order_release);
            } else {
                while (began->load(std::memory_order_acquire) != round + 1)
                    std::this_thread::yield();
            }
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
        ASSERT_EQ(ran_on[0], caller) << "round " << round;
        ASSERT_NE(ran_on[1], caller) << "round " << round;
    }
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
    // note: the helper sleeps on a futex between runs; each run wakes it.
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

TEST(TwoWay, EachHalfRunsExactlyOnceWhicheverThreadClaimsIt) {
    // note: the caller claims the second half when the helper has not started it yet (after 3 ms
    // the helper sleeps on its futex and takes tens of microseconds to wake, an empty first half
    // ends long before); either thread may win, on a loaded machine either way. Whichever does,
    // each half runs exactly once and both are done when run() returns.
    TwoWay split(true);
    for (int round = 1; round <= 20; ++round) {
        if (round % 2 == 0) std::this_thread::sleep_for(std::chrono::milliseconds(3));
        std::array<std::atomic<int>, 2> calls{};
        std::array<int, 2> seen{};
        auto* c = &calls;
        int* out = seen.data();
        auto job = [c, out, round](int half) {
            (*c)[half].fetch_add(1, std::memory_order_relaxed);
            out[half] = round * 10 + half;
        };
        split.run(job);
        ASSERT_EQ(calls[0].load(), 1) << "round " << round;
        ASSERT_EQ(calls[1].load(), 1) << "round " << round;
        ASSERT_EQ(seen[0], round * 10) << "round " << round;
        ASSERT_EQ(seen[1], round * 10 + 1) << "round " << round;
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
    std::atomic<bool> second_done{false};
    std::atomic<bool>* done = &second_done;
    auto job = [out, done](int half) {
        if (half == 0) {
            // note: the caller stays in its half until the helper has run the other one
            while (!done->load(std::memory_order_acquire)) std::this_thread::yield();
            return;
        }
        cpu_set_t set;
        CPU_ZERO(&set);
        if (sched_getaffinity(0, sizeof set, &set) == 0) *out = CPU_COUNT(&set);
        done->store(true, std::memory_order_release);
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
