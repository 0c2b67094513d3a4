// The display interface of the hardware abstraction layer: vsync timing, presentation of a
// finished stereo frame, and feedback on which vsync each present lands on (what a KMS page-flip
// event or VK_GOOGLE_display_timing / VK_KHR_present_wait report on real hardware), so that pacing
// never targets a vsync that an earlier frame already holds. Backends: the mock headset
// (display/mock_display.hpp) and KMS direct output (display/kms_display.hpp); VK_KHR_display
// output is render's (render/vk_display.hpp), made a Display by firmware_host's wiring.
#pragma once

#include <cstdint>
#include <string>

#include "hmdnode/core/image.hpp"
#include "hmdnode/core/result.hpp"

namespace hmdnode {

struct DisplayInfo {
    std::string name;
    int eye_width = 0;
    int eye_height = 0;
    double refresh_hz = 0.0;
    int64_t period_ns = 0;
    int64_t latch_margin_ns = 0;  // a frame must be presented this long before its vsync
    int64_t persistence_ns = 0;   // how long a row glows after its scan-out (0: unknown)
};

struct PresentResult {
    uint64_t frame_index = 0;     // counts presents
    int64_t target_vsync_ns = 0;  // the vsync the frame was meant for
    int64_t vsync_ns = 0;         // the vsync it was shown at (later than target when late)
    int64_t photon_time_ns = 0;   // photons of the panel centre (scan-out of the middle row +
                                  // half the persistence)
    bool on_time = false;         // vsync_ns == target_vsync_ns
};

class Display {
  public:
    virtual ~Display() = default;

    // Any thread.
    virtual DisplayInfo info() const = 0;
    // The first vsync strictly after t_ns (host clock).
    virtual int64_t next_vsync_ns(int64_t t_ns) const = 0;
    // The vsync a frame presented at t_ns would be shown at: the first vsync whose latch point
    // (vsync - latch margin) is not before t_ns and that no earlier present already holds. This is
    // the display's feedback to pacing (a frame queued behind another waits for the next vsync).
    virtual int64_t free_vsync_ns(int64_t t_ns) const = 0;
    // Time from a vsync to the photons of the panel centre.
    virtual int64_t photon_offset_ns() const = 0;
    // Time from a vsync to the photons of panel row `row` (pixels from the top, a real number:
    // pixel row r spans [r, r + 1)): its scan-out plus half the persistence, so row
    // eye_height / 2 gives photon_offset_ns(). A display that does not model its scan-out gives
    // the centre's figure for every row.
    virtual int64_t row_photon_offset_ns(double row) const {
        (void)row;
        return photon_offset_ns();
    }

    // Frame thread only. Presents a frame at the current time of the display's clock, meant for
    // target_vsync_ns. image may be null (timing only). A frame that arrives after its vsync's
    // latch point, or whose vsync an earlier present already holds, is shown at the vsync
    // free_vsync_ns(now) names and counts as late.
    virtual Result<PresentResult> present(const StereoImage* image, int64_t target_vsync_ns) = 0;
};

}  // namespace hmdnode
