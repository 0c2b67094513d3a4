// Instance creation and physical-device choice for the headless renderer. Cost: one driver load
// and device enumeration at start (docs/DESIGN.md §9 has its figure on lavapipe); nothing on the
// frame path.
#include "vk_device.hpp"

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "vk_check.hpp"

namespace hmdnode::vk {
namespace {

constexpr const char* kValidationLayer = "VK_LAYER_KHRONOS_validation";

bool layer_present(const char* name) {
    uint32_t count = 0;
    if (vkEnumerateInstanceLayerProperties(&count, nullptr) != VK_SUCCESS) return false;
    std::vector<VkLayerProperties> layers(count);
    if (vkEnumerateInstanceLayerProperties(&count, layers.data()) != VK_SUCCESS) return false;
    return std::any_of(layers.begin(), layers.end(), [&](const VkLayerProperties& l) {
        return std::strcmp(l.layerName, name) == 0;
    });
}

// Lower is better: discrete, integrated, virtual, other, CPU.
int type_rank(VkPhysicalDeviceType type) {
    switch (type) {
        case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU:
            return 0;
        case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU:
            return 1;
        case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU:
            return 2;
        case VK_PHYSICAL_DEVICE_TYPE_CPU:
            return 4;
        default:
            return 3;
    }
}

struct Candidate {
    VkPhysicalDevice device = VK_NULL_HANDLE;
    VkPhysicalDeviceProperties properties{};
    uint32_t queue_family = 0;
    std::string why_not;  // empty when usable
};

Candidate examine(VkPhysicalDevice device) {
    Candidate c;
    c.device = device;
    vkGetPhysicalDeviceProperties(device, &c.properties);
    if (c.properties.apiVersion < VK_API_VERSION_1_1) {
        c.why_not = "Vulkan 1.0 only";
        return c;
    }
    VkPhysicalDeviceMultiviewFeatures multiview{};
    multiview.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_MULTIVIEW_FEATURES;
    VkPhysicalDeviceFeatures2 features{};
    features.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2;
    features.pNext = &multiview;
    vkGetPhysicalDeviceFeatures2(device, &features);
    if (!multiview.multiview) {
        c.why_not = "no multiview";
        return c;
    }
    uint32_t count = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(device, &count, nullptr);
    std::vector<VkQueueFamilyProperties> families(count);
    vkGetPhysicalDeviceQueueFamilyProperties(device, &count, families.data());
    for (uint32_t i = 0; i < count; ++i) {
        if (families[i].queueCount > 0 && (families[i].queueFlags & VK_QUEUE_GRAPHICS_BIT)) {
            c.queue_family = i;
            return c;
        }
    }
    c.why_not = "no graphics queue";
    return c;
}

}  // namespace

DeviceContext::~DeviceContext() {
    if (device) {
        vkDeviceWaitIdle(device);
        if (command_pool) vkDestroyCommandPool(device, command_pool, nullptr);
        vkDestroyDevice(device, nullptr);
    }
    if (instance) vkDestroyInstance(instance, nullptr);
}

int DeviceContext::find_memory_type(uint32_t type_bits, VkMemoryPropertyFlags required,
                                    VkMemoryPropertyFlags preferred) const {
    int fallback = -1;
    for (uint32_t i = 0; i < memory_properties.memoryTypeCount; ++i) {
        if (!(type_bits & (1u << i))) continue;
        const VkMemoryPropertyFlags flags = memory_properties.memoryTypes[i].propertyFlags;
        if ((flags & required) != required) continue;
        if ((flags & preferred) == preferred) return int(i);
        if (fallback < 0) fallback = int(i);
    }
    return fallback;
}

Status DeviceContext::submit_and_wait(const std::function<void(VkCommandBuffer)>& record) {
    VkCommandBufferAllocateInfo alloc{};
    alloc.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
    alloc.commandPool = command_pool;
    alloc.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    alloc.commandBufferCount = 1;
    VkCommandBuffer cmd = VK_NULL_HANDLE;
    HMDNODE_VK_TRY(vkAllocateCommandBuffers(device, &alloc, &cmd),
                   "vkAllocateCommandBuffers (upload)");
    VkFence fence = VK_NULL_HANDLE;
    const auto release = [&] {
        if (fence) vkDestroyFence(device, fence, nullptr);
        vkFreeCommandBuffers(device, command_pool, 1, &cmd);
    };

    VkCommandBufferBeginInfo begin{};
    begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
    begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    VkResult r = vkBeginCommandBuffer(cmd, &begin);
    if (r == VK_SUCCESS) {
        record(cmd);
        r = vkEndCommandBuffer(cmd);
    }
    if (r != VK_SUCCESS) {
        release();
        return vk_error("recording the upload commands", r);
    }
    VkFenceCreateInfo fence_info{};
    fence_info.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
    r = vkCreateFence(device, &fence_info, nullptr, &fence);
    if (r == VK_SUCCESS) {
        VkSubmitInfo submit{};
        submit.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
        submit.commandBufferCount = 1;
        submit.pCommandBuffers = &cmd;
        r = vkQueueSubmit(queue, 1, &submit, fence);
    }
    if (r == VK_SUCCESS) r = vkWaitForFences(device, 1, &fence, VK_TRUE, UINT64_MAX);
    release();
    if (r != VK_SUCCESS) return vk_error("submitting the upload commands", r);
    return Status::success();
}

Result<std::unique_ptr<DeviceContext>> create_device_context(bool validation) {
    auto ctx = std::make_unique<DeviceContext>();

    uint32_t instance_version = VK_API_VERSION_1_0;
    if (vkEnumerateInstanceVersion(&instance_version) != VK_SUCCESS ||
        instance_version < VK_API_VERSION_1_1)
        return make_error("Vulkan: the installed loader supports Vulkan 1.0 only; 1.1 is required");

    // 1. Instance: no extensions at all (headless, no surface).
    VkApplicationInfo app{};
    app.sType = VK_STRUCTURE_TYPE_APPLICATION_INFO;
    app.pApplicationName = "hmdnode";
    app.pEngineName = "hmdnode";
    app.apiVersion = VK_API_VERSION_1_1;
    VkInstanceCreateInfo instance_info{};
    instance_info.sType = VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO;
    instance_info.pApplicationInfo = &app;
    ctx->validation_enabled = validation && layer_present(kValidationLayer);
    if (ctx->validation_enabled) {
        instance_info.enabledLayerCount = 1;
        instance_info.ppEnabledLayerNames = &kValidationLayer;
    }
    const VkResult r = vkCreateInstance(&instance_info, nullptr, &ctx->instance);
    if (r == VK_ERROR_INCOMPATIBLE_DRIVER)
        return make_error(
            "Vulkan: no driver (ICD) installed; install mesa-vulkan-drivers for lavapipe");
    HMDNODE_VK_TRY(r, "vkCreateInstance");

    // 2. Physical device.
    uint32_t count = 0;
    HMDNODE_VK_TRY(vkEnumeratePhysicalDevices(ctx->instance, &count, nullptr),
                   "vkEnumeratePhysicalDevices");
    std::vector<VkPhysicalDevice> devices(count);
    HMDNODE_VK_TRY(vkEnumeratePhysicalDevices(ctx->instance, &count, devices.data()),
                   "vkEnumeratePhysicalDevices");
    if (count == 0) return make_error("Vulkan: no physical device found (no GPU and no lavapipe)");

    const char* wanted = std::getenv("HMDNODE_VK_DEVICE");
    const Candidate* best = nullptr;
    std::vector<Candidate> candidates;
    candidates.reserve(count);
    std::string rejected;
    for (VkPhysicalDevice d : devices) {
        candidates.push_back(examine(d));
        Candidate& c = candidates.back();
        if (c.why_not.empty() && wanted && *wanted &&
            std::strstr(c.properties.deviceName, wanted) == nullptr)
            c.why_not = std::string("name does not contain HMDNODE_VK_DEVICE=") + wanted;
        if (!c.why_not.empty()) {
            rejected += std::string(rejected.empty() ? "" : "; ") + c.properties.deviceName + " (" +
                        c.why_not + ")";
            continue;
        }
        if (!best || type_rank(c.properties.deviceType) < type_rank(best->properties.deviceType))
            best = &c;
    }
    if (!best) return make_error("Vulkan: no usable device: " + rejected);
    ctx->physical = best->device;
    ctx->properties = best->properties;
    ctx->queue_family = best->queue_family;
    ctx->name = best->properties.deviceName;
    vkGetPhysicalDeviceMemoryProperties(ctx->physical, &ctx->memory_properties);

    // 3. Logical device with multiview, one graphics queue.
    const float priority = 1.0f;
    VkDeviceQueueCreateInfo queue_info{};
    queue_info.sType = VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO;
    queue_info.queueFamilyIndex = ctx->queue_family;
    queue_info.queueCount = 1;
    queue_info.pQueuePriorities = &priority;
    VkPhysicalDeviceMultiviewFeatures multiview{};
    multiview.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_MULTIVIEW_FEATURES;
    multiview.multiview = VK_TRUE;
    VkDeviceCreateInfo device_info{};
    device_info.sType = VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO;
    device_info.pNext = &multiview;
    device_info.queueCreateInfoCount = 1;
    device_info.pQueueCreateInfos = &queue_info;
    HMDNODE_VK_TRY(vkCreateDevice(ctx->physical, &device_info, nullptr, &ctx->device),
                   "vkCreateDevice");
    vkGetDeviceQueue(ctx->device, ctx->queue_family, 0, &ctx->queue);

    VkCommandPoolCreateInfo pool_info{};
    pool_info.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
    pool_info.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
    pool_info.queueFamilyIndex = ctx->queue_family;
    HMDNODE_VK_TRY(vkCreateCommandPool(ctx->device, &pool_info, nullptr, &ctx->command_pool),
                   "vkCreateCommandPool");
    return ctx;
}

}  // namespace hmdnode::vk
