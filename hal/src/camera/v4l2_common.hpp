// What the V4L2 camera and output backends share (private to hal): ioctl with EINTR retried,
// errors that name the device, the ioctl and the errno, and the two set-up steps both sides of an
// HDMI link take -- a standard DV timing of the frame's size and controls set by name -- and the
// format and mmap buffer requests of either buffer type.
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "hmdnode/core/result.hpp"

namespace hmdnode::v4l2_detail {

// ioctl(fd, request, arg), retried on EINTR.
int xioctl(int fd, unsigned long request, void* arg);

// "No such file or directory (ENOENT)".
std::string errno_text(int e);

// "DEVICE: WHAT: errno text" and, for the errors a user can fix, what to do.
std::string explain(const std::string& device, const std::string& what, int e);

// CLOCK_MONOTONIC now, ns.
int64_t monotonic_now_ns();

// The first of the device's standard DV timings (VIDIOC_ENUM_DV_TIMINGS) that is width x height,
// progressive, set with VIDIOC_S_DV_TIMINGS (on the current input or output). Errors name the
// device and list the progressive sizes it offers.
Status set_dv_timings(int fd, const std::string& device, uint32_t width, uint32_t height);

// Sets each control found by its name (VIDIOC_QUERYCTRL with V4L2_CTRL_FLAG_NEXT_CTRL) to its
// value (VIDIOC_S_CTRL). Errors name the device and the control.
Status set_controls(int fd, const std::string& device,
                    const std::vector<std::pair<std::string, int32_t>>& controls);

// What VIDIOC_S_FMT settled on.
struct PixFormat {
    uint32_t width = 0, height = 0, fourcc = 0, bytes_per_line = 0;
};

// VIDIOC_S_FMT of `buf_type` (V4L2_BUF_TYPE_VIDEO_CAPTURE or _OUTPUT) at width x height in
// `fourcc` and `field`; an error naming the device when the driver keeps another pixel format,
// listing those it offers (VIDIOC_ENUM_FMT).
Result<PixFormat> set_pix_format(int fd, const std::string& device, uint32_t buf_type,
                                 uint32_t width, uint32_t height, uint32_t fourcc, uint32_t field);

// VIDIOC_REQBUFS of `count` (at least 2) mmap buffers of `buf_type`: the count the driver gave,
// or an error when it gave fewer than 2.
Result<uint32_t> request_mmap_buffers(int fd, const std::string& device, uint32_t buf_type,
                                      int count);

}  // namespace hmdnode::v4l2_detail
