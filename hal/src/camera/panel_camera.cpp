// The simulated camera filming the mock display (camera/panel_camera.hpp): the panel's light
// integrated over each row's exposure, the rolling scan-out and persistence of
// display/mock_display.hpp. Cost: O(panel pixels) per present (luma of one eye); per camera
// frame O(panel pixels x lit intervals its exposure overlaps).
#include "hmdnode/hal/camera/panel_camera.hpp"

#include <algorithm>
#include <cmath>
#include <deque>
#include <random>
#include <vector>

namespace hmdnode {
namespace {

class PanelCameraImpl final : public PanelCamera {
  public:
    PanelCameraImpl(Clock& clock, const PanelCameraConfig& c)
        : clock_(clock),
          c_(c),
          period_ns_(std::llround(1e9 / c.display.refresh_hz)),
          rng_(c.seed) {}

    std::string name() const override { return "sim-panel"; }
    Status start() override { return Status::success(); }
    void stop() override {}
    uint32_t width() const override { return uint32_t(c_.display.eye_width); }
    uint32_t height() const override { return uint32_t(c_.display.eye_height); }
    uint32_t fourcc() const override { return kFourccGrey; }

    void shown(int64_t vsync_ns, const StereoImage* image) override {
        Shown s;
        s.vsync_ns = vsync_ns;
        if (image && image->eye[c_.eye].width == c_.display.eye_width &&
            image->eye[c_.eye].height == c_.display.eye_height) {
            const ImageRGBA8& eye = image->eye[c_.eye];
            s.luma.resize(size_t(eye.width) * eye.height);
            for (size_t i = 0; i < s.luma.size(); ++i) {
                const uint8_t* p = &eye.pixels[i * 4];
                s.luma[i] = uint8_t((77u * p[0] + 150u * p[1] + 29u * p[2] + 128u) >> 8);
            }
        }
        shown_.push_back(std::move(s));
    }

    Result<std::optional<CameraFrame>> next_frame(int timeout_ms) override {
        const int64_t start = frame_start_ns(next_);
        const int64_t ready =
            start + c_.exposure_ns + int64_t(height() - 1) * c_.line_time_ns + c_.stamp_delay_ns;
        if (clock_.now_ns() < ready) {
            if (timeout_ms == 0) return std::optional<CameraFrame>{};
            const int64_t until =
                timeout_ms < 0 ? ready
                               : std::min(ready, clock_.now_ns() + int64_t(timeout_ms) * 1'000'000);
            clock_.sleep_until_ns(until);
            if (clock_.now_ns() < ready) return std::optional<CameraFrame>{};
        }
        CameraFrame f;
        f.width = width();
        f.height = height();
        f.fourcc = kFourccGrey;
        f.bytes_per_line = f.width;
        f.sequence = next_;
        f.exposure_ns = c_.exposure_ns;
        f.line_time_ns = c_.line_time_ns;
        f.timestamp = c_.timestamp;
        const int64_t last_row = int64_t(f.height) - 1;
        f.host_time_ns =
            c_.stamp_delay_ns + (c_.timestamp == CameraTimestamp::exposure_start ? start
                                 : c_.timestamp == CameraTimestamp::exposure_middle
                                     ? start + c_.exposure_ns / 2
                                     : start + c_.exposure_ns + last_row * c_.line_time_ns);
        integrate(start, f.bytes);
        ++next_;
        prune(frame_start_ns(next_));
        return std::optional<CameraFrame>{std::move(f)};
    }

  private:
    struct Shown {
        int64_t vsync_ns = 0;
        std::vector<uint8_t> luma;  // empty: black
    };

    int64_t frame_start_ns(uint64_t k) {
        while (starts_.size() <= k - first_start_) {
            const uint64_t i = first_start_ + starts_.size();
            int64_t jitter = 0;
            if (c_.jitter_ns > 0)
                jitter = std::uniform_int_distribution<int64_t>(-c_.jitter_ns, c_.jitter_ns)(rng_);
            starts_.push_back(c_.phase_ns + std::llround(double(i) * 1e9 / c_.fps) + jitter);
        }
        return starts_[k - first_start_];
    }

