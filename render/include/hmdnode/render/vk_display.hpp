// VK_KHR_display: the displays a Vulkan driver drives directly (no window system), for
// display.type "vk-display": listing, choosing, and the present path (a display plane surface
// and a FIFO swapchain, render/src/vulkan/vk_display_output.cpp). No Vulkan type appears here.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "hmdnode/core/image.hpp"
#include "hmdnode/core/result.hpp"

namespace hmdnode {

struct VulkanDisplayMode {
    int width = 0;
    int height = 0;
    double refresh_hz = 0.0;
};

struct VulkanDisplayInfo {
    std::string gpu;   // the physical device's name
    std::string name;  // VkDisplayPropertiesKHR::displayName (may be empty)
    int width = 0;     // physical resolution
    int height = 0;
    std::vector<VulkanDisplayMode> modes;
};

// Every display of every physical device. An instance without VK_KHR_display (no driver offers
// it) gives an empty list, not an error; a missing Vulkan loader/driver is an error.
Result<std::vector<VulkanDisplayInfo>> list_vulkan_displays();

// The display whose name or GPU name contains `want` (empty: the only display). The error names
// the displays found ("none" where the driver has none, as lavapipe).
Result<VulkanDisplayInfo> choose_vulkan_display(const std::vector<VulkanDisplayInfo>& displays,
                                                const std::string& want);

// The index of the display's mode of width x height (0: any) at refresh_hz (within 0.5 Hz; 0:
// the highest); all zero: the highest refresh at the display's physical resolution (else the
// first mode). The error names the display and lists its modes.
Result<size_t> choose_vulkan_display_mode(const VulkanDisplayInfo& display, int width, int height,
                                          double refresh_hz);

struct VulkanDisplayOutputConfig {
    std::string display;        // a part of the display's or GPU's name (choose_vulkan_display)
    int width = 0, height = 0;  // the mode (choose_vulkan_display_mode); 0: see there
    double refresh_hz = 0.0;
};

// A display driven through VK_KHR_display: the chosen display's mode on a plane that can show it
// (vkCreateDisplayPlaneSurfaceKHR), a swapchain with FIFO present (one image per vsync, never
// torn), and VK_KHR_present_id + VK_KHR_present_wait where the device offers them.
class VulkanDisplayOutput {
  public:
    virtual ~VulkanDisplayOutput() = default;
    virtual const VulkanDisplayInfo& display() const = 0;
    virtual VulkanDisplayMode mode() const = 0;
    // True when present() waits with vkWaitForPresentKHR until the image is on the display, so
    // that the time it returns at is the vsync it was shown at (to within the driver's wake-up).
    virtual bool present_wait() const = 0;
    // Copies the image (the mode's size: both eyes side by side) into the next swapchain image and
    // queues it for the next vsync; returns once it is shown (present_wait()) or queued (FIFO
    // then blocks a later present until an image is free). Errors: a size other than the mode's,
    // the display lost (VK_ERROR_OUT_OF_DATE_KHR / SURFACE_LOST), a device loss.
    virtual Status present(const ImageRGBA8& image) = 0;
    // e.g. "B8G8R8A8_UNORM, 3 images, FIFO, present_wait".
    virtual std::string describe() const = 0;
};

// Creates the output. Errors: no display matches (naming the displays found: "none" with
// lavapipe), no such mode (listing them), no plane can show the display, no queue can present to
// its surface, no transfer-destination swapchain format.
Result<std::unique_ptr<VulkanDisplayOutput>> create_vulkan_display_output(
    const VulkanDisplayOutputConfig& config);

}  // namespace hmdnode
