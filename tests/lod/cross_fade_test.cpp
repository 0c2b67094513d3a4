// LodCrossFade: a visible level change becomes N frames drawing both levels with complementary
// dithers (the new level's share rising), never a one-frame jump; with N = 0 every visible change
// is a pop; objects coming into view never pop.
#include <gtest/gtest.h>

#include "hmdnode/lod/cross_fade.hpp"

using namespace hmdnode;

TEST(LodCrossFade, AVisibleChangeDrawsBothLevelsWithComplementaryRisingMasks) {
    LodCrossFade fade(1, 3);
    LodFadeStep s = fade.update(0, 2);
    EXPECT_EQ(s.count, 1);
    EXPECT_EQ(s.draws[0].level, 2);
    EXPECT_EQ(s.draws[0].dither, 0);
    EXPECT_FALSE(s.started || s.popped);  // first appearance: nothing to pop
    s = fade.update(0, 1);
    EXPECT_TRUE(s.started);
    int last_k = 0;
    for (int frame = 1; frame <= 3; ++frame) {
        if (frame > 1) s = fade.update(0, 1);
        ASSERT_EQ(s.count, 2) << frame;
        EXPECT_EQ(s.draws[0].level, 1);
        EXPECT_EQ(s.draws[1].level, 2);
        EXPECT_EQ(s.draws[1].dither, -s.draws[0].dither);  // complementary masks
        EXPECT_GT(s.draws[0].dither, last_k);              // the new level's share rises
        last_k = s.draws[0].dither;
        EXPECT_FALSE(s.popped);
    }
    EXPECT_EQ(last_k, 12);  // 3/4 of 16
    s = fade.update(0, 1);
    EXPECT_EQ(s.count, 1);
    EXPECT_EQ(s.draws[0].level, 1);
    EXPECT_EQ(s.draws[0].dither, 0);
}

TEST(LodCrossFade, WithoutTransitionsEveryVisibleChangeIsAPop) {
    LodCrossFade fade(2, 0);
    fade.update(0, 0);
    fade.update(1, 0);
    int pops = 0;
    for (int f = 1; f <= 10; ++f) {
        LodFadeStep s = fade.update(0, f % 2);
        EXPECT_EQ(s.count, 1);
        pops += s.popped;
        pops += fade.update(1, 0).popped;  // never changes
    }
    EXPECT_EQ(pops, 10);
}

TEST(LodCrossFade, ALevelWantedDuringATransitionWaitsForItsEnd) {
    LodCrossFade fade(1, 2);
    fade.update(0, 0);
    EXPECT_TRUE(fade.update(0, 1).started);
    LodFadeStep s = fade.update(0, 2);  // step 2 of 0 -> 1 still
    EXPECT_EQ(s.count, 2);
    EXPECT_EQ(s.draws[0].level, 1);
    EXPECT_EQ(s.draws[1].level, 0);
    s = fade.update(0, 2);  // 0 -> 1 done: 1 -> 2 starts at once
    EXPECT_TRUE(s.started);
    EXPECT_EQ(s.draws[0].level, 2);
    EXPECT_EQ(s.draws[1].level, 1);
}

TEST(LodCrossFade, AnObjectComingBackIntoViewTakesItsLevelWithoutAPop) {
    for (int frames : {0, 3}) {
        LodCrossFade fade(1, frames);
        fade.update(0, 0);
        fade.hide(0);
        LodFadeStep s = fade.update(0, 3);
        EXPECT_FALSE(s.popped || s.started);
        EXPECT_EQ(s.count, 1);
        EXPECT_EQ(s.draws[0].level, 3);
    }
}

TEST(LodCrossFade, StepsSpreadOverTheDitherTile) {
    LodCrossFade fade(1, 50);  // clamped to 15: one rank per frame
    EXPECT_EQ(fade.fade_frames(), kMaxLodFadeFrames);
    for (int s = 1; s <= kMaxLodFadeFrames; ++s) EXPECT_EQ(fade.dither_of_step(s), s);
    LodCrossFade one(1, 1);
    EXPECT_EQ(one.dither_of_step(1), 8);  // half and half
}
