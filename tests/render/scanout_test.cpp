// Zero-copy scan-out's pure parts (render/scanout.hpp, render/src/scanout_ring.hpp): the format and
// modifiers chosen from what a KMS plane lists, the ring's bookkeeping of which GBM buffer object
// the warp may draw into, and the errors when there is no DRM device to render on (this machine
// has no /dev/dri; the real path runs in the kernel lane, docs/hardware.md).
#include <fcntl.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <set>
#include <string>
#include <vector>

#include "../../render/src/scanout_ring.hpp"
#include "hmdnode/render/renderer.hpp"
#include "hmdnode/render/scanout.hpp"

using namespace hmdnode;
using gpu::ScanoutRing;
using State = ScanoutRing::State;

namespace {

constexpr uint32_t kXR24 = 0x34325258;  // 'X' 'R' '2' '4'
constexpr uint32_t kAR24 = 0x34325241;
constexpr uint32_t kXB24 = 0x34324258;
constexpr uint32_t kNV12 = 0x3231564e;
constexpr uint64_t kTiled = 0x0100000000000002ull;  // I915_FORMAT_MOD_Y_TILED

}  // namespace

TEST(ScanoutFormat, FourccText) {
    EXPECT_EQ(fourcc_text(kXR24), "XR24");
    EXPECT_EQ(fourcc_text(kNV12), "NV12");
    EXPECT_EQ(fourcc_text(0x00015258), "XR??");
}

TEST(ScanoutFormat, PlaneWithoutInFormatsTakesXrgbImplicit) {
    // A plane without IN_FORMATS: its formats with the implicit layout; XRGB8888 wins over ARGB.
    auto a = choose_scanout_allocation(
        {{kAR24, kDrmModInvalid}, {kXR24, kDrmModInvalid}, {kNV12, kDrmModInvalid}}, "card0");
    ASSERT_TRUE(a.ok()) << a.error().message;
    EXPECT_EQ(a->fourcc, kXR24);
    EXPECT_TRUE(a->modifiers.empty());
    EXPECT_TRUE(a->implicit_ok);
}

TEST(ScanoutFormat, ExplicitModifiersArePassedOnAndLinearAllowsImplicit) {
    // bochs-drm and virtio-gpu list LINEAR only; a GPU lists tiled layouts beside it.
    auto a = choose_scanout_allocation(
        {{kXR24, kTiled}, {kXR24, kDrmModLinear}, {kAR24, kDrmModLinear}}, "/dev/dri/card0");
    ASSERT_TRUE(a.ok());
    EXPECT_EQ(a->fourcc, kXR24);
    EXPECT_EQ(a->modifiers, (std::vector<uint64_t>{kTiled, kDrmModLinear}));
    EXPECT_TRUE(a->implicit_ok);
    // Tiled only: the allocator must use the modifier (no implicit fallback).
    auto t = choose_scanout_allocation({{kXB24, kTiled}}, "/dev/dri/card0");
    ASSERT_TRUE(t.ok());
    EXPECT_EQ(t->fourcc, kXB24);
    EXPECT_EQ(t->modifiers, std::vector<uint64_t>{kTiled});
    EXPECT_FALSE(t->implicit_ok);
}

TEST(ScanoutFormat, NoRgbFormatIsAnErrorNamingTheDeviceAndTheOffer) {
    auto a = choose_scanout_allocation({{kNV12, kDrmModLinear}}, "/dev/dri/card1");
    ASSERT_FALSE(a.ok());
    EXPECT_NE(a.error().message.find("/dev/dri/card1"), std::string::npos) << a.error().message;
    EXPECT_NE(a.error().message.find("NV12:0x0"), std::string::npos) << a.error().message;
    auto none = choose_scanout_allocation({}, "/dev/dri/card1");
    ASSERT_FALSE(none.ok());
    EXPECT_NE(none.error().message.find("offered: none"), std::string::npos);
}

