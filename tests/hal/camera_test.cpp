// The simulated camera (test pattern, frame times on the clock, timeouts) and the V4L2 backend's
// errors when there is no camera. Real V4L2 streaming is proven in the kernel lane (vivid).
#include <gtest/gtest.h>

#include "hmdnode/hal/camera.hpp"

namespace hmdnode {
namespace {

TEST(SimCamera, FramesCarryThePatternAndExactTimes) {
    SimulatedClock clock(7 * kNsPerSecond);
    SimCameraConfig cfg;
    cfg.width = 64;
    cfg.height = 16;
    cfg.fps = 30.0;
    auto cam = create_sim_camera(clock, cfg);
    EXPECT_FALSE(cam->next_frame(0).ok());  // before start
    ASSERT_TRUE(cam->start().ok());
    for (uint64_t k = 0; k < 90; ++k) {
        auto f = cam->next_frame(100);
        ASSERT_TRUE(f.ok()) << f.error().message;
        ASSERT_TRUE(f->has_value());
        const CameraFrame& fr = **f;
        EXPECT_EQ(fr.sequence, k);
        EXPECT_EQ(fr.host_time_ns, 7 * kNsPerSecond + s_to_ns(k / 30.0));
        ASSERT_EQ(fr.bytes.size(), 64u * 16u);
        EXPECT_EQ(fr.fourcc, kFourccGrey);
        EXPECT_EQ(fr.bytes[5 * 64 + 9], static_cast<uint8_t>((9 + 10 + 4 * k) & 0xff));
        EXPECT_EQ(fr.bytes[15 * 64 + 63], sim_camera_pattern(63, 15, k));
    }
    // 90 frames at 30 fps: the clock stands at frame 89's time.
    EXPECT_EQ(clock.now_ns(), 7 * kNsPerSecond + s_to_ns(89 / 30.0));
}

TEST(SimCamera, TimesOutBetweenFramesAndDoesYuyv) {
    SimulatedClock clock(0);
    SimCameraConfig cfg;
    cfg.width = 8;
    cfg.height = 2;
    cfg.fps = 10.0;
    cfg.fourcc = kFourccYuyv;
    auto cam = create_sim_camera(clock, cfg);
    ASSERT_TRUE(cam->start().ok());
    ASSERT_TRUE(cam->next_frame(0)->has_value());  // frame 0 at t = 0
    auto none = cam->next_frame(40);               // frame 1 is due at 100 ms
    ASSERT_TRUE(none.ok());
    EXPECT_FALSE(none->has_value());
    EXPECT_EQ(clock.now_ns(), 40 * kNsPerMs);
    auto f = cam->next_frame(100);
    ASSERT_TRUE(f.ok() && f->has_value());
    EXPECT_EQ((*f)->host_time_ns, 100 * kNsPerMs);
    EXPECT_EQ((*f)->bytes_per_line, 16u);
    EXPECT_EQ((*f)->bytes[2 * 3], sim_camera_pattern(3, 0, 1));
    EXPECT_EQ((*f)->bytes[2 * 2 + 1], 128);  // U
    EXPECT_EQ((*f)->bytes[2 * 3 + 1], 1);    // V = sequence
    EXPECT_EQ(fourcc_to_string(kFourccYuyv), "YUYV");
}

TEST(V4l2Camera, MissingDeviceIsAClearErrorNamingIt) {
    V4l2CameraConfig cfg;
    cfg.device = "/dev/video-hmdnode-missing";
    auto cam = open_v4l2_camera(cfg);
    ASSERT_FALSE(cam.ok());
    EXPECT_NE(cam.error().message.find("/dev/video-hmdnode-missing"), std::string::npos);
    EXPECT_NE(cam.error().message.find("ENOENT"), std::string::npos) << cam.error().message;
}

TEST(V4l2Camera, AFileThatIsNotACameraIsRefused) {
    V4l2CameraConfig cfg;
    cfg.device = "/dev/null";
    auto cam = open_v4l2_camera(cfg);
    ASSERT_FALSE(cam.ok());
    EXPECT_NE(cam.error().message.find("/dev/null: not a V4L2 device"), std::string::npos)
        << cam.error().message;
}

}  // namespace
}  // namespace hmdnode
