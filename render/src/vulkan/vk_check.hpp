// VkResult -> hmdnode::Error: the name of the result and the call that failed. No cost beyond a
// string on the failure path.
#pragma once

#include <vulkan/vulkan.h>

#include <string>

#include "hmdnode/core/result.hpp"

namespace hmdnode::vk {

// "VK_ERROR_OUT_OF_DEVICE_MEMORY", ... ("VkResult <n>" for codes it does not know).
const char* result_name(VkResult result);

// An Error saying which call failed and why, e.g. "vkCreateImage (colour target): VK_ERROR_...".
inline Error vk_error(const char* what, VkResult result) {
    std::string message = std::string(what) + ": " + result_name(result);
    if (result == VK_ERROR_OUT_OF_HOST_MEMORY || result == VK_ERROR_OUT_OF_DEVICE_MEMORY)
        message += " (out of memory)";
    else if (result == VK_ERROR_DEVICE_LOST)
        message += " (the GPU was lost; recreate the renderer)";
    return make_error(std::move(message));
}

}  // namespace hmdnode::vk

// Returns an Error from the enclosing function (which returns Status or Result<T>) when the call
// does not return VK_SUCCESS. `what` names the operation for the message.
#define HMDNODE_VK_TRY(call, what)                                      \
    do {                                                                \
        const VkResult hmdnode_vk_result_ = (call);                     \
        if (hmdnode_vk_result_ != VK_SUCCESS)                           \
            return ::hmdnode::vk::vk_error((what), hmdnode_vk_result_); \
    } while (0)
