// display.type "vk-display" pacing (firmware_host/src/runtime/vk_display_pacing.cpp) against a
// fake VK_KHR_display output on a simulated clock: a FIFO display whose vsyncs run 3 ms off the
// grid the pacing starts with. With present_wait the pacing re-anchors on the vsync each present
// returned at, so frames sent for free vsyncs are on time; a late frame counts for the vsync it
// showed at; without present_wait the send time decides; the output's errors pass through.
#include <gtest/gtest.h>

#include "hmdnode/core/time.hpp"
#include "runtime/vk_display_pacing.hpp"

using namespace hmdnode;

namespace {

constexpr int64_t kMs = 1'000'000;
constexpr int64_t kPeriod = 10 * kMs;  // 100 Hz
constexpr int64_t kPhase = 3 * kMs;    // the display's vsyncs: 3, 13, 23, ... ms

class FakeOutput final : public VulkanDisplayOutput {
  public:
    FakeOutput(SimulatedClock& clock, bool wait) : clock_(clock), wait_(wait) {
        info_.name = "Fake HMD";
        info_.gpu = "Fake GPU";
        info_.modes = {{200, 100, 100.0}};
    }
    const VulkanDisplayInfo& display() const override { return info_; }
    VulkanDisplayMode mode() const override { return info_.modes[0]; }
    bool present_wait() const override { return wait_; }
    std::string describe() const override { return "fake"; }
    Status present(const ImageRGBA8& image) override {
        ++presents;
        if (fail) return make_error("vk-display: the display \"Fake HMD\" was lost");
        EXPECT_EQ(image.width, 200);
        EXPECT_EQ(image.height, 100);
        // FIFO: the first vsync after now and after the image before it.
        const int64_t rel = clock_.now_ns() - kPhase;
        int64_t v = kPhase + (rel < 0 ? 0 : rel / kPeriod + 1) * kPeriod;
        if (v <= shown_ns) v = shown_ns + kPeriod;
        shown_ns = v;
        if (wait_) clock_.sleep_until_ns(v);
        return {};
    }
    int presents = 0;
    bool fail = false;
    int64_t shown_ns = 0;

  private:
    SimulatedClock& clock_;
    bool wait_;
    VulkanDisplayInfo info_;
};

StereoImage frame() {
    StereoImage f;
    for (ImageRGBA8& e : f.eye) {
        e.width = 100;
        e.height = 100;
        e.pixels.assign(100 * 100 * 4, 128);
    }
    return f;
}

}  // namespace

TEST(VkDisplayPacing, PresentWaitReanchorsOnTheShownVsync) {
    SimulatedClock clock(0);
    auto fake = std::make_unique<FakeOutput>(clock, true);
    FakeOutput* out = fake.get();
    auto d = make_vk_display_pacing(clock, std::move(fake), 1 * kMs, 2 * kMs);
    const DisplayInfo info = d->info();
    EXPECT_EQ(info.eye_width, 100);
    EXPECT_EQ(info.eye_height, 100);
    EXPECT_EQ(info.period_ns, kPeriod);
    EXPECT_EQ(info.name, "vk-display Fake HMD on Fake GPU");
    const StereoImage f = frame();
    // The first present shows at the display's first vsync (3 ms); the grid moves there.
    auto r = d->present(&f, d->free_vsync_ns(clock.now_ns()));
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_EQ(clock.now_ns(), kPhase);
    EXPECT_EQ(d->next_vsync_ns(clock.now_ns()), kPhase + kPeriod);
    // Then every frame sent for the free vsync is shown at it.
    for (int i = 0; i < 20; ++i) {
        const int64_t target = d->free_vsync_ns(clock.now_ns() + 4 * kMs);  // 4 ms of rendering
        clock.sleep_until_ns(clock.now_ns() + 4 * kMs);
        r = d->present(&f, target);
        ASSERT_TRUE(r.ok()) << r.error().message;
        EXPECT_TRUE(r->on_time) << i;
        EXPECT_EQ(r->vsync_ns, out->shown_ns) << i;
        EXPECT_EQ(r->photon_time_ns, r->vsync_ns + kPeriod / 2 + 1 * kMs);
    }
    // A frame that misses its latch point is shown a vsync later and counted late.
    const int64_t target = d->free_vsync_ns(clock.now_ns());
    clock.sleep_until_ns(target + 1 * kMs);
    r = d->present(&f, target);
    ASSERT_TRUE(r.ok());
    EXPECT_FALSE(r->on_time);
    EXPECT_EQ(r->vsync_ns, target + kPeriod);
    EXPECT_EQ(r->vsync_ns, out->shown_ns);
}

TEST(VkDisplayPacing, WithoutPresentWaitTheSendTimeDecides) {
    SimulatedClock clock(0);
    auto fake = std::make_unique<FakeOutput>(clock, false);
    auto d = make_vk_display_pacing(clock, std::move(fake), 1 * kMs, 0);
    const StereoImage f = frame();
    // Sent early: held until one period before the target, then counted for it.
    auto r = d->present(&f, 5 * kPeriod);
    ASSERT_TRUE(r.ok());
    EXPECT_EQ(clock.now_ns(), 4 * kPeriod);
    EXPECT_TRUE(r->on_time);
    // Sent after the target's latch point: the next vsync.
    clock.sleep_until_ns(6 * kPeriod - kMs / 2);
    r = d->present(&f, 6 * kPeriod);
    ASSERT_TRUE(r.ok());
    EXPECT_FALSE(r->on_time);
    EXPECT_EQ(r->vsync_ns, 7 * kPeriod);
}

TEST(VkDisplayPacing, OutputErrorsPassThroughAndNoImageIsTimingOnly) {
    SimulatedClock clock(0);
    auto fake = std::make_unique<FakeOutput>(clock, true);
    FakeOutput* out = fake.get();
    auto d = make_vk_display_pacing(clock, std::move(fake), 1 * kMs, 0);
    auto r = d->present(nullptr, d->free_vsync_ns(clock.now_ns()));
    ASSERT_TRUE(r.ok());
    EXPECT_EQ(out->presents, 0);
    out->fail = true;
    const StereoImage f = frame();
    r = d->present(&f, d->free_vsync_ns(clock.now_ns()));
    ASSERT_FALSE(r.ok());
    EXPECT_NE(r.error().message.find("was lost"), std::string::npos) << r.error().message;
}
