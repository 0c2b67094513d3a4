// The simulated camera: deterministic test patterns at a fixed frame rate, stamped on the given
// clock (docs/hardware.md). Frame k is captured at start + round(k * 1e9 / fps) ns.
// Cost: O(width x height) per frame to draw the pattern; memory one frame.
#include <algorithm>
#include <climits>
#include <cmath>

#include "hmdnode/hal/camera.hpp"

namespace hmdnode {

std::string fourcc_to_string(uint32_t f) {
    std::string s(4, ' ');
    for (int i = 0; i < 4; ++i)
        s[static_cast<size_t>(i)] = static_cast<char>((f >> (8 * i)) & 0xff);
    return s;
}

const char* camera_timestamp_name(CameraTimestamp t) {
    switch (t) {
        case CameraTimestamp::exposure_start:
            return "start";
        case CameraTimestamp::exposure_middle:
            return "middle";
        case CameraTimestamp::exposure_end:
            return "end";
    }
    return "?";
}

int64_t exposure_middle_ns(const CameraFrame& f, double row) {
    const double last_row = f.height > 0 ? double(f.height) - 1.0 : 0.0;
    double row0_start = double(f.host_time_ns);
    if (f.timestamp == CameraTimestamp::exposure_middle) row0_start -= 0.5 * double(f.exposure_ns);
    if (f.timestamp == CameraTimestamp::exposure_end)
        row0_start -= double(f.exposure_ns) + last_row * double(f.line_time_ns);
    return int64_t(
        std::llround(row0_start + row * double(f.line_time_ns) + 0.5 * double(f.exposure_ns)));
}

uint8_t sim_camera_pattern(uint32_t x, uint32_t y, uint64_t sequence) {
    return static_cast<uint8_t>((x + 2 * y + 4 * sequence) & 0xff);
}

namespace {

class SimCamera final : public Camera {
  public:
    SimCamera(Clock& clock, const SimCameraConfig& config) : clock_(clock), config_(config) {
        if (config_.fourcc != kFourccYuyv) config_.fourcc = kFourccGrey;
        if (!(config_.fps > 0)) config_.fps = 60.0;
        if (config_.fourcc == kFourccYuyv) config_.width &= ~1u;
    }

    std::string name() const override { return "sim"; }
    uint32_t width() const override { return config_.width; }
    uint32_t height() const override { return config_.height; }
    uint32_t fourcc() const override { return config_.fourcc; }

    Status start() override {
        if (!streaming_) {
            streaming_ = true;
            start_ns_ = clock_.now_ns();
            next_ = 0;
        }
        return {};
    }
    void stop() override { streaming_ = false; }

    Result<std::optional<CameraFrame>> next_frame(int timeout_ms) override {
        if (!streaming_) return make_error("sim camera: next_frame before start()");
        const int64_t deadline =
            timeout_ms < 0 ? INT64_MAX : clock_.now_ns() + int64_t{timeout_ms} * kNsPerMs;
        const int64_t ready = capture_time(next_) + config_.exposure_delay_ns;
        if (ready > clock_.now_ns()) {
            if (ready > deadline) {
                clock_.sleep_until_ns(deadline);
                return std::optional<CameraFrame>{};
            }
            clock_.sleep_until_ns(ready);
        }
        CameraFrame f;
        f.width = config_.width;
        f.height = config_.height;
        f.fourcc = config_.fourcc;
        f.sequence = next_;
        f.host_time_ns = capture_time(next_);
        const bool yuyv = config_.fourcc == kFourccYuyv;
        f.bytes_per_line = config_.width * (yuyv ? 2 : 1);
        f.bytes.resize(size_t{f.bytes_per_line} * config_.height);
        for (uint32_t y = 0; y < config_.height; ++y) {
            uint8_t* row = f.bytes.data() + size_t{y} * f.bytes_per_line;
            for (uint32_t x = 0; x < config_.width; ++x) {
                const uint8_t v = sim_camera_pattern(x, y, next_);
                if (!yuyv) {
                    row[x] = v;
                } else {
                    row[2 * x] = v;
                    row[2 * x + 1] = (x & 1) ? static_cast<uint8_t>(next_ & 0xff) : 128;
                }
            }
        }
        ++next_;
        return std::optional<CameraFrame>{std::move(f)};
    }

  private:
    int64_t capture_time(uint64_t k) const {
        return start_ns_ +
               static_cast<int64_t>(std::llround(static_cast<double>(k) * 1e9 / config_.fps));
    }

    Clock& clock_;
    SimCameraConfig config_;
    bool streaming_ = false;
    int64_t start_ns_ = 0;
    uint64_t next_ = 0;
};

}  // namespace

std::unique_ptr<Camera> create_sim_camera(Clock& clock, const SimCameraConfig& config) {
    return std::make_unique<SimCamera>(clock, config);
}

}  // namespace hmdnode
