#include <gtest/gtest.h>

#include <filesystem>

#include "hmdnode/hal/display/mock_display.hpp"

using namespace hmdnode;

TEST(MockDisplay, VsyncsArePeriodicAndPhotonsFollowTheScanOutModel) {
    SimulatedClock clock(0);
    MockDisplayConfig cfg;
    cfg.refresh_hz = 90.0;
    cfg.scanout_fraction = 1.0;
    cfg.persistence_ns = 2 * kNsPerMs;
    auto d = create_mock_display(clock, cfg);
    ASSERT_TRUE(d.ok());
    const int64_t period = (*d)->info().period_ns;
    EXPECT_EQ(period, 11111111);
    EXPECT_EQ((*d)->next_vsync_ns(0), period);
    EXPECT_EQ((*d)->next_vsync_ns(period - 1), period);
    EXPECT_EQ((*d)->next_vsync_ns(period), 2 * period);
    // Centre row is scanned half a period after vsync, and glows for 2 ms: +1 ms to its middle.
    EXPECT_EQ((*d)->photon_offset_ns(), period / 2 + 1 + kNsPerMs);
}

TEST(MockDisplay, LateFrameIsShownAtTheNextVsyncAndCountsAsLate) {
    SimulatedClock clock(0);
    MockDisplayConfig cfg;
    auto d = create_mock_display(clock, cfg);
    ASSERT_TRUE(d.ok());
    const int64_t period = (*d)->info().period_ns;
    clock.sleep_until_ns(period - 2 * kNsPerMs);
    auto ok = (*d)->present(nullptr, period);
    ASSERT_TRUE(ok.ok());
    EXPECT_TRUE(ok->on_time);
    EXPECT_EQ(ok->vsync_ns, period);
    EXPECT_EQ(ok->photon_time_ns, period + (*d)->photon_offset_ns());
    clock.sleep_until_ns(2 * period - cfg.latch_margin_ns + 1);  // misses the latch point
    auto late = (*d)->present(nullptr, 2 * period);
    ASSERT_TRUE(late.ok());
    EXPECT_FALSE(late->on_time);
    EXPECT_EQ(late->vsync_ns, 3 * period);
}

TEST(MockDisplay, WritesFramesAsPng) {
    SimulatedClock clock(0);
    MockDisplayConfig cfg;
    cfg.eye_width = 4;
    cfg.eye_height = 3;
    cfg.frames_dir = std::filesystem::temp_directory_path() / "hmdnode_mock_display_test";
    std::filesystem::remove_all(cfg.frames_dir);
    auto d = create_mock_display(clock, cfg);
    ASSERT_TRUE(d.ok());
    StereoImage img;
    for (int e = 0; e < 2; ++e) {
        img.eye[e].width = 4;
        img.eye[e].height = 3;
        img.eye[e].pixels.assign(4 * 3 * 4, uint8_t(e ? 200 : 50));
    }
    ASSERT_TRUE((*d)->present(&img, (*d)->next_vsync_ns(0)).ok());
    auto back = read_image(cfg.frames_dir / "frame_000000.png");
    ASSERT_TRUE(back.ok()) << back.error().message;
    EXPECT_EQ(back->width, 8);
    EXPECT_EQ(back->height, 3);
    EXPECT_EQ(back->at(1, 1)[0], 50);  // left eye on the left
    EXPECT_EQ(back->at(6, 1)[0], 200);
    std::filesystem::remove_all(cfg.frames_dir);
}

TEST(MockDisplay, RejectsBadConfiguration) {
    SimulatedClock clock(0);
    MockDisplayConfig cfg;
    cfg.refresh_hz = 0.0;
    auto d = create_mock_display(clock, cfg);
    ASSERT_FALSE(d.ok());
    EXPECT_NE(d.error().message.find("refresh"), std::string::npos);
}

TEST(MockDisplay, FeedbackNamesTheVsyncAPresentWouldLandOn) {
    SimulatedClock clock(0);
    MockDisplayConfig cfg;
    cfg.latch_margin_ns = 500'000;
    auto d = create_mock_display(clock, cfg);
    ASSERT_TRUE(d.ok());
    const int64_t period = (*d)->info().period_ns;
    EXPECT_EQ((*d)->info().latch_margin_ns, cfg.latch_margin_ns);
    // Before the latch point of the first vsync: that vsync; just after it: the next one.
    EXPECT_EQ((*d)->free_vsync_ns(period - cfg.latch_margin_ns), period);
    EXPECT_EQ((*d)->free_vsync_ns(period - cfg.latch_margin_ns + 1), 2 * period);
    // A present holds its vsync: the next present made before that vsync lands one later, and the
    // feedback says so before it is made (no loop can lock onto a vsync that is taken).
    clock.sleep_until_ns(period / 2);
    auto first = (*d)->present(nullptr, period);
    ASSERT_TRUE(first.ok());
    EXPECT_TRUE(first->on_time);
    EXPECT_EQ((*d)->free_vsync_ns(clock.now_ns()), 2 * period);
    auto second = (*d)->present(nullptr, period);  // aims at the held vsync
    ASSERT_TRUE(second.ok());
    EXPECT_EQ(second->vsync_ns, 2 * period);
    EXPECT_FALSE(second->on_time);
    // A frame presented early for a later vsync waits for it and is on time.
    auto early = (*d)->present(nullptr, 5 * period);
    ASSERT_TRUE(early.ok());
    EXPECT_EQ(early->vsync_ns, 5 * period);
    EXPECT_TRUE(early->on_time);
}
