// VK_KHR_display enumeration shared by the listing (vk_display.cpp) and the present path
// (vk_display_output.cpp): the instance and every display with its Vulkan handles.
#pragma once

#include <vulkan/vulkan.h>

#include <vector>

#include "hmdnode/core/result.hpp"
#include "hmdnode/render/vk_display.hpp"

namespace hmdnode::vkdisplay {

struct FoundDisplay {
    VkPhysicalDevice gpu = VK_NULL_HANDLE;
    VkDisplayKHR display = VK_NULL_HANDLE;
    std::vector<VkDisplayModeKHR> modes;  // parallel to info.modes
    VulkanDisplayInfo info;
};

// An instance with VK_KHR_surface + VK_KHR_display; VK_NULL_HANDLE (not an error) where no
// driver offers VK_KHR_display. Errors: no Vulkan driver, instance creation failing.
Result<VkInstance> create_instance();

// Every display of every physical device of the instance.
std::vector<FoundDisplay> enumerate(VkInstance instance);

}  // namespace hmdnode::vkdisplay
