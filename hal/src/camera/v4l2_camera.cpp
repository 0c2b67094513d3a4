// The V4L2 camera backend: memory-mapped streaming I/O (V4L2 API, "Streaming I/O (Memory
// Mapping)"): VIDIOC_QUERYCAP -> [S_INPUT, S_CTRL by name, S_DV_TIMINGS: V4l2CameraConfig] ->
// S_FMT -> REQBUFS(MMAP) -> QUERYBUF + mmap -> QBUF all -> STREAMON; each frame is poll + DQBUF,
// copied out, and QBUF'd back at once so the driver never runs out of buffers. Timestamps: a buffer
// flagged V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC carries the capture time on CLOCK_MONOTONIC -- the host
// clock of hmdnode -- and is used as is; any other timestamp source is replaced by the dequeue time
// (and said by timestamps_from_driver()). Cost: one copy of each frame (bytesused); memory the
// driver's buffers (mapped) + one frame. Departs from libv4l2: plain ioctls on the kernel's device
// -- no format emulation, so the device must offer the requested fourcc (the error lists what it
// offers).
#include <fcntl.h>
#include <linux/videodev2.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <ctime>
#include <vector>

#include "hmdnode/hal/camera.hpp"
#include "v4l2_common.hpp"

namespace hmdnode {
namespace {

using v4l2_detail::errno_text;
using v4l2_detail::explain;
using v4l2_detail::monotonic_now_ns;
using v4l2_detail::xioctl;

class V4l2Camera final : public Camera {
  public:
    V4l2Camera(std::string device, int fd) : device_(std::move(device)), fd_(fd) {}
    ~V4l2Camera() override {
        stop();
        for (const Mapping& m : maps_)
            if (m.ptr != MAP_FAILED) munmap(m.ptr, m.length);
        close(fd_);
    }

    Status configure(const V4l2CameraConfig& config) {
        v4l2_capability cap{};
        if (xioctl(fd_, VIDIOC_QUERYCAP, &cap) == -1)
            return make_error(errno == ENOTTY ? device_ + ": not a V4L2 device (VIDIOC_QUERYCAP: " +
                                                    errno_text(errno) + ")"
                                              : explain(device_, "VIDIOC_QUERYCAP", errno));
        const uint32_t caps =
            (cap.capabilities & V4L2_CAP_DEVICE_CAPS) ? cap.device_caps : cap.capabilities;
        if (!(caps & V4L2_CAP_VIDEO_CAPTURE))
            return make_error(device_ + ": \"" + reinterpret_cast<const char*>(cap.card) +
                              "\" is not a video capture device");
        if (!(caps & V4L2_CAP_STREAMING))
            return make_error(device_ + ": \"" + reinterpret_cast<const char*>(cap.card) +
                              "\" does not support streaming I/O");

        if (config.input >= 0) {
            int input = config.input;
            if (xioctl(fd_, VIDIOC_S_INPUT, &input) == -1)
                return make_error(
                    explain(device_, "VIDIOC_S_INPUT " + std::to_string(config.input), errno));
        }
        if (Status s = v4l2_detail::set_controls(fd_, device_, config.controls); !s.ok()) return s;
        if (config.dv_timings)
            if (Status s = v4l2_detail::set_dv_timings(fd_, device_, config.width, config.height);
                !s.ok())
                return s;

        Result<v4l2_detail::PixFormat> pix =
            v4l2_detail::set_pix_format(fd_, device_, V4L2_BUF_TYPE_VIDEO_CAPTURE, config.width,
                                        config.height, config.fourcc, V4L2_FIELD_ANY);
        if (!pix.ok()) return pix.error();
        width_ = pix->width;
        height_ = pix->height;
        fourcc_ = pix->fourcc;
        bytes_per_line_ = pix->bytes_per_line;

        Result<uint32_t> count = v4l2_detail::request_mmap_buffers(
            fd_, device_, V4L2_BUF_TYPE_VIDEO_CAPTURE, int(config.buffers));
        if (!count.ok()) return count.error();
        for (uint32_t i = 0; i < *count; ++i) {
            v4l2_buffer b{};
            b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
            b.memory = V4L2_MEMORY_MMAP;
            b.index = i;
            if (xioctl(fd_, VIDIOC_QUERYBUF, &b) == -1)
                return make_error(explain(device_, "VIDIOC_QUERYBUF", errno));
            Mapping m;
            m.length = b.length;
            m.ptr = mmap(nullptr, b.length, PROT_READ | PROT_WRITE, MAP_SHARED, fd_, b.m.offset);
            if (m.ptr == MAP_FAILED) return make_error(explain(device_, "mmap", errno));
            maps_.push_back(m);
        }
        return {};
    }

