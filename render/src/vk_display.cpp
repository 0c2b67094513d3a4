// VK_KHR_display enumeration (Vulkan spec, "WSI: Display enumeration"): an instance with
// VK_KHR_surface + VK_KHR_display, then per physical device vkGetPhysicalDeviceDisplayPropertiesKHR
// and per display vkGetDisplayModePropertiesKHR. Cost: one instance creation (milliseconds).
#include "hmdnode/render/vk_display.hpp"

#include <vulkan/vulkan.h>

#include <cstring>

namespace hmdnode {
namespace {

bool instance_extension(const char* name) {
    uint32_t n = 0;
    if (vkEnumerateInstanceExtensionProperties(nullptr, &n, nullptr) != VK_SUCCESS) return false;
    std::vector<VkExtensionProperties> exts(n);
    if (vkEnumerateInstanceExtensionProperties(nullptr, &n, exts.data()) != VK_SUCCESS)
        return false;
    for (const VkExtensionProperties& e : exts)
        if (std::strcmp(e.extensionName, name) == 0) return true;
    return false;
}

}  // namespace

Result<std::vector<VulkanDisplayInfo>> list_vulkan_displays() {
    std::vector<VulkanDisplayInfo> out;
    if (!instance_extension(VK_KHR_DISPLAY_EXTENSION_NAME)) return out;
    const char* exts[] = {VK_KHR_SURFACE_EXTENSION_NAME, VK_KHR_DISPLAY_EXTENSION_NAME};
    VkApplicationInfo app{};
    app.sType = VK_STRUCTURE_TYPE_APPLICATION_INFO;
    app.pApplicationName = "hmdnode";
    app.apiVersion = VK_API_VERSION_1_1;
    VkInstanceCreateInfo ci{};
    ci.sType = VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO;
    ci.pApplicationInfo = &app;
    ci.enabledExtensionCount = 2;
    ci.ppEnabledExtensionNames = exts;
    VkInstance instance = VK_NULL_HANDLE;
    const VkResult r = vkCreateInstance(&ci, nullptr, &instance);
    if (r == VK_ERROR_INCOMPATIBLE_DRIVER)
        return make_error("Vulkan: no driver (ICD) installed; install mesa-vulkan-drivers");
    if (r != VK_SUCCESS)
        return make_error("Vulkan: vkCreateInstance with VK_KHR_display failed (" +
                          std::to_string(int(r)) + ")");
    uint32_t ngpu = 0;
    vkEnumeratePhysicalDevices(instance, &ngpu, nullptr);
    std::vector<VkPhysicalDevice> gpus(ngpu);
    vkEnumeratePhysicalDevices(instance, &ngpu, gpus.data());
    for (VkPhysicalDevice gpu : gpus) {
        VkPhysicalDeviceProperties gp{};
        vkGetPhysicalDeviceProperties(gpu, &gp);
        uint32_t nd = 0;
        if (vkGetPhysicalDeviceDisplayPropertiesKHR(gpu, &nd, nullptr) != VK_SUCCESS) continue;
        std::vector<VkDisplayPropertiesKHR> ds(nd);
        vkGetPhysicalDeviceDisplayPropertiesKHR(gpu, &nd, ds.data());
        for (const VkDisplayPropertiesKHR& d : ds) {
            VulkanDisplayInfo info;
            info.gpu = gp.deviceName;
            info.name = d.displayName ? d.displayName : "";
            info.width = int(d.physicalResolution.width);
            info.height = int(d.physicalResolution.height);
            uint32_t nm = 0;
            vkGetDisplayModePropertiesKHR(gpu, d.display, &nm, nullptr);
            std::vector<VkDisplayModePropertiesKHR> ms(nm);
            vkGetDisplayModePropertiesKHR(gpu, d.display, &nm, ms.data());
            for (const VkDisplayModePropertiesKHR& m : ms)
                info.modes.push_back({int(m.parameters.visibleRegion.width),
                                      int(m.parameters.visibleRegion.height),
                                      m.parameters.refreshRate / 1000.0});
            out.push_back(std::move(info));
        }
    }
    vkDestroyInstance(instance, nullptr);
    return out;
}

Result<VulkanDisplayInfo> choose_vulkan_display(const std::vector<VulkanDisplayInfo>& displays,
                                                const std::string& want) {
    std::vector<const VulkanDisplayInfo*> hits;
    for (const VulkanDisplayInfo& d : displays)
        if (want.empty() || d.name.find(want) != std::string::npos ||
            d.gpu.find(want) != std::string::npos)
            hits.push_back(&d);
    if (hits.size() == 1) return *hits[0];
    std::string found;
    for (const VulkanDisplayInfo& d : displays)
        found += (found.empty() ? "" : ", ") + ("\"" + d.name + "\" on " + d.gpu);
    return make_error(
        std::string("display.type vk-display: ") +
        (want.empty() ? "no single Vulkan display"
                      : "no single Vulkan display matches display.connector \"" + want + "\"") +
        "; displays found: " + (found.empty() ? "none" : found) +
        (displays.empty() ? " (no driver exposes a display through VK_KHR_display; "
                            "lavapipe never does: use display.type \"kms\")"
                          : ""));
}

}  // namespace hmdnode
