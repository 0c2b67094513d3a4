// The V4L2 output backend (v4l2_output.hpp): memory-mapped streaming I/O of the OUTPUT type (V4L2
// API, "Streaming I/O (Memory Mapping)", "Video Output Interface"): VIDIOC_QUERYCAP ->
// [S_OUTPUT, S_DV_TIMINGS] -> S_FMT -> REQBUFS(MMAP) -> QUERYBUF + mmap. A write copies the frame
// into a buffer the driver does not hold and QBUFs it; buffers the driver has shown come back by
// poll (POLLOUT) + DQBUF, with its frame counter and stamp, and are written again. Timestamps as
// the camera backend takes them: a buffer flagged V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC carries the
// driver's CLOCK_MONOTONIC time, any other source is replaced by the dequeue time.
// Cost: one copy of each frame; memory the driver's buffers (mapped).
#include "hmdnode/hal/camera/v4l2_output.hpp"

#include <fcntl.h>
#include <linux/videodev2.h>
#include <poll.h>
#include <sys/mman.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <utility>

#include "v4l2_common.hpp"

namespace hmdnode {
namespace {

class V4l2Output final : public VideoOutput {
  public:
    V4l2Output(std::string device, int fd) : device_(std::move(device)), fd_(fd) {}
    ~V4l2Output() override {
        stop();
        for (const OutMapping& m : maps_)
            if (m.ptr != MAP_FAILED) munmap(m.ptr, m.length);
        close(fd_);
    }

    Status configure(const V4l2OutputConfig& config);

    std::string name() const override { return device_; }
    uint32_t width() const override { return width_; }
    uint32_t height() const override { return height_; }
    uint32_t fourcc() const override { return fourcc_; }
    uint32_t bytes_per_line() const override { return bytes_per_line_; }
    uint32_t buffers() const override { return uint32_t(maps_.size()); }

    Status start() override {
        if (streaming_) return Status::success();
        int type = V4L2_BUF_TYPE_VIDEO_OUTPUT;
        if (v4l2_detail::xioctl(fd_, VIDIOC_STREAMON, &type) == -1)
            return make_error(v4l2_detail::explain(device_, "VIDIOC_STREAMON (output)", errno));
        streaming_ = true;
        return Status::success();
    }

    void stop() override {
        if (!streaming_) return;
        int type = V4L2_BUF_TYPE_VIDEO_OUTPUT;
        v4l2_detail::xioctl(fd_, VIDIOC_STREAMOFF, &type);  // every buffer back, not shown
        streaming_ = false;
        for (OutMapping& m : maps_) m.queued = false;
    }

    Result<bool> write(std::span<const uint8_t> frame, uint64_t tag, int timeout_ms) override {
        const size_t size = size_t(bytes_per_line_) * height_;
        if (frame.size() != size)
            return make_error(device_ + ": a frame of " + std::to_string(frame.size()) +
                              " bytes written to a " + std::to_string(width_) + "x" +
                              std::to_string(height_) + " " + fourcc_to_string(fourcc_) +
                              " output of " + std::to_string(size) + " bytes a frame");
        int free = next_free();
        if (free < 0) {
            if (!streaming_)
                return make_error(device_ + ": all " + std::to_string(maps_.size()) +
                                  " buffers queued before start(): none can come back");
            Result<bool> got = reclaim(timeout_ms);
            if (!got.ok()) return got.error();
            free = next_free();
            if (free < 0) return false;
        }
        OutMapping& m = maps_[size_t(free)];
        std::memcpy(m.ptr, frame.data(), size);
        v4l2_buffer b{};
        b.type = V4L2_BUF_TYPE_VIDEO_OUTPUT;
        b.memory = V4L2_MEMORY_MMAP;
        b.index = uint32_t(free);
        b.bytesused = uint32_t(size);
        b.field = V4L2_FIELD_NONE;
        const int64_t now = v4l2_detail::monotonic_now_ns();
        b.timestamp.tv_sec = now / kNsPerSecond;
        b.timestamp.tv_usec = (now % kNsPerSecond) / kNsPerUs;
        if (v4l2_detail::xioctl(fd_, VIDIOC_QBUF, &b) == -1)
            return make_error(v4l2_detail::explain(device_, "VIDIOC_QBUF (output)", errno));
        m.queued = true;
        m.tag = tag;
        m.order = next_order_++;
        return true;
    }

