// Pacing of a VK_KHR_display output (FIFO swapchain): the vsync grid is anchor + k * period with
// the period from the mode's refresh. FIFO shows a present at the first vsync after the image
// before it, so present() sends a frame no earlier than one period before its target vsync (else
// it would show a vsync early). With VK_KHR_present_wait the output's present() returns once the
// image is on the display: that time, rounded to the grid, is the vsync it showed at, and it
// re-anchors the grid (drift between the display's clock and ours). Without it the frame counts
// for its target when it was queued by the target's latch point, else for the next vsync after.
// Cost: O(1) per present besides the output's copy.
#include "vk_display_pacing.hpp"

#include <cassert>
#include <cmath>

#include "hmdnode/hal/display/vsync_grid.hpp"

namespace hmdnode {
namespace {

class VkDisplayPacing final : public Display {
  public:
    VkDisplayPacing(Clock& clock, std::unique_ptr<VulkanDisplayOutput> output,
                    int64_t latch_margin_ns, int64_t persistence_ns)
        : clock_(clock), output_(std::move(output)) {
        const VulkanDisplayMode m = output_->mode();
        info_.name = "vk-display " + output_->display().name + " on " + output_->display().gpu;
        info_.eye_width = m.width / 2;
        info_.eye_height = m.height;
        info_.refresh_hz = m.refresh_hz;
        info_.period_ns = int64_t(std::llround(1e9 / m.refresh_hz));
        // choose_vulkan_display_mode() refuses a mode without a refresh rate of 1..1000 Hz.
        assert(info_.period_ns > 0 && latch_margin_ns >= 0 && persistence_ns >= 0);
        info_.latch_margin_ns = latch_margin_ns;
        info_.persistence_ns = persistence_ns;
        anchor_ns_ = clock_.now_ns();
    }

    DisplayInfo info() const override { return info_; }

    int64_t next_vsync_ns(int64_t t_ns) const override {
        return grid_vsync_after(anchor_ns_, info_.period_ns, t_ns);
    }

    int64_t free_vsync_ns(int64_t t_ns) const override {
        return grid_free_vsync(anchor_ns_, info_.period_ns, info_.latch_margin_ns, last_vsync_ns_,
                               t_ns);
    }

    int64_t photon_offset_ns() const override {
        return info_.period_ns / 2 + info_.persistence_ns / 2;
    }

    Result<PresentResult> present(const StereoImage* image, int64_t target_vsync_ns) override {
        const int64_t p = info_.period_ns;
        const int64_t send_at = target_vsync_ns - p;
        if (clock_.now_ns() < send_at) clock_.sleep_until_ns(send_at);
        const int64_t sent_ns = clock_.now_ns();
        if (image)
            if (Status st = output_->present(side_by_side(*image)); !st.ok()) return st.error();
        const int64_t t = clock_.now_ns();
        PresentResult r;
        r.frame_index = frame_index_++;
        r.target_vsync_ns = target_vsync_ns;
        if (image && output_->present_wait()) {
            const int64_t k = std::llround(double(t - target_vsync_ns) / double(p));
            r.vsync_ns = target_vsync_ns + k * p;
            anchor_ns_ = t;
        } else {
            r.vsync_ns = sent_ns <= target_vsync_ns - info_.latch_margin_ns
                             ? target_vsync_ns
                             : next_vsync_ns(sent_ns + info_.latch_margin_ns - 1);
        }
        if (r.vsync_ns <= last_vsync_ns_) r.vsync_ns = last_vsync_ns_ + p;
        assert(r.vsync_ns > last_vsync_ns_);  // one frame per vsync, in order
        last_vsync_ns_ = r.vsync_ns;
        r.on_time = r.vsync_ns == target_vsync_ns;
        r.photon_time_ns = r.vsync_ns + photon_offset_ns();
        return r;
    }

  private:
    Clock& clock_;
    std::unique_ptr<VulkanDisplayOutput> output_;
    DisplayInfo info_;
    int64_t anchor_ns_ = 0;
    int64_t last_vsync_ns_ = 0;
    uint64_t frame_index_ = 0;
};

}  // namespace

std::unique_ptr<Display> make_vk_display_pacing(Clock& clock,
                                                std::unique_ptr<VulkanDisplayOutput> output,
                                                int64_t latch_margin_ns, int64_t persistence_ns) {
    return std::make_unique<VkDisplayPacing>(clock, std::move(output), latch_margin_ns,
                                             persistence_ns);
}

}  // namespace hmdnode
