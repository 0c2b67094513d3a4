// The simplifiers' per-thread scratch cache (lod/src/scratch.hpp): large blocks come back for the
// next request of the same size class, small ones and what passes the cap are freed, each thread
// has its own, and a simplification run twice in one thread gives the same output.
#include <cstdint>
#include <cstring>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "../../lod/src/scratch.hpp"
#include "hmdnode/lod/simplify.hpp"
#include "lod/test_meshes.hpp"

namespace hmdnode::lod_detail {
namespace {

TEST(Scratch, LargeBlocksAreReusedSmallOnesAreNot) {
    const size_t before = scratch_cached_bytes();
    const uint32_t* first = nullptr;
    {
        Scratch<uint32_t> v(300000, 7u);  // 1.2 MB: a 2 MiB block
        first = v.data();
    }
    EXPECT_EQ(scratch_cached_bytes(), before + (size_t(2) << 20));
    {
        Scratch<uint32_t> v(400000);  // same size class: the same block
        EXPECT_EQ(v.data(), first);
        EXPECT_EQ(scratch_cached_bytes(), before);
    }
    const size_t with_block = scratch_cached_bytes();
    { Scratch<uint32_t> small(100); }
    EXPECT_EQ(scratch_cached_bytes(), with_block);
}

TEST(Scratch, KeepsAtMostTheCap) {
    {
        std::vector<Scratch<char>> many;
        for (int i = 0; i < 12; ++i) many.emplace_back(size_t(8) << 20);  // 96 MiB in all
    }
    EXPECT_LE(scratch_cached_bytes(), kScratchKeepBytes);
    EXPECT_GT(scratch_cached_bytes(), 0u);
}

TEST(Scratch, EachThreadHasItsOwn) {
    { Scratch<char> v(size_t(1) << 20); }
    size_t in_thread_before = 1, in_thread_after = 0;
    std::thread t([&] {
        in_thread_before = scratch_cached_bytes();
        { Scratch<char> v(size_t(1) << 20); }
        in_thread_after = scratch_cached_bytes();
    });
    t.join();
    EXPECT_EQ(in_thread_before, 0u);
    EXPECT_EQ(in_thread_after, size_t(1) << 20);
}

TEST(Scratch, SimplifyingTwiceInOneThreadGivesTheSameMesh) {
    const Primitive sphere = test::unit_icosphere(4);
    const size_t targets[] = {sphere.triangle_count() / 4, 64};
    for (const char* algorithm : {"qem", "melax"}) {
        auto a = simplify(sphere, algorithm, targets);
        auto b = simplify(sphere, algorithm, targets);
        ASSERT_TRUE(a.ok() && b.ok()) << algorithm;
        ASSERT_EQ(a->size(), b->size());
        for (size_t i = 0; i < a->size(); ++i) {
            const Primitive &pa = (*a)[i].primitive, &pb = (*b)[i].primitive;
            EXPECT_EQ(pa.indices, pb.indices) << algorithm << " level " << i;
            ASSERT_EQ(pa.positions.size(), pb.positions.size());
            EXPECT_EQ(0, std::memcmp(pa.positions.data(), pb.positions.data(),
                                     pa.positions.size() * sizeof(pa.positions[0])));
        }
    }
}

}  // namespace
}  // namespace hmdnode::lod_detail