    // The frame on screen at vsync v: the newest present shown at or before it (null: none).
    const Shown* on_screen(int64_t v) const {
        auto it = std::upper_bound(shown_.begin(), shown_.end(), v,
                                   [](int64_t t, const Shown& s) { return t < s.vsync_ns; });
        if (it == shown_.begin()) return nullptr;
        return &*(it - 1);
    }

    void integrate(int64_t start, std::vector<uint8_t>& out) const {
        const int w = c_.display.eye_width, h = c_.display.eye_height;
        out.assign(size_t(w) * h, 0);
        const int64_t p = c_.display.persistence_ns, e = c_.exposure_ns;
        const double gain = 1.0 / double(std::max<int64_t>(1, std::min(e, p)));
        std::vector<double> acc(static_cast<size_t>(w));
        for (int y = 0; y < h; ++y) {
            const int64_t a = start + int64_t(y) * c_.line_time_ns, b = a + e;
            const int64_t scan = mock_display_row_scanout_ns(c_.display, double(y) + 0.5);
            // The vsyncs whose lit interval [V + scan, V + scan + p) overlaps [a, b).
            const int64_t epoch = c_.display.vsync_epoch_ns;
            int64_t n = (a - scan - p - epoch) / period_ns_ - 1;
            std::fill(acc.begin(), acc.end(), 0.0);
            for (;; ++n) {
                const int64_t v = epoch + n * period_ns_;
                const int64_t lit0 = v + scan, lit1 = lit0 + p;
                if (lit0 >= b) break;
                const int64_t overlap = std::min(b, lit1) - std::max(a, lit0);
                if (overlap <= 0) continue;
                const Shown* s = on_screen(v);
                if (!s || s->luma.empty()) continue;
                const double weight = double(overlap) * gain;
                const uint8_t* row = &s->luma[size_t(y) * w];
                for (int x = 0; x < w; ++x) acc[size_t(x)] += weight * row[x];
            }
            for (int x = 0; x < w; ++x)
                out[size_t(y) * w + x] = uint8_t(std::min(255.0, std::round(acc[size_t(x)])));
        }
    }

    // Forgets the presents no exposure from `next_start` on can see.
    void prune(int64_t next_start) {
        const int64_t oldest_vsync =
            next_start - c_.jitter_ns - period_ns_ - c_.display.persistence_ns - period_ns_;
        while (shown_.size() >= 2 && shown_[1].vsync_ns <= oldest_vsync) shown_.pop_front();
        while (!starts_.empty() && first_start_ < next_) {
            starts_.pop_front();
            ++first_start_;
        }
    }

    Clock& clock_;
    PanelCameraConfig c_;
    int64_t period_ns_;
    std::mt19937 rng_;
    std::deque<Shown> shown_;
    std::deque<int64_t> starts_;  // exposure starts of frames first_start_, ...
    uint64_t first_start_ = 0;
    uint64_t next_ = 0;  // the next frame to deliver
};

}  // namespace

Result<std::unique_ptr<PanelCamera>> create_panel_camera(Clock& clock,
                                                         const PanelCameraConfig& config) {
    if (config.exposure_ns <= 0) return make_error("panel camera: exposure must be > 0");
    if (!(config.fps > 0.0 && config.fps <= 10000.0))
        return make_error("panel camera: frame rate must be in (0, 10000] Hz");
    if (config.eye != 0 && config.eye != 1) return make_error("panel camera: eye must be 0 or 1");
    if (config.line_time_ns < 0 || config.jitter_ns < 0 || config.stamp_delay_ns < 0)
        return make_error("panel camera: line time, jitter and stamp delay must be >= 0");
    // The panel must be one the mock display accepts.
    MockDisplayConfig d = config.display;
    d.frames_dir.clear();
    d.watcher = nullptr;
    if (auto probe = create_mock_display(clock, d); !probe) return probe.error();
    return std::unique_ptr<PanelCamera>(new PanelCameraImpl(clock, config));
}

}  // namespace hmdnode
