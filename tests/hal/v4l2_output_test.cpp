// The V4L2 output backend's errors where there is no output device (a missing node, a file that
// is not a V4L2 device), the camera backend's new set-up steps failing the same way, and the
// RGBA to YUYV conversion against BT.601's closed forms. Real output streaming, looped back
// through vivid to its capture device, is proven in the kernel lane.
#include <gtest/gtest.h>

#include "hmdnode/hal/camera.hpp"
#include "hmdnode/hal/camera/v4l2_output.hpp"
#include "hmdnode/hal/camera/yuyv.hpp"

namespace hmdnode {
namespace {

TEST(V4l2Output, MissingDeviceIsAClearErrorNamingIt) {
    V4l2OutputConfig cfg;
    cfg.device = "/dev/video-hmdnode-missing-output";
    auto out = open_v4l2_output(cfg);
    ASSERT_FALSE(out.ok());
    const std::string& m = out.error().message;
    EXPECT_NE(m.find("/dev/video-hmdnode-missing-output: cannot open"), std::string::npos) << m;
    EXPECT_NE(m.find("ENOENT"), std::string::npos) << m;
}

TEST(V4l2Output, AFileThatIsNotAV4l2DeviceIsRefusedNamingTheIoctl) {
    V4l2OutputConfig cfg;
    cfg.device = "/dev/null";
    auto out = open_v4l2_output(cfg);
    ASSERT_FALSE(out.ok());
    const std::string& m = out.error().message;
    EXPECT_NE(m.find("/dev/null: not a V4L2 device (VIDIOC_QUERYCAP"), std::string::npos) << m;
}

TEST(V4l2Camera, InputControlsAndTimingsDoNotHideTheOpenError) {
    V4l2CameraConfig cfg;
    cfg.device = "/dev/null";
    cfg.input = 1;
    cfg.controls = {{"Loop Video", 1}};
    cfg.dv_timings = true;
    auto cam = open_v4l2_camera(cfg);
    ASSERT_FALSE(cam.ok());
    EXPECT_NE(cam.error().message.find("/dev/null: not a V4L2 device"), std::string::npos)
        << cam.error().message;
}

ImageRGBA8 image_of(int w, int h, std::initializer_list<std::array<uint8_t, 3>> rgb) {
    ImageRGBA8 img;
    img.width = w;
    img.height = h;
    for (const auto& p : rgb) img.pixels.insert(img.pixels.end(), {p[0], p[1], p[2], 255});
    return img;
}

TEST(Yuyv, BlackWhiteAndPrimariesAreBt601LimitedRange) {
    // One row: white, black, red, green, blue, grey 128.
    const ImageRGBA8 img = image_of(
        6, 1, {{255, 255, 255}, {0, 0, 0}, {255, 0, 0}, {0, 255, 0}, {0, 0, 255}, {128, 128, 128}});
    std::vector<uint8_t> bytes(6 * 2);
    const YuyvFrameView f{bytes, 6, 1, 12};
    write_rgba_to_yuyv(img, 0, 0, f);
    // Y = ((66 R + 129 G + 25 B + 128) >> 8) + 16.
    EXPECT_EQ(bytes[0], 235);   // white
    EXPECT_EQ(bytes[2], 16);    // black
    EXPECT_EQ(bytes[4], 82);    // red: (16830 + 128) >> 8 = 66, + 16
    EXPECT_EQ(bytes[6], 144);   // green: (32895 + 128) >> 8 = 128, + 16
    EXPECT_EQ(bytes[8], 41);    // blue: (6375 + 128) >> 8 = 25, + 16
    EXPECT_EQ(bytes[10], 126);  // grey: (28160 + 128) >> 8 = 110, + 16
    // The white/black pair's chroma is that of their mean (128, 128, 128): neutral.
    EXPECT_EQ(bytes[1], 128);
    EXPECT_EQ(bytes[3], 128);
    // Red and green: mean (128, 128, 0): U = ((-38 - 74) 128 + 128) >> 8 = -56 -> 72,
    // V = ((112 - 94) 128 + 128) >> 8 = 9 -> 137.
    EXPECT_EQ(bytes[5], 72);
    EXPECT_EQ(bytes[7], 137);
}

TEST(Yuyv, PlacedAndClippedOnABlackFrame) {
    std::vector<uint8_t> bytes(8 * 2 * 3, 0xAA);
    const YuyvFrameView f{bytes, 8, 3, 16};
    fill_yuyv_black(f);
    for (size_t i = 0; i < bytes.size(); ++i) ASSERT_EQ(bytes[i], i % 2 ? 128 : 16) << i;
    // A 4x2 white image at (6, 2): only its top-left 2x1 lands.
    ImageRGBA8 white;
    white.width = 4;
    white.height = 2;
    white.pixels.assign(4 * 2 * 4, 255);
    write_rgba_to_yuyv(white, 6, 2, f);
    for (uint32_t y = 0; y < 3; ++y)
        for (uint32_t x = 0; x < 8; ++x)
            EXPECT_EQ(bytes[y * 16 + 2 * x], (y == 2 && x >= 6) ? 235 : 16) << x << "," << y;
}

}  // namespace
}  // namespace hmdnode
