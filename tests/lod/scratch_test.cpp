// The simplifiers' scratch memory (lod/src/simplify/scratch.hpp): within a ScratchScope large
// blocks come back from the caller's SimplifyScratch for the next request of the same size class,
// small ones and what passes the cap are freed; without one (no scratch, another thread) nothing is
// kept; and a simplification gives the same output with a reused scratch, a fresh one or none.
#include <cstdint>
#include <cstring>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "../../lod/src/simplify/scratch.hpp"
#include "hmdnode/lod/simplify.hpp"
#include "lod/test_meshes.hpp"

namespace hmdnode::lod_detail {
namespace {

TEST(Scratch, LargeBlocksAreReusedSmallOnesAreNot) {
    SimplifyScratch scratch;
    const ScratchScope scope(&scratch);
    const uint32_t* first = nullptr;
    {
        Scratch<uint32_t> v(300000, 7u);  // 1.2 MB: a 2 MiB block
        first = v.data();
    }
    EXPECT_EQ(scratch.cached_bytes(), size_t(2) << 20);
    {
        Scratch<uint32_t> v(400000);  // same size class: the same block
        EXPECT_EQ(v.data(), first);
        EXPECT_EQ(scratch.cached_bytes(), 0u);
    }
    const size_t with_block = scratch.cached_bytes();
    { Scratch<uint32_t> small(100); }
    EXPECT_EQ(scratch.cached_bytes(), with_block);
}

TEST(Scratch, KeepsAtMostTheCap) {
    SimplifyScratch scratch;
    {
        const ScratchScope scope(&scratch);
        std::vector<Scratch<char>> many;
        for (int i = 0; i < 12; ++i) many.emplace_back(size_t(8) << 20);  // 96 MiB in all
    }
    EXPECT_LE(scratch.cached_bytes(), kScratchKeepBytes);
    EXPECT_GT(scratch.cached_bytes(), 0u);
}

TEST(Scratch, NothingIsKeptOutsideAScopeOrOnAnotherThread) {
    SimplifyScratch scratch;
    { Scratch<char> v(size_t(1) << 20); }  // no scope
    EXPECT_EQ(scratch.cached_bytes(), 0u);
    const ScratchScope scope(&scratch);
    std::thread t([] { Scratch<char> v(size_t(1) << 20); });  // the scope is this thread's
    t.join();
    EXPECT_EQ(scratch.cached_bytes(), 0u);
    { Scratch<char> v(size_t(1) << 20); }
    EXPECT_EQ(scratch.cached_bytes(), size_t(1) << 20);
}

TEST(Scratch, SimplifyGivesTheSameMeshWithAndWithoutAScratch) {
    const Primitive sphere = test::unit_icosphere(4);
    const size_t targets[] = {sphere.triangle_count() / 4, 64};
    SimplifyScratch scratch;
    SimplifyOptions reused;
    reused.scratch = &scratch;
    for (const char* algorithm : {"qem", "melax"}) {
        auto a = simplify(sphere, algorithm, targets);
        auto b = simplify(sphere, algorithm, targets, reused);
        auto c = simplify(sphere, algorithm, targets, reused);
        ASSERT_TRUE(a.ok() && b.ok() && c.ok()) << algorithm;
        EXPECT_GT(scratch.cached_bytes(), 0u) << algorithm;
        for (const auto* other : {&*b, &*c}) {
            ASSERT_EQ(a->size(), other->size());
            for (size_t i = 0; i < a->size(); ++i) {
                const Primitive &pa = (*a)[i].primitive, &pb = (*other)[i].primitive;
                EXPECT_EQ(pa.indices, pb.indices) << algorithm << " level " << i;
                ASSERT_EQ(pa.positions.size(), pb.positions.size());
                EXPECT_EQ(0, std::memcmp(pa.positions.data(), pb.positions.data(),
                                         pa.positions.size() * sizeof(pa.positions[0])));
            }
        }
    }
}

}  // namespace
}  // namespace hmdnode::lod_detail
