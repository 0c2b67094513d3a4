// The Vulkan instance and logical device of the renderer: headless (no surface extensions),
// Vulkan 1.1, multiview enabled, one graphics queue, one command pool. Created once.
#pragma once

#include <vulkan/vulkan.h>

#include <functional>
#include <memory>
#include <string>

#include "hmdnode/core/result.hpp"

namespace hmdnode::vk {

class DeviceContext {
  public:
    DeviceContext() = default;
    DeviceContext(const DeviceContext&) = delete;
    DeviceContext& operator=(const DeviceContext&) = delete;
    ~DeviceContext();  // waits for the device to go idle, then destroys device and instance

    VkInstance instance = VK_NULL_HANDLE;
    VkPhysicalDevice physical = VK_NULL_HANDLE;
    VkDevice device = VK_NULL_HANDLE;
    VkQueue queue = VK_NULL_HANDLE;
    uint32_t queue_family = 0;
    VkCommandPool command_pool = VK_NULL_HANDLE;  // RESET_COMMAND_BUFFER: buffers are reusable
    VkPhysicalDeviceProperties properties{};
    VkPhysicalDeviceMemoryProperties memory_properties{};
    std::string name;
    bool validation_enabled = false;

    // Index of a memory type allowed by type_bits that has every `required` flag, preferring one
    // that also has every `preferred` flag; -1 when none has the required flags.
    int find_memory_type(uint32_t type_bits, VkMemoryPropertyFlags required,
                         VkMemoryPropertyFlags preferred = 0) const;

    // Records a one-shot command buffer with `record`, submits it and waits for it. For upload
    // time only (it allocates and blocks).
    Status submit_and_wait(const std::function<void(VkCommandBuffer)>& record);
};

// Creates the instance and picks a device: among the devices with Vulkan >= 1.1, the multiview
// feature and a graphics queue, the first discrete GPU, else integrated, virtual, other, CPU.
// HMDNODE_VK_DEVICE=<substring> restricts the choice to devices whose name contains it.
// `validation` enables VK_LAYER_KHRONOS_validation when that layer is installed.
Result<std::unique_ptr<DeviceContext>> create_device_context(bool validation);

}  // namespace hmdnode::vk
