// A mock headset display: per-eye resolution, refresh rate, a rolling scan-out and a persistence
// model. Reports vsync and photon times of every presented frame and can write frames to PNG.
#pragma once

#include <filesystem>
#include <memory>

#include "hmdnode/core/time.hpp"
#include "hmdnode/hal/display.hpp"

namespace hmdnode {

// Watches what the mock display shows (a simulated camera filming it: camera/panel_camera.hpp).
// Called on the frame thread at each present, with the vsync the frame is shown at (it stays on
// screen, repeated, until the next present's vsync) and its image (null: a timing-only present,
// which shows black).
class PanelWatcher {
  public:
    virtual ~PanelWatcher() = default;
    virtual void shown(int64_t vsync_ns, const StereoImage* image) = 0;
};

struct MockDisplayConfig {
    int eye_width = 540;
    int eye_height = 600;
    double refresh_hz = 90.0;
    int64_t vsync_epoch_ns = 0;  // a vsync happens at epoch + k * period
    double scanout_fraction =
        1.0;  // rolling scan-out: top to bottom row over this part of a period
    int64_t persistence_ns = 2'000'000;  // each row glows this long after it is scanned
    int64_t latch_margin_ns = 500'000;   // a frame must arrive this long before its vsync
    std::filesystem::path frames_dir;    // empty: no PNGs
    int frames_every = 1;                // write every Nth presented frame
    PanelWatcher* watcher = nullptr;     // told of every present (null: none); must outlive it
};

// The time from a vsync to the scan-out of panel row `row` (pixels from the top, a real number):
// rows are scanned top to bottom over scanout_fraction of a period; a row glows from then for the
// persistence.
int64_t mock_display_row_scanout_ns(const MockDisplayConfig& config, double row);

// A panel lit longer than its refresh period is not a panel: the error gives both figures.
Status check_persistence(const MockDisplayConfig& display);

// Fails when the configuration is invalid (size, rate) or frames_dir cannot be created.
Result<std::unique_ptr<Display>> create_mock_display(Clock& clock, const MockDisplayConfig& config);

}  // namespace hmdnode
