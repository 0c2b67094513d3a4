// Cameras for a latency rig and, later, eye tracking: frames with their capture time on the host
// clock. Backends: V4L2 (mmap streaming) and a simulated camera producing test patterns.
// No V4L2 type appears here.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "hmdnode/core/result.hpp"
#include "hmdnode/core/time.hpp"

namespace hmdnode {

constexpr uint32_t make_fourcc(char a, char b, char c, char d) {
    return static_cast<uint32_t>(static_cast<uint8_t>(a)) |
           (static_cast<uint32_t>(static_cast<uint8_t>(b)) << 8) |
           (static_cast<uint32_t>(static_cast<uint8_t>(c)) << 16) |
           (static_cast<uint32_t>(static_cast<uint8_t>(d)) << 24);
}
constexpr uint32_t kFourccYuyv = make_fourcc('Y', 'U', 'Y', 'V');
constexpr uint32_t kFourccGrey = make_fourcc('G', 'R', 'E', 'Y');
// "YUYV"
std::string fourcc_to_string(uint32_t fourcc);

// What a frame's host_time_ns marks (V4L2: V4L2_BUF_FLAG_TSTAMP_SRC_SOE is the start of
// exposure, V4L2_BUF_FLAG_TSTAMP_SRC_EOF, the default, the end of the frame, taken here as the
// end of exposure of its last row).
enum class CameraTimestamp { exposure_start, exposure_middle, exposure_end };
const char* camera_timestamp_name(CameraTimestamp t);  // "start", "middle", "end"

struct CameraFrame {
    uint32_t width = 0;
    uint32_t height = 0;
    uint32_t fourcc = 0;
    uint32_t bytes_per_line = 0;
    std::vector<uint8_t> bytes;
    uint64_t sequence = 0;     // the driver's frame counter (gaps = frames it dropped)
    int64_t host_time_ns = 0;  // capture time on CLOCK_MONOTONIC (or the simulated clock)
    // The exposure: how long each row gathered light (0: unknown), what host_time_ns marks, and
    // for a rolling shutter the delay from one row's exposure to the next's (0: global shutter;
    // row 0 first). Where the stamp is the start or middle it is row 0's, the end the last row's.
    int64_t exposure_ns = 0;
    CameraTimestamp timestamp = CameraTimestamp::exposure_end;
    int64_t line_time_ns = 0;
};

// The middle of the exposure of row `row` (pixels from the top, a real number) of a frame on the
// host clock, from its stamp, exposure and line time (camera_observer: the photons' time there).
int64_t exposure_middle_ns(const CameraFrame& frame, double row);

class Camera {
  public:
    virtual ~Camera() = default;
    virtual std::string name() const = 0;  // "/dev/video0", "sim"
    // Control thread. Begins / ends streaming. Idempotent.
    virtual Status start() = 0;
    virtual void stop() = 0;
    // The capture thread (one at a time). Waits up to timeout_ms (0: poll, -1: forever) for the
    // next frame; nullopt on a timeout; an error when the device failed or was removed.
    virtual Result<std::optional<CameraFrame>> next_frame(int timeout_ms) = 0;
    // The format the device actually gave (it may adjust what was asked).
    virtual uint32_t width() const = 0;
    virtual uint32_t height() const = 0;
    virtual uint32_t fourcc() const = 0;
};

struct V4l2CameraConfig {
    std::string device = "/dev/video0";
    uint32_t width = 640;
    uint32_t height = 480;
    uint32_t fourcc = kFourccYuyv;
    uint32_t buffers = 4;  // mmap buffers requested (the driver may give more)
    int input = -1;        // >= 0: select this input first (VIDIOC_S_INPUT), e.g. an HDMI one
    // Controls set by name before the format (VIDIOC_QUERYCTRL, S_CTRL), e.g. vivid's
    // {"Loop Video", 1}.
    std::vector<std::pair<std::string, int32_t>> controls;
    // An HDMI input: first set the device's standard DV timing of width x height, progressive
    // (VIDIOC_ENUM_DV_TIMINGS, S_DV_TIMINGS), so that the frame is the signal's size.
    bool dv_timings = false;
};

// Opens and configures a V4L2 capture device (VIDIOC_QUERYCAP, [S_INPUT, S_CTRL, S_DV_TIMINGS],
// S_FMT, REQBUFS mmap, QBUF). Errors name the device and the ioctl: missing (ENOENT), busy
// (EBUSY: another program streams from it), no permission (EACCES: the "video" group), not a
// capture device, no such input or control, no DV timing of the size.
Result<std::unique_ptr<Camera>> open_v4l2_camera(const V4l2CameraConfig& config);

struct SimCameraConfig {
    uint32_t width = 320;
    uint32_t height = 240;
    uint32_t fourcc = kFourccGrey;  // GREY or YUYV
    double fps = 60.0;
    int64_t exposure_delay_ns = 0;  // frame k is stamped start + k / fps; readable this much later
};

// Test pattern: GREY pixel (x, y) of frame k = (x + 2 y + 4 k) mod 256; YUYV: Y as GREY, U = 128,
// V = (k mod 256). On a SimulatedClock, next_frame(timeout) moves the clock to the next frame (or
// the timeout); on the system clock it waits. `clock` must outlive the camera.
std::unique_ptr<Camera> create_sim_camera(Clock& clock, const SimCameraConfig& config = {});
// The pattern byte of the simulated camera's frame `sequence` at (x, y) for GREY, for tests.
uint8_t sim_camera_pattern(uint32_t x, uint32_t y, uint64_t sequence);

}  // namespace hmdnode
