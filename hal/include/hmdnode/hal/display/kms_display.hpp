// KMS direct output: the headset's connector on /dev/dri/card*, chosen by name, EDID identity or
// the kernel's `non-desktop` property; its mode set with an atomic commit (legacy SetCrtc only on
// drivers without atomic); frames copied into CPU-mapped dumb buffers, or (zero-copy) buffers a
// renderer draws into attached as framebuffers once, page-flipped once per vsync, the page-flip
// event's timestamp and sequence being the display's vsync feedback. docs/hardware.md ("KMS
// output"). No libdrm type appears here.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "hmdnode/core/image.hpp"
#include "hmdnode/core/scanout_buffer.hpp"
#include "hmdnode/core/time.hpp"
#include "hmdnode/hal/display.hpp"

namespace hmdnode {

struct KmsMode {
    int width = 0;
    int height = 0;
    double refresh_hz = 0.0;  // from the pixel clock and the totals, not the rounded vrefresh
    bool preferred = false;
};

// The identity in an EDID's base block: the PNP vendor (3 letters, bytes 8-9), the product code
// (bytes 10-11, little endian) and the monitor name descriptor (tag 0xFC), when present.
struct EdidIdentity {
    std::string vendor;    // "VLV"
    uint16_t product = 0;  // 0x91a8
    std::string monitor_name;
};

// Parses an EDID base block (128 bytes or more; extension blocks are ignored). The error names
// the byte that is wrong (header, checksum, vendor letters).
Result<EdidIdentity> parse_edid_identity(const uint8_t* bytes, size_t size);

// "2880x1600@90" (refresh optional: "2880x1600"). The error names the text.
struct KmsModeRequest {
    int width = 0;
    int height = 0;
    double refresh_hz = 0.0;  // 0: any
};
Result<KmsModeRequest> parse_kms_mode(std::string_view text);

struct KmsConnectorInfo {
    std::string device;      // /dev/dri/card0
    std::string name;        // DP-1, HDMI-A-1, Virtual-1
    std::string connection;  // connected, disconnected, unknown
    std::optional<EdidIdentity> edid;
    bool non_desktop = false;  // the kernel's property: set for known HMDs (or forced, docs)
    std::vector<KmsMode> modes;
};

// Every connector of every /dev/dri/card* (device empty) or of one device. Needs no DRM master.
// An empty list is not an error; a device that cannot be opened is (the error names it).
Result<std::vector<KmsConnectorInfo>> list_kms_connectors(const std::string& device = "");

struct KmsDisplayConfig {
    std::string device;  // /dev/dri/cardN; empty: every card in turn
    // Which connector: "DP-1" (a name as list_kms_connectors gives it), "edid:VLV:91A8" (vendor
    // and product code from the EDID), "non-desktop" (the one connector the kernel marks so);
    // empty: the non-desktop connector when exactly one is connected, else the only connected one.
    std::string connector;
    std::string mode;                    // "2880x1600@90"; empty: the connector's preferred mode
    int64_t latch_margin_ns = 500'000;   // a commit must reach the kernel this long before vblank
    int64_t persistence_ns = 2'000'000;  // how long a row glows (the panel's, for photon time)
    bool force_legacy = false;           // legacy SetCrtc/PageFlip even where atomic is offered
};

// The timestamp and sequence of the last page-flip event (CLOCK_MONOTONIC, as the clock the
// daemon runs on).
struct KmsFlip {
    uint64_t sequence = 0;     // the CRTC's vblank counter; 0 on drivers without vblank
    int64_t timestamp_ns = 0;  // the event's time
    int64_t commit_ns = 0;     // when the flip was committed
};

// Zero-copy scan-out: where present() finds the frame to flip when buffers are attached (the
// GLES renderer's GBM ring, connected by firmware_host's wiring). Called on the frame thread from
// present() only.
struct KmsBufferSource {
    std::function<int()> drawn;          // the attached buffer holding the newest frame; -1: none
    std::function<void(int)> committed;  // a flip to that buffer was committed
};

class KmsDisplay : public Display {
  public:
    // "atomic" or "legacy (no atomic modesetting on this driver)".
    virtual std::string modeset_path() const = 0;
    // False where the driver has no vblank interrupt (virtio-gpu, bochs: the kernel completes a
    // flip at once): flips are then paced by the display's own timer on the mode's period.
    virtual bool hardware_vblank() const = 0;
    virtual KmsMode mode() const = 0;
    virtual std::string connector_name() const = 0;
    // Frame thread only: the last page flip's event. Without hardware vblank present() returns
    // before its flip's event; the event is read by the next present() or by finish().
    virtual KmsFlip last_flip() const = 0;
    // Frame thread only: waits for the pending flip's event (none pending: returns at once).
    virtual Status finish() = 0;
    // Frame thread only: the framebuffer the CRTC scans out now, read back through the kernel
    // (GETFB2, then a CPU map of its buffer: MAP_DUMB, else its PRIME dma-buf; linear layouts
    // only), converted to RGBA8 (alpha 255).
    virtual Result<ImageRGBA8> read_scanout() = 0;

    // What a renderer needs to allocate buffers this display can scan out: the DRM file (the
    // display's own; borrowed), the device path, the mode's size and the primary plane's formats
    // with their modifiers (IN_FORMATS; without it each format with kDrmModInvalid).
    virtual ScanoutTargetInfo scanout_target() const = 0;
    // Frame thread only. Makes each buffer a framebuffer (ADDFB2, with its modifier where it has
    // an explicit one), once; from then on present() flips the buffer source.drawn() names and
    // tells source.committed() (image is ignored; with no drawn buffer it falls back to copying
    // the image, when given, into the dumb buffers). Errors name the device, the buffer and the
    // kernel's reason; on error nothing is attached.
    virtual Status attach_buffers(std::span<const ScanoutBuffer> buffers,
                                  KmsBufferSource source) = 0;
    // "dumb-buffer copy" or "zero-copy (3 attached buffers)".
    virtual std::string scanout_path() const = 0;
};

// Opens the device, becomes DRM master (the error names the device and says what to do when a
// compositor holds it: docs/hardware.md, DRM lease), picks the connector and mode, sets the mode
// and shows a black frame. info(): eye size = half the mode's width x its height.
// clock must be CLOCK_MONOTONIC (SystemClock): page-flip events are on that clock.
Result<std::unique_ptr<KmsDisplay>> create_kms_display(Clock& clock,
                                                       const KmsDisplayConfig& config);

}  // namespace hmdnode