    Result<bool> wait_in_flight(size_t at_most, int timeout_ms) override {
        const int64_t deadline = v4l2_detail::monotonic_now_ns() + int64_t(timeout_ms) * kNsPerMs;
        while (in_flight() > at_most) {
            if (!streaming_) return make_error(device_ + ": wait_in_flight() before start()");
            int left = -1;
            if (timeout_ms >= 0) {
                const int64_t rest = deadline - v4l2_detail::monotonic_now_ns();
                if (rest <= 0) return false;
                left = int((rest + kNsPerMs - 1) / kNsPerMs);
            }
            Result<bool> got = reclaim(left);
            if (!got.ok()) return got.error();
        }
        return true;
    }

    std::vector<ShownFrame> take_shown() override { return std::exchange(shown_, {}); }

    size_t in_flight() const override {
        size_t n = 0;
        for (const OutMapping& m : maps_) n += m.queued;
        return n;
    }

  private:
    struct OutMapping {
        void* ptr = MAP_FAILED;
        size_t length = 0;
        bool queued = false;
        uint64_t tag = 0, order = 0;
    };

    // The buffer not held by the driver that was written longest ago (-1: all queued).
    int next_free() const {
        int pick = -1;
        for (size_t i = 0; i < maps_.size(); ++i)
            if (!maps_[i].queued && (pick < 0 || maps_[i].order < maps_[size_t(pick)].order))
                pick = int(i);
        return pick;
    }

    // Dequeues every buffer the driver has shown, waiting up to timeout_ms for the first; true
    // when one came back.
    Result<bool> reclaim(int timeout_ms) {
        pollfd p{fd_, POLLOUT, 0};
        const int rc = poll(&p, 1, timeout_ms);
        if (rc < 0) return make_error(v4l2_detail::explain(device_, "poll (output)", errno));
        if (rc == 0) return false;
        if (p.revents & (POLLERR | POLLHUP | POLLNVAL))
            return make_error(device_ + ": the output failed or was removed (poll error)");
        bool any = false;
        for (;;) {
            v4l2_buffer b{};
            b.type = V4L2_BUF_TYPE_VIDEO_OUTPUT;
            b.memory = V4L2_MEMORY_MMAP;
            if (v4l2_detail::xioctl(fd_, VIDIOC_DQBUF, &b) == -1) {
                if (errno == EAGAIN) return any;
                return make_error(v4l2_detail::explain(device_, "VIDIOC_DQBUF (output)", errno));
            }
            if (b.index >= maps_.size())
                return make_error(device_ + ": VIDIOC_DQBUF (output) gave buffer " +
                                  std::to_string(b.index) + " of " + std::to_string(maps_.size()));
            OutMapping& m = maps_[b.index];
            m.queued = false;
            ShownFrame s;
            s.tag = m.tag;
            s.sequence = b.sequence;
            s.driver_stamp =
                (b.flags & V4L2_BUF_FLAG_TIMESTAMP_MASK) == V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC &&
                (b.timestamp.tv_sec || b.timestamp.tv_usec);
            s.host_time_ns = s.driver_stamp ? int64_t(b.timestamp.tv_sec) * kNsPerSecond +
                                                  int64_t(b.timestamp.tv_usec) * kNsPerUs
                                            : v4l2_detail::monotonic_now_ns();
            shown_.push_back(s);
            any = true;
        }
    }

