// Zero-copy scan-out of the renderer's panel image (docs/rendering.md, "Scan-out";
// docs/hardware.md, "KMS output"): the GLES backend renders on EGL's GBM platform, on the KMS
// display's own DRM device, into a ring of GBM buffer objects the display turns into framebuffers
// once and flips. This header holds the pure part: which of the formats the display's plane accepts
// the buffers are allocated in. No GBM, EGL or libdrm type.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "hmdnode/core/result.hpp"
#include "hmdnode/core/scanout_buffer.hpp"

namespace hmdnode {

// The four-character text of a DRM fourcc ("XR24"); non-printable bytes as '?'.
std::string fourcc_text(uint32_t fourcc);

// What to allocate: a format and the modifiers to offer the allocator (empty: the driver's
// implicit layout for scan-out, GBM_BO_USE_SCANOUT without modifiers).
struct ScanoutAllocation {
    uint32_t fourcc = 0;
    std::vector<uint64_t> modifiers;  // the plane's explicit modifiers for the format
    bool implicit_ok = true;          // the plane also accepts the implicit layout (or LINEAR)
};

// The first of XRGB8888, ARGB8888, XBGR8888, ABGR8888 (8-bit RGB the panel image is written in,
// alpha ignored by the plane) that the plane accepts, with the plane's modifiers for it. A plane
// that lists a format only with kDrmModInvalid (no IN_FORMATS) takes the implicit layout. The
// error names the device and lists what the plane offers. O(formats).
Result<ScanoutAllocation> choose_scanout_allocation(const std::vector<ScanoutFormat>& offered,
                                                    const std::string& device);

}  // namespace hmdnode
