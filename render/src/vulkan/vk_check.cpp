// Names of VkResult codes for error messages. Constant time.
#include "vk_check.hpp"

#include <cstdio>

namespace hmdnode::vk {

const char* result_name(VkResult result) {
    switch (result) {
#define HMDNODE_VK_NAME(r) \
    case r:                \
        return #r;
        HMDNODE_VK_NAME(VK_SUCCESS)
        HMDNODE_VK_NAME(VK_NOT_READY)
        HMDNODE_VK_NAME(VK_TIMEOUT)
        HMDNODE_VK_NAME(VK_INCOMPLETE)
        HMDNODE_VK_NAME(VK_ERROR_OUT_OF_HOST_MEMORY)
        HMDNODE_VK_NAME(VK_ERROR_OUT_OF_DEVICE_MEMORY)
        HMDNODE_VK_NAME(VK_ERROR_INITIALIZATION_FAILED)
        HMDNODE_VK_NAME(VK_ERROR_DEVICE_LOST)
        HMDNODE_VK_NAME(VK_ERROR_MEMORY_MAP_FAILED)
        HMDNODE_VK_NAME(VK_ERROR_LAYER_NOT_PRESENT)
        HMDNODE_VK_NAME(VK_ERROR_EXTENSION_NOT_PRESENT)
        HMDNODE_VK_NAME(VK_ERROR_FEATURE_NOT_PRESENT)
        HMDNODE_VK_NAME(VK_ERROR_INCOMPATIBLE_DRIVER)
        HMDNODE_VK_NAME(VK_ERROR_TOO_MANY_OBJECTS)
        HMDNODE_VK_NAME(VK_ERROR_FORMAT_NOT_SUPPORTED)
        HMDNODE_VK_NAME(VK_ERROR_FRAGMENTED_POOL)
        HMDNODE_VK_NAME(VK_ERROR_OUT_OF_POOL_MEMORY)
        HMDNODE_VK_NAME(VK_ERROR_UNKNOWN)
#undef HMDNODE_VK_NAME
        default:
            break;
    }
    thread_local char buffer[32];
    std::snprintf(buffer, sizeof(buffer), "VkResult %d", int(result));
    return buffer;
}

}  // namespace hmdnode::vk
