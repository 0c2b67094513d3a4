// Keeping the cores awake (firmware_host/cpu_wake.hpp): the spinning threads are idle-class, one
// pinned to each core the process may use, and gone with the guard; PM QoS, where this process may
// hold it, reads back as 0 us while held and as the kernel's default after; auto picks the lever
// by the presence of a cpuidle driver.
#include <gtest/gtest.h>
#include <sched.h>
#include <unistd.h>

#include <cstdint>
#include <filesystem>
#include <fstream>

#include "hmdnode/firmware_host/cpu_wake.hpp"

using namespace hmdnode;

namespace {

size_t allowed_cores() {
    cpu_set_t s;
    CPU_ZERO(&s);
    EXPECT_EQ(sched_getaffinity(0, sizeof s, &s), 0);
    return size_t(CPU_COUNT(&s));
}

// The system-wide PM QoS CPU latency target (us): reading /dev/cpu_dma_latency gives it as 32
// bits; nullopt where the file cannot be read (not root, or no such file).
std::optional<int32_t> qos_target_us() {
    std::ifstream in("/dev/cpu_dma_latency", std::ios::binary);
    int32_t v = 0;
    if (!in.read(reinterpret_cast<char*>(&v), sizeof v)) return std::nullopt;
    return v;
}

}  // namespace

TEST(CpuWake, NamesRoundTripAndOthersAreRefused) {
    for (CpuWake w : {CpuWake::off, CpuWake::automatic, CpuWake::qos, CpuWake::spin})
        EXPECT_EQ(parse_cpu_wake(cpu_wake_name(w)), w);
    EXPECT_EQ(parse_cpu_wake("poll"), std::nullopt);
    EXPECT_EQ(parse_cpu_wake(""), std::nullopt);
}

TEST(CpuWake, OffHoldsNothingAndStartsNoThread) {
    std::unique_ptr<CpuWakeGuard> g = CpuWakeGuard::start(CpuWake::off);
    EXPECT_EQ(g->spinning_threads(), 0u);
    EXPECT_FALSE(g->qos_held());
    EXPECT_EQ(g->description(), "off");
}

TEST(CpuWake, SpinningThreadsAreIdleClassOnePerCoreAndGoWithTheGuard) {
    std::vector<int> tids;
    {
        std::unique_ptr<CpuWakeGuard> g = CpuWakeGuard::start(CpuWake::spin);
        ASSERT_EQ(g->spinning_threads(), allowed_cores()) << g->description();
        tids = g->spinner_tids();
        std::vector<int> cores;
        for (int tid : tids) {
            // A thread of this process (its id under /proc/self/task).
            EXPECT_TRUE(std::filesystem::exists("/proc/self/task/" + std::to_string(tid))) << tid;
            // The idle class: the scheduler runs it only when nothing else wants the core.
            EXPECT_EQ(sched_getscheduler(tid), SCHED_IDLE) << tid;
            // Pinned to one core (the spinner pins itself right after taking the idle class).
            cpu_set_t s;
            CPU_ZERO(&s);
            for (int tries = 0; tries < 1000; ++tries) {
                ASSERT_EQ(sched_getaffinity(tid, sizeof s, &s), 0);
                if (CPU_COUNT(&s) == 1) break;
                usleep(1000);
            }
            ASSERT_EQ(CPU_COUNT(&s), 1) << tid;
            for (int c = 0; c < CPU_SETSIZE; ++c)
                if (CPU_ISSET(c, &s)) cores.push_back(c);
        }
        std::sort(cores.begin(), cores.end());
        EXPECT_EQ(std::unique(cores.begin(), cores.end()), cores.end()) << "two on one core";
        EXPECT_NE(g->description().find("spinning on"), std::string::npos) << g->description();
    }
    // Joined with the guard: none of them is a thread of this process any more. (Counting all
    // threads would not do: a sanitizer's runtime starts threads of its own at any time.)
    for (int tid : tids)
        EXPECT_FALSE(std::filesystem::exists("/proc/self/task/" + std::to_string(tid))) << tid;
}

TEST(CpuWake, PmQosReadsBackAsZeroWhileHeldAndAsBeforeAfter) {
    const std::optional<int32_t> before = qos_target_us();
    std::unique_ptr<CpuWakeGuard> g = CpuWakeGuard::start(CpuWake::qos);
    EXPECT_EQ(g->spinning_threads(), 0u);
    if (!g->qos_held()) {
        // Not root, or no PM QoS device: the guard says why and holds nothing.
        EXPECT_NE(g->description().find("PM QoS not held"), std::string::npos) << g->description();
        GTEST_SKIP() << g->description();
    }
    ASSERT_TRUE(before.has_value());
    EXPECT_EQ(qos_target_us(), 0);
    g.reset();
    EXPECT_EQ(qos_target_us(), before);
}

TEST(CpuWake, AutoSpinsWhereThereIsNoCpuidleDriverAndAsksPmQosWhereThereIsOne) {
    std::unique_ptr<CpuWakeGuard> g = CpuWakeGuard::start(CpuWake::automatic);
    if (has_cpuidle_driver()) {
        EXPECT_EQ(g->spinning_threads(), 0u) << g->description();
        EXPECT_NE(g->description().find("PM QoS"), std::string::npos) << g->description();
    } else {
        EXPECT_EQ(g->spinning_threads(), allowed_cores()) << g->description();
        EXPECT_NE(g->description().find("no cpuidle driver"), std::string::npos)
            << g->description();
    }
}
