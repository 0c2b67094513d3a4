// The vocabulary between a renderer that draws into scan-out buffers and a KMS display that shows
// them (zero-copy scan-out, docs/hardware.md "KMS output"): what the display's plane accepts and
// what a buffer is, as plain numbers (DRM fourcc codes and format modifiers, GEM handles on the
// display's DRM file). No libdrm, GBM or EGL type: render/ allocates the buffers, hal/ turns them
// into framebuffers and flips them, firmware_host/ connects the two.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace hmdnode {

// DRM_FORMAT_MOD_LINEAR and DRM_FORMAT_MOD_INVALID (drm_fourcc.h), for code without libdrm.
inline constexpr uint64_t kDrmModLinear = 0;
inline constexpr uint64_t kDrmModInvalid = 0x00ffffffffffffffull;

// One format a plane can scan out, with one modifier (kDrmModInvalid: the driver's implicit
// layout, what a plane without the IN_FORMATS property says).
struct ScanoutFormat {
    uint32_t fourcc = 0;
    uint64_t modifier = kDrmModInvalid;
    bool operator==(const ScanoutFormat&) const = default;
};

// One buffer object the renderer draws into and the display scans out: up to four planes (one for
// the RGB formats used here), each a GEM handle on the display's DRM file with its pitch and
// offset in bytes.
struct ScanoutBuffer {
    int width = 0;
    int height = 0;
    uint32_t fourcc = 0;
    uint64_t modifier = kDrmModInvalid;  // kDrmModInvalid: implicit (ADDFB2 without modifiers)
    int planes = 1;
    uint32_t handles[4] = {0, 0, 0, 0};
    uint32_t pitches[4] = {0, 0, 0, 0};
    uint32_t offsets[4] = {0, 0, 0, 0};
};

// What a renderer needs to allocate scan-out buffers for a display: its DRM file (borrowed: the
// renderer keeps a duplicate of it, so the GEM handles stay valid as long as its buffers live),
// the mode's size, and the formats the display's plane accepts.
struct ScanoutTargetInfo {
    int drm_fd = -1;
    std::string device;  // for messages: "/dev/dri/card0"
    int width = 0;
    int height = 0;
    std::vector<ScanoutFormat> formats;
};

}  // namespace hmdnode