    std::string name() const override { return device_; }
    uint32_t width() const override { return width_; }
    uint32_t height() const override { return height_; }
    uint32_t fourcc() const override { return fourcc_; }

    Status start() override {
        if (streaming_) return {};
        for (uint32_t i = 0; i < maps_.size(); ++i) {
            v4l2_buffer b{};
            b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
            b.memory = V4L2_MEMORY_MMAP;
            b.index = i;
            if (xioctl(fd_, VIDIOC_QBUF, &b) == -1)
                return make_error(explain(device_, "VIDIOC_QBUF", errno));
        }
        int type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
        if (xioctl(fd_, VIDIOC_STREAMON, &type) == -1)
            return make_error(explain(device_, "VIDIOC_STREAMON", errno));
        streaming_ = true;
        return {};
    }

    void stop() override {
        if (!streaming_) return;
        int type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
        xioctl(fd_, VIDIOC_STREAMOFF, &type);  // also dequeues every buffer
        streaming_ = false;
    }

    Result<std::optional<CameraFrame>> next_frame(int timeout_ms) override {
        if (!streaming_) return make_error(device_ + ": next_frame before start()");
        pollfd p{fd_, POLLIN, 0};
        const int rc = poll(&p, 1, timeout_ms);
        if (rc < 0) return make_error(explain(device_, "poll", errno));
        if (rc == 0) return std::optional<CameraFrame>{};
        if (p.revents & (POLLERR | POLLHUP | POLLNVAL))
            return make_error(device_ + ": the device failed or was removed (poll error)");
        v4l2_buffer b{};
        b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
        b.memory = V4L2_MEMORY_MMAP;
        if (xioctl(fd_, VIDIOC_DQBUF, &b) == -1) {
            if (errno == EAGAIN) return std::optional<CameraFrame>{};
            return make_error(explain(device_, "VIDIOC_DQBUF", errno));
        }
        const int64_t now = monotonic_now_ns();
        CameraFrame f;
        f.width = width_;
        f.height = height_;
        f.fourcc = fourcc_;
        f.bytes_per_line = bytes_per_line_;
        f.sequence = b.sequence;
        f.timestamp = (b.flags & V4L2_BUF_FLAG_TSTAMP_SRC_MASK) == V4L2_BUF_FLAG_TSTAMP_SRC_SOE
                          ? CameraTimestamp::exposure_start
                          : CameraTimestamp::exposure_end;  // exposure and line time: unknown
        if ((b.flags & V4L2_BUF_FLAG_TIMESTAMP_MASK) == V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC &&
            (b.timestamp.tv_sec || b.timestamp.tv_usec)) {
            f.host_time_ns = static_cast<int64_t>(b.timestamp.tv_sec) * kNsPerSecond +
                             static_cast<int64_t>(b.timestamp.tv_usec) * kNsPerUs;
        } else {
            f.host_time_ns = now;
        }
        const auto* src = static_cast<const uint8_t*>(maps_[b.index].ptr);
        f.bytes.assign(src, src + std::min<size_t>(b.bytesused, maps_[b.index].length));
        if (xioctl(fd_, VIDIOC_QBUF, &b) == -1)
            return make_error(explain(device_, "VIDIOC_QBUF (requeue)", errno));
        return std::optional<CameraFrame>{std::move(f)};
    }

  private:
    struct Mapping {
        void* ptr = MAP_FAILED;
        size_t length = 0;
    };
    std::string device_;
    int fd_;
    std::vector<Mapping> maps_;
    bool streaming_ = false;
    uint32_t width_ = 0, height_ = 0, fourcc_ = 0, bytes_per_line_ = 0;
};

}  // namespace

Result<std::unique_ptr<Camera>> open_v4l2_camera(const V4l2CameraConfig& config) {
    const int fd = open(config.device.c_str(), O_RDWR | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0) return make_error(explain(config.device, "cannot open", errno));
    auto cam = std::make_unique<V4l2Camera>(config.device, fd);
    if (Status s = cam->configure(config); !s.ok()) return s.error();
    return std::unique_ptr<Camera>(std::move(cam));
}

}  // namespace hmdnode
