// Mock headset display. Vsyncs fall at epoch + k * period. A frame presented at time t for vsync V
// is shown at V when t <= V - latch margin and no earlier frame holds V, else at the first vsync
// whose latch point is not before t and that is free (free_vsync_ns).
// Photon time of the panel centre = vsync + scan-out of the middle row + half the persistence.
#include "hmdnode/hal/display/mock_display.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstdio>
#include <system_error>

namespace hmdnode {
namespace {

class MockDisplay final : public Display {
  public:
    MockDisplay(Clock& clock, const MockDisplayConfig& config)
        : clock_(clock),
          config_(config),
          period_ns_(int64_t(std::llround(1e9 / config.refresh_hz))) {
        // create_mock_display() checked the configuration: 1..1000 Hz gives a period >= 1 ms.
        assert(period_ns_ > 0 && config.frames_every >= 1 && config.latch_margin_ns >= 0);
        info_.name = "mock headset";
        info_.eye_width = config.eye_width;
        info_.eye_height = config.eye_height;
        info_.refresh_hz = config.refresh_hz;
        info_.period_ns = period_ns_;
        info_.latch_margin_ns = config.latch_margin_ns;
        info_.persistence_ns = config.persistence_ns;
    }

    DisplayInfo info() const override { return info_; }

    int64_t next_vsync_ns(int64_t t_ns) const override {
        const int64_t rel = t_ns - config_.vsync_epoch_ns;
        int64_t k = rel >= 0 ? rel / period_ns_ + 1 : -((-rel) / period_ns_);
        int64_t v = config_.vsync_epoch_ns + k * period_ns_;
        if (v <= t_ns) v += period_ns_;
        // The first vsync of the grid strictly after t: on the grid, within one period.
        assert(v > t_ns && v - period_ns_ <= t_ns);
        assert((v - config_.vsync_epoch_ns) % period_ns_ == 0);
        return v;
    }

    int64_t free_vsync_ns(int64_t t_ns) const override {
        // The first vsync V with t <= V - latch, i.e. the first vsync after t + latch - 1.
        int64_t v = next_vsync_ns(t_ns + config_.latch_margin_ns - 1);
        if (v <= last_vsync_ns_) v = last_vsync_ns_ + period_ns_;
        // Free: after the vsync an earlier present holds, and its latch point not before t.
        assert(v > last_vsync_ns_ && v - config_.latch_margin_ns >= t_ns);
        return v;
    }

    int64_t photon_offset_ns() const override {
        return int64_t(std::llround(0.5 * config_.scanout_fraction * double(period_ns_))) +
               config_.persistence_ns / 2;
    }

    int64_t row_photon_offset_ns(double row) const override {
        return mock_display_row_scanout_ns(config_, row) + config_.persistence_ns / 2;
    }

    Result<PresentResult> present(const StereoImage* image, int64_t target_vsync_ns) override {
        const int64_t now = clock_.now_ns();
        PresentResult r;
        r.frame_index = frame_index_++;
        r.target_vsync_ns = target_vsync_ns;
        // A display cannot show two frames at one vsync: the later one waits for the next free one;
        // nor can it show a frame before the vsync it was meant for.
        r.vsync_ns = std::max(free_vsync_ns(now), target_vsync_ns);
        // The vsync sequence only moves forward: one frame per vsync, never before its target.
        assert(r.vsync_ns > last_vsync_ns_ && r.vsync_ns >= target_vsync_ns);
        last_vsync_ns_ = r.vsync_ns;
        r.on_time = r.vsync_ns == target_vsync_ns;
        r.photon_time_ns = r.vsync_ns + photon_offset_ns();
        if (config_.watcher) config_.watcher->shown(r.vsync_ns, image);
        if (image && !config_.frames_dir.empty() &&
            r.frame_index % uint64_t(config_.frames_every) == 0) {
            char name[32];
            std::snprintf(name, sizeof name, "frame_%06llu.png", (unsigned long long)r.frame_index);
            Status st = write_png(side_by_side(*image), config_.frames_dir / name);
            if (!st.ok()) return st.error();
        }
        return r;
    }

  private:
    Clock& clock_;
    MockDisplayConfig config_;
    int64_t period_ns_;
    DisplayInfo info_;
    uint64_t frame_index_ = 0;
    int64_t last_vsync_ns_ = INT64_MIN;
};

}  // namespace

Result<std::unique_ptr<Display>> create_mock_display(Clock& clock,
                                                     const MockDisplayConfig& config) {
    if (config.eye_width < 1 || config.eye_height < 1 || config.eye_width > 16384 ||
        config.eye_height > 16384)
        return make_error("mock display: eye size must be between 1 and 16384 pixels");
    if (!(config.refresh_hz >= 1.0 && config.refresh_hz <= 1000.0))
        return make_error("mock display: refresh rate must be between 1 and 1000 Hz");
    if (!(config.scanout_fraction >= 0.0 && config.scanout_fraction <= 1.0) ||
        config.persistence_ns < 0 || config.latch_margin_ns < 0 || config.frames_every < 1)
        return make_error(
            "mock display: scan-out fraction must be in [0,1], persistence and latch margin >= 0, "
            "frames_every >= 1");
    if (!config.frames_dir.empty()) {
        std::error_code ec;
        std::filesystem::create_directories(config.frames_dir, ec);
        if (ec)
            return make_error("mock display: cannot create " + config.frames_dir.string() + ": " +
                              ec.message());
    }
    return std::unique_ptr<Display>(new MockDisplay(clock, config));
}

int64_t mock_display_row_scanout_ns(const MockDisplayConfig& config, double row) {
    const double period = double(std::llround(1e9 / config.refresh_hz));  // as the display's
    return int64_t(std::llround(config.scanout_fraction * period * (row / config.eye_height)));
}

Status check_persistence(const MockDisplayConfig& display) {
    const double period_ms = 1e3 / display.refresh_hz;
    if (!(ns_to_ms(display.persistence_ns) <= period_ms)) {
        char msg[160];
        std::snprintf(msg, sizeof msg,
                      "%.3f ms is longer than the refresh period (%.3f ms at %g Hz)",
                      ns_to_ms(display.persistence_ns), period_ms, display.refresh_hz);
        return make_error(msg);
    }
    return {};
}

}  // namespace hmdnode