    std::string device_;
    int fd_;
    std::vector<OutMapping> maps_;
    std::vector<ShownFrame> shown_;
    bool streaming_ = false;
    uint64_t next_order_ = 0;
    uint32_t width_ = 0, height_ = 0, fourcc_ = 0, bytes_per_line_ = 0;
};

Status V4l2Output::configure(const V4l2OutputConfig& config) {
    using v4l2_detail::explain;
    using v4l2_detail::xioctl;
    v4l2_capability cap{};
    if (xioctl(fd_, VIDIOC_QUERYCAP, &cap) == -1)
        return make_error(errno == ENOTTY ? device_ + ": not a V4L2 device (VIDIOC_QUERYCAP: " +
                                                v4l2_detail::errno_text(errno) + ")"
                                          : explain(device_, "VIDIOC_QUERYCAP", errno));
    const uint32_t caps =
        (cap.capabilities & V4L2_CAP_DEVICE_CAPS) ? cap.device_caps : cap.capabilities;
    const std::string card = reinterpret_cast<const char*>(cap.card);
    if (!(caps & V4L2_CAP_VIDEO_OUTPUT))
        return make_error(device_ + ": \"" + card + "\" is not a video output device" +
                          ((caps & V4L2_CAP_VIDEO_CAPTURE) ? " (it captures)" : ""));
    if (!(caps & V4L2_CAP_STREAMING))
        return make_error(device_ + ": \"" + card + "\" does not support streaming I/O");
    if (config.output >= 0) {
        int output = config.output;
        if (xioctl(fd_, VIDIOC_S_OUTPUT, &output) == -1)
            return make_error(
                explain(device_, "VIDIOC_S_OUTPUT " + std::to_string(config.output), errno));
    }
    if (config.dv_timings)
        if (Status s = v4l2_detail::set_dv_timings(fd_, device_, config.width, config.height);
            !s.ok())
            return s;

    Result<v4l2_detail::PixFormat> pix =
        v4l2_detail::set_pix_format(fd_, device_, V4L2_BUF_TYPE_VIDEO_OUTPUT, config.width,
                                    config.height, config.fourcc, V4L2_FIELD_NONE);
    if (!pix.ok()) return pix.error();
    width_ = pix->width;
    height_ = pix->height;
    fourcc_ = pix->fourcc;
    bytes_per_line_ = pix->bytes_per_line;

    Result<uint32_t> count = v4l2_detail::request_mmap_buffers(
        fd_, device_, V4L2_BUF_TYPE_VIDEO_OUTPUT, int(config.buffers));
    if (!count.ok()) return count.error();
    for (uint32_t i = 0; i < *count; ++i) {
        v4l2_buffer b{};
        b.type = V4L2_BUF_TYPE_VIDEO_OUTPUT;
        b.memory = V4L2_MEMORY_MMAP;
        b.index = i;
        if (xioctl(fd_, VIDIOC_QUERYBUF, &b) == -1)
            return make_error(explain(device_, "VIDIOC_QUERYBUF (output)", errno));
        OutMapping m;
        m.length = b.length;
        if (b.length < size_t(bytes_per_line_) * height_)
            return make_error(device_ + ": output buffer " + std::to_string(i) + " holds " +
                              std::to_string(b.length) + " bytes, less than a frame");
        m.ptr = mmap(nullptr, b.length, PROT_READ | PROT_WRITE, MAP_SHARED, fd_, b.m.offset);
        if (m.ptr == MAP_FAILED) return make_error(explain(device_, "mmap (output)", errno));
        maps_.push_back(m);
    }
    return Status::success();
}

}  // namespace

Result<std::unique_ptr<VideoOutput>> open_v4l2_output(const V4l2OutputConfig& config) {
    const int fd = open(config.device.c_str(), O_RDWR | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0) return make_error(v4l2_detail::explain(config.device, "cannot open", errno));
    auto out = std::make_unique<V4l2Output>(config.device, fd);
    if (Status s = out->configure(config); !s.ok()) return s.error();
    return std::unique_ptr<VideoOutput>(std::move(out));
}

}  // namespace hmdnode