TEST(ScanoutRing, ThreeBuffersAlwaysLeaveOneToDrawInto) {
    // The display's discipline: each present commits the newest drawn buffer after the flip
    // before it completed. Over many frames the warp never draws into the shown or queued buffer.
    ScanoutRing ring(3);
    int shown = -1, queued = -1;
    std::set<int> used;
    for (int frame = 0; frame < 30; ++frame) {
        const int b = ring.acquire();
        ASSERT_GE(b, 0) << "frame " << frame;
        EXPECT_NE(b, shown);
        EXPECT_NE(b, queued);
        used.insert(b);
        ring.finish(b);
        EXPECT_EQ(ring.drawn(), b);
        ring.commit(b);
        shown = queued;
        queued = b;
        EXPECT_EQ(ring.state(b), State::queued);
        if (shown >= 0) {
            EXPECT_EQ(ring.state(shown), State::shown);
        }
        EXPECT_EQ(ring.drawn(), -1);
    }
    EXPECT_EQ(used.size(), 3u);  // round robin over the ring
}

TEST(ScanoutRing, RedrawsWithoutCommitSupersedeAndAbandonedDrawsAreFreed) {
    ScanoutRing ring(3);
    // Warps with no present in between (the node's warp-cost calibration): the newest drawn one
    // is what a present would flip; an older drawn one is free again.
    const int a = ring.acquire();
    ring.finish(a);
    const int b = ring.acquire();
    EXPECT_NE(a, b);
    ring.finish(b);
    EXPECT_EQ(ring.drawn(), b);
    EXPECT_EQ(ring.state(a), State::free);
    // A warp that failed between acquire and finish leaves nothing drawing.
    const int c = ring.acquire();
    EXPECT_EQ(ring.state(c), State::drawing);
    const int d = ring.acquire();
    EXPECT_EQ(ring.state(c), c == d ? State::drawing : State::free);
    EXPECT_EQ(ring.drawn(), b);
}

TEST(ScanoutRing, WhenShownAndQueuedHoldAllButOneTheDrawnOneIsReused) {
    ScanoutRing ring(3);
    for (int i = 0; i < 2; ++i) {  // one shown, one queued
        const int b = ring.acquire();
        ring.finish(b);
        ring.commit(b);
    }
    const int drawn = ring.acquire();
    ring.finish(drawn);
    // Shown + queued + drawn: the next warp overwrites the drawn one (never committed).
    EXPECT_EQ(ring.acquire(), drawn);
    // With only two buffers, both held by the display, there is nothing to draw into.
    ScanoutRing two(2);
    for (int i = 0; i < 2; ++i) {
        const int b = two.acquire();
        two.finish(b);
        two.commit(b);
    }
    EXPECT_EQ(two.acquire(), -1);
}

TEST(ScanoutRenderer, VulkanRefusesScanOutNamingTheGlesBackend) {
    RendererConfig rc;
    rc.backend = "vulkan";
    rc.eye_width = rc.eye_height = 8;
    rc.scanout = ScanoutTargetInfo{};
    auto r = create_renderer(rc);
    ASSERT_FALSE(r.ok());
    EXPECT_NE(r.error().message.find("gles"), std::string::npos) << r.error().message;
}

TEST(ScanoutRenderer, GlesOnAFileThatIsNoDrmDeviceIsAnErrorNamingIt) {
    const int fd = open("/dev/null", O_RDWR | O_CLOEXEC);
    ASSERT_GE(fd, 0);
    RendererConfig rc;
    rc.backend = "gles";
    rc.eye_width = rc.eye_height = 8;
    rc.scanout = ScanoutTargetInfo{fd, "/dev/null", 16, 8, {{kXR24, kDrmModInvalid}}};
    auto r = create_renderer(rc);
    close(fd);
    // (Mesa's GBM falls back to kms_swrast there; its first dumb buffer fails.)
    ASSERT_FALSE(r.ok()) << "rendered for scan-out on /dev/null?";
    EXPECT_NE(r.error().message.find("/dev/null"), std::string::npos) << r.error().message;
}
