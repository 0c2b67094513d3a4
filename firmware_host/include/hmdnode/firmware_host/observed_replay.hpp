// A replay watched by a camera (`hmdnode latency --observer camera`, docs/latency.md, "The
// observer"): the node runs as run_replay runs it, with the latency marker on, while a camera
// films the panel; each captured frame is decoded as it arrives (sight_camera_frame: only the
// decoded marker is kept, never the pixels) and, once the replay is done, matched against the
// presents (match_camera_sightings). And the camera's own delay measured against a flash
// (calibrate_camera_flash). Cost: the replay's, plus per camera frame one decode (and, for the
// simulated camera, its integration of the panel's light); memory one CameraSighting per frame.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "hmdnode/core/result.hpp"
#include "hmdnode/core/time.hpp"
#include "hmdnode/firmware_host/camera_observer.hpp"
#include "hmdnode/firmware_host/replay.hpp"
#include "hmdnode/hal/camera.hpp"
#include "hmdnode/hal/camera/panel_camera.hpp"
#include "hmdnode/hal/display.hpp"

namespace hmdnode {

struct ObservedReplay {
    ReplayResult replay;
    ObserverResult observer;    // the frames filmed while the node presented
    std::string camera;         // its name
    size_t frames_outside = 0;  // frames filmed before the first present or after the last
};

// The simulated camera filming the mock display: `camera` with its panel (size, rate, scan-out,
// persistence, epoch) taken from the node's mock display, and its phase counted from the
// display's vsync epoch; made as the display's watcher (ReplayOptions::display_watcher). Its
// frames are taken after each present on the frame thread. options.node.latency_marker_cell_px
// must be > 0 (else: an error).
Result<ObservedReplay> run_replay_filmed(ReplayOptions options, const PanelCameraConfig& camera);

// A camera device (V4L2) on the real clock: streamed on a capture thread for the replay's whole
// run, each frame decoded as it arrives. `exposure_ns` > 0 is the exposure the frames are taken
// to have where the device does not say (V4L2 does not): their capture time is its middle. A
// device that fails mid-run ends it with an error naming it.
Result<ObservedReplay> run_replay_observed(ReplayOptions options, Camera& camera,
                                           int64_t exposure_ns = 0);

// Per camera frame one line (camera sequence, present, observed MTP, the node's figure for the
// marker's row, their difference; or why undecoded), then the summary: p50/p95/p99 of each,
// frames undecoded, repeats, skips, decoded ids never presented.
std::string observer_frames_table(const ObserverResult& result);
std::string observer_summary_table(const ObserverResult& result);
// {"camera", "summary": {frames, decoded, undecoded, unmatched, repeats, skipped, observed_ms,
//  node_ms, difference_ms}, "frames": [{camera_sequence, decoded, reason, present, capture_ns,
//  sample_time_ns, observed_ms, node_ms, difference_ms, repeat}]}
nlohmann::json observer_json(const ObservedReplay& observed);

// The flash calibration (docs/latency.md, "Calibration"): the panel black, then full-field white
// at known vsyncs, `flashes` times; per flash the first camera frame whose mean brightness passes
// half way from the dark level to the lit level. On a low-persistence panel a frame's brightness
// passes half way when the middle of its exposure (camera row 0 for a global shutter, the middle
// row for a rolling one) is at the flash's vsync + that panel row's photon offset (scan-out + half
// the persistence); the first frame past it lies up to a camera period later, so each flash's
// delay is (its exposure middle, from its stamp as the camera states it - that time) - half a
// camera period, within +-(period + exposure)/2 of the camera's own stamp delay. The estimate is
// their median.
struct FlashCalibrationOptions {
    int flashes = 12;
    int dark_vsyncs = 10;  // black before each flash
    int lit_vsyncs = 9;    // white from the flash's vsync
};

struct FlashSighting {
    int64_t flash_vsync_ns = 0;
    bool seen = false;
    uint64_t camera_sequence = 0;
    int64_t capture_ns = 0;  // exposure middle of the first frame past half way
    double delay_ms = 0.0;   // capture - expected - half a camera period
};

struct FlashCalibration {
    std::vector<FlashSighting> flashes;
    double camera_period_ms = 0.0;             // median interval of the frames' stamps
    double dark_level = 0.0, lit_level = 0.0;  // mean grey levels (medians over the frames)
    double delay_ms = 0.0;                     // median of the seen flashes' delays
    double bound_ms = 0.0;  // one flash's accuracy: +-(camera period + exposure) / 2
    size_t frames = 0;
};

// Presents to `display` (black and white frames of its size, from its next vsync) and reads
// `camera` (started here, stopped at the end) after each present, on `clock` (the display's).
// `exposure_ns`: as for run_replay_observed. Errors: a display or camera failure, a flash no
// frame saw, frames too dim to tell lit from dark.
Result<FlashCalibration> calibrate_camera_flash(Clock& clock, Display& display, Camera& camera,
                                                const FlashCalibrationOptions& options,
                                                int64_t exposure_ns = 0);

// A table for people: per flash its vsync, the frame and the delay; then the median.
std::string flash_calibration_table(const FlashCalibration& c);
nlohmann::json flash_calibration_json(const FlashCalibration& c);

}  // namespace hmdnode
