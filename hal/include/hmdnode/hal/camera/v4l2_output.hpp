// A V4L2 video output device (an HDMI transmitter; vivid's output, which loops back to its HDMI
// input): frames the program writes, shown by the driver on its own schedule, each returned with
// the time the driver finished showing it. The kernel lane writes the node's panel image to it and
// reads it back through a Camera (docs/latency.md, "The kernel lane's loopback"). No V4L2 type
// appears here.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "hmdnode/core/result.hpp"
#include "hmdnode/hal/camera.hpp"

namespace hmdnode {

struct V4l2OutputConfig {
    std::string device = "/dev/video1";
    uint32_t width = 640;
    uint32_t height = 480;
    uint32_t fourcc = kFourccYuyv;
    uint32_t buffers = 8;  // mmap buffers requested (the driver may give more or fewer, >= 2)
    int output = -1;       // >= 0: select this output first (VIDIOC_S_OUTPUT)
    // An HDMI output: first set the device's standard DV timing of width x height, progressive
    // (VIDIOC_ENUM_DV_TIMINGS, S_DV_TIMINGS), so that the signal is the frame's size.
    bool dv_timings = false;
};

// A frame the driver finished showing (dequeued).
struct ShownFrame {
    uint64_t tag = 0;       // what write() was given with it
    uint64_t sequence = 0;  // the driver's output frame counter
    // When the driver finished it on CLOCK_MONOTONIC: the driver's stamp where it is monotonic
    // (driver_stamp), else the dequeue time.
    int64_t host_time_ns = 0;
    bool driver_stamp = false;
};

class VideoOutput {
  public:
    virtual ~VideoOutput() = default;
    virtual std::string name() const = 0;  // "/dev/video1"
    // The format the device actually took (it may adjust what was asked).
    virtual uint32_t width() const = 0;
    virtual uint32_t height() const = 0;
    virtual uint32_t fourcc() const = 0;
    virtual uint32_t bytes_per_line() const = 0;
    virtual uint32_t buffers() const = 0;  // the driver's buffers
    // Begins streaming (VIDIOC_STREAMON; the driver shows frames once it holds enough of them).
    // Frames written before are queued and shown first. Idempotent.
    virtual Status start() = 0;
    // Ends streaming (VIDIOC_STREAMOFF): frames not yet shown are dropped. Idempotent.
    virtual void stop() = 0;
    // Copies `frame` (bytes_per_line() x height() bytes) into a free buffer and queues it. With
    // none free, waits up to timeout_ms (-1: forever) for the driver to finish showing one;
    // false when none came free in time. Errors: a frame of the wrong size, no free buffer
    // before start(), the device failed or was removed.
    virtual Result<bool> write(std::span<const uint8_t> frame, uint64_t tag, int timeout_ms) = 0;
    // Waits up to timeout_ms (-1: forever) until at most `at_most` frames written are not yet
    // shown; true when so. A driver may keep its newest frame until the next one comes (vivid
    // does: the frame stays on its output), so "all but the last" is at_most = 1. Errors: the
    // device failed or was removed.
    virtual Result<bool> wait_in_flight(size_t at_most, int timeout_ms) = 0;
    // The frames the driver finished since the last call, in the order it finished them.
    virtual std::vector<ShownFrame> take_shown() = 0;
    // Frames written and not yet shown.
    virtual size_t in_flight() const = 0;
};

// Opens and configures a V4L2 output device (VIDIOC_QUERYCAP, [S_OUTPUT, S_DV_TIMINGS], S_FMT of
// the OUTPUT type, REQBUFS mmap, QUERYBUF + mmap). Errors name the device and the ioctl: missing
// (ENOENT), busy (EBUSY), no permission (EACCES), not a V4L2 device, not a video output device,
// the pixel format not offered (the error lists what is), no DV timing of the size.
Result<std::unique_ptr<VideoOutput>> open_v4l2_output(const V4l2OutputConfig& config);

}  // namespace hmdnode
