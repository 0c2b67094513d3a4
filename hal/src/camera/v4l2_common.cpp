// The V4L2 backends' shared steps (v4l2_common.hpp), after the V4L2 API ("Digital Video (DV)
// Timings": ENUM_DV_TIMINGS / S_DV_TIMINGS; "User Controls": QUERYCTRL with NEXT_CTRL, S_CTRL).
// Cost: one ioctl per timing or control the device lists.
#include "v4l2_common.hpp"

#include <linux/videodev2.h>
#include <sys/ioctl.h>

#include <cerrno>
#include <cstring>
#include <ctime>

#include "hmdnode/core/time.hpp"
#include "hmdnode/hal/camera.hpp"

namespace hmdnode::v4l2_detail {

int xioctl(int fd, unsigned long request, void* arg) {
    int r;
    do r = ioctl(fd, request, arg);
    while (r == -1 && errno == EINTR);
    return r;
}

std::string errno_text(int e) {
    const char* name = e == ENOENT    ? "ENOENT"
                       : e == EBUSY   ? "EBUSY"
                       : e == EACCES  ? "EACCES"
                       : e == ENODEV  ? "ENODEV"
                       : e == ENOTTY  ? "ENOTTY"
                       : e == EINVAL  ? "EINVAL"
                       : e == ENODATA ? "ENODATA"
                                      : nullptr;
    return std::string(std::strerror(e)) + (name ? std::string(" (") + name + ")" : "");
}

std::string explain(const std::string& device, const std::string& what, int e) {
    std::string m = device + ": " + what + ": " + errno_text(e);
    if (e == ENOENT) m += " -- no such device; is it plugged in (ls /dev/video*)?";
    if (e == EBUSY) m += " -- the device is busy: another program is streaming on it";
    if (e == EACCES) m += " -- no permission; add the user to the \"video\" group";
    if (e == ENODEV) m += " -- the device was removed";
    return m;
}

int64_t monotonic_now_ns() {
    timespec ts{};
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return static_cast<int64_t>(ts.tv_sec) * kNsPerSecond + ts.tv_nsec;
}

Status set_dv_timings(int fd, const std::string& device, uint32_t width, uint32_t height) {
    std::string offered;
    v4l2_enum_dv_timings e{};
    for (e.index = 0; xioctl(fd, VIDIOC_ENUM_DV_TIMINGS, &e) == 0; ++e.index) {
        const v4l2_bt_timings& bt = e.timings.bt;
        if (e.timings.type != V4L2_DV_BT_656_1120 || bt.interlaced) continue;
        if (bt.width == width && bt.height == height) {
            v4l2_dv_timings t = e.timings;
            if (xioctl(fd, VIDIOC_S_DV_TIMINGS, &t) == -1)
                return make_error(explain(
                    device,
                    "VIDIOC_S_DV_TIMINGS " + std::to_string(width) + "x" + std::to_string(height),
                    errno));
            return Status::success();
        }
        const std::string size = std::to_string(bt.width) + "x" + std::to_string(bt.height);
        if (offered.find(size) == std::string::npos)
            offered += (offered.empty() ? "" : ", ") + size;
    }
    if (e.index == 0)
        return make_error(explain(device,
                                  "VIDIOC_ENUM_DV_TIMINGS (no DV timings: not an HDMI "
                                  "input or output?)",
                                  errno));
    return make_error(device + ": no progressive standard DV timing of " + std::to_string(width) +
                      "x" + std::to_string(height) + " (offered: " + offered + ")");
}

Status set_controls(int fd, const std::string& device,
                    const std::vector<std::pair<std::string, int32_t>>& controls) {
    for (const auto& [name, value] : controls) {
        v4l2_queryctrl q{};
        bool found = false;
        q.id = V4L2_CTRL_FLAG_NEXT_CTRL;
        while (!found && xioctl(fd, VIDIOC_QUERYCTRL, &q) == 0) {
            if (name == reinterpret_cast<const char*>(q.name) &&
                !(q.flags & V4L2_CTRL_FLAG_DISABLED))
                found = true;
            else
                q.id |= V4L2_CTRL_FLAG_NEXT_CTRL;
        }
        if (!found) return make_error(device + ": no control named \"" + name + "\"");
        v4l2_control c{};
        c.id = q.id;
        c.value = value;
        if (xioctl(fd, VIDIOC_S_CTRL, &c) == -1)
            return make_error(explain(
                device, "VIDIOC_S_CTRL \"" + name + "\" = " + std::to_string(value), errno));
    }
    return Status::success();
}

Result<PixFormat> set_pix_format(int fd, const std::string& device, uint32_t buf_type,
                                 uint32_t width, uint32_t height, uint32_t fourcc, uint32_t field) {
    const bool output = buf_type == V4L2_BUF_TYPE_VIDEO_OUTPUT;
    v4l2_format fmt{};
    fmt.type = buf_type;
    fmt.fmt.pix.width = width;
    fmt.fmt.pix.height = height;
    fmt.fmt.pix.pixelformat = fourcc;
    fmt.fmt.pix.field = field;
    if (xioctl(fd, VIDIOC_S_FMT, &fmt) == -1)
        return make_error(
            explain(device, output ? "VIDIOC_S_FMT (output)" : "VIDIOC_S_FMT", errno));
    if (fmt.fmt.pix.pixelformat != fourcc) {
        std::string offered;
        v4l2_fmtdesc d{};
        d.type = buf_type;
        for (d.index = 0; xioctl(fd, VIDIOC_ENUM_FMT, &d) == 0; ++d.index)
            offered += (offered.empty() ? "" : ", ") + fourcc_to_string(d.pixelformat);
        return make_error(device + (output ? ": output pixel format " : ": pixel format ") +
                          fourcc_to_string(fourcc) + " is not offered (offered: " + offered + ")");
    }
    return PixFormat{fmt.fmt.pix.width, fmt.fmt.pix.height, fmt.fmt.pix.pixelformat,
                     fmt.fmt.pix.bytesperline};
}

Result<uint32_t> request_mmap_buffers(int fd, const std::string& device, uint32_t buf_type,
                                      int count) {
    const bool output = buf_type == V4L2_BUF_TYPE_VIDEO_OUTPUT;
    v4l2_requestbuffers req{};
    req.count = count < 2 ? 2 : uint32_t(count);
    req.type = buf_type;
    req.memory = V4L2_MEMORY_MMAP;
    if (xioctl(fd, VIDIOC_REQBUFS, &req) == -1)
        return make_error(explain(
            device, output ? "VIDIOC_REQBUFS (output, mmap)" : "VIDIOC_REQBUFS (mmap)", errno));
    if (req.count < 2)
        return make_error(device + ": the driver gave " + std::to_string(req.count) +
                          (output ? " output buffer(s)" : " buffer(s)") +
                          "; streaming needs at least 2");
    return req.count;
}

}  // namespace hmdnode::v4l2_detail
