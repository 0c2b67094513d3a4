// A simulated camera filming the mock display (docs/latency.md, "The simulated camera"): it
// watches the presents (MockDisplayConfig::watcher) and integrates the panel's light over each
// exposure: panel row r of the frame shown at vsync v glows from v + its scan-out
// (mock_display_row_scanout_ns) for the persistence, black otherwise; a frame stays on screen,
// repeated at every vsync, until the next present's. Its frames are GREY, one eye's panel pixel
// for pixel (luma), at its own rate, phase and jitter, with a global or rolling shutter, and
// stamped as a real camera would be (start, middle or end of exposure, plus an optional delay of
// its own that the observer does not know: what the calibration measures).
//
// Pixel value = luma of the shown frame x (time the row was lit within the row's exposure) /
// min(exposure, persistence), summed over the vsyncs the exposure overlaps, clamped to 255: a
// camera whose gain makes one full lit interval full scale.
//
// Cost: per present, the luma of one eye (O(panel pixels)); per camera frame O(panel pixels x
// vsyncs its exposure overlaps). Memory: the frames still needed by an exposure not yet taken.
#pragma once

#include <cstdint>
#include <memory>

#include "hmdnode/core/time.hpp"
#include "hmdnode/hal/camera.hpp"
#include "hmdnode/hal/display/mock_display.hpp"

namespace hmdnode {

struct PanelCameraConfig {
    MockDisplayConfig display;  // the panel filmed (size, refresh, epoch, scan-out, persistence)
    int eye = 0;                // which eye's panel
    double fps = 240.0;
    int64_t phase_ns = 0;   // frame k's row 0 starts exposing at phase + k / fps + jitter
    int64_t jitter_ns = 0;  // uniform in [-jitter, +jitter] per frame
    uint32_t seed = 1;      // of the jitter
    int64_t exposure_ns = 1'000'000;
    int64_t line_time_ns = 0;  // 0: global shutter; else rolling, row y starts y * this later
    CameraTimestamp timestamp = CameraTimestamp::exposure_end;
    int64_t stamp_delay_ns = 0;  // the camera's own delay: stamps come this much late
};

class PanelCamera : public Camera, public PanelWatcher {};

// Errors: an empty exposure, a rate outside (0, 10000] Hz, an eye other than 0 or 1, a panel the
// mock display refuses. Frames are ready once the clock has passed their last row's exposure;
// next_frame(0) polls, a timeout waits on the clock. `clock` must outlive the camera.
Result<std::unique_ptr<PanelCamera>> create_panel_camera(Clock& clock,
                                                         const PanelCameraConfig& config);

}  // namespace hmdnode
