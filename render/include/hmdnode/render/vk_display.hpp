// VK_KHR_display: the displays a Vulkan driver drives directly (no window system), for
// display.type "vk-display". Listing and choosing are here; the present path through
// vkCreateDisplayPlaneSurfaceKHR is planned (docs/hardware.md). No Vulkan type appears here.
#pragma once

#include <string>
#include <vector>

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

}  // namespace hmdnode
