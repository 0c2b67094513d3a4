// VK_KHR_display enumeration (Vulkan spec, "WSI: Display enumeration"): an instance with
// VK_KHR_surface + VK_KHR_display, then per physical device vkGetPhysicalDeviceDisplayPropertiesKHR
// and per display vkGetDisplayModePropertiesKHR. Cost: one instance creation (milliseconds).
#include "hmdnode/render/vk_display.hpp"

#include <vulkan/vulkan.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <optional>

#include "vk_display_list.hpp"

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

namespace vkdisplay {

Result<VkInstance> create_instance() {
    if (!instance_extension(VK_KHR_DISPLAY_EXTENSION_NAME)) return VkInstance{VK_NULL_HANDLE};
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
    return instance;
}

std::vector<FoundDisplay> enumerate(VkInstance instance) {
    std::vector<FoundDisplay> out;
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
            FoundDisplay f;
            f.gpu = gpu;
            f.display = d.display;
            f.info.gpu = gp.deviceName;
            f.info.name = d.displayName ? d.displayName : "";
            f.info.width = int(d.physicalResolution.width);
            f.info.height = int(d.physicalResolution.height);
            uint32_t nm = 0;
            vkGetDisplayModePropertiesKHR(gpu, d.display, &nm, nullptr);
            std::vector<VkDisplayModePropertiesKHR> ms(nm);
            vkGetDisplayModePropertiesKHR(gpu, d.display, &nm, ms.data());
            for (const VkDisplayModePropertiesKHR& m : ms) {
                f.modes.push_back(m.displayMode);
                f.info.modes.push_back({int(m.parameters.visibleRegion.width),
                                        int(m.parameters.visibleRegion.height),
                                        m.parameters.refreshRate / 1000.0});
            }
            out.push_back(std::move(f));
        }
    }
    return out;
}

}  // namespace vkdisplay

Result<std::vector<VulkanDisplayInfo>> list_vulkan_displays() {
    Result<VkInstance> instance = vkdisplay::create_instance();
    if (!instance.ok()) return instance.error();
    std::vector<VulkanDisplayInfo> out;
    if (*instance == VK_NULL_HANDLE) return out;
    for (vkdisplay::FoundDisplay& f : vkdisplay::enumerate(*instance))
        out.push_back(std::move(f.info));
    vkDestroyInstance(*instance, nullptr);
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

Result<size_t> choose_vulkan_display_mode(const VulkanDisplayInfo& display, int width, int height,
                                          double refresh_hz) {
    const bool any = width == 0 && height == 0 && refresh_hz == 0.0;
    const int w = any ? display.width : width, h = any ? display.height : height;
    std::optional<size_t> best;
    for (size_t i = 0; i < display.modes.size(); ++i) {
        const VulkanDisplayMode& m = display.modes[i];
        if ((w && m.width != w) || (h && m.height != h)) continue;
        if (refresh_hz > 0.0 && std::fabs(m.refresh_hz - refresh_hz) > 0.5) continue;
        if (!best || m.refresh_hz > display.modes[*best].refresh_hz) best = i;
    }
    if (!best && any && !display.modes.empty()) best = 0;
    if (best) {
        // The driver's refresh gives the vsync grid (firmware_host's pacing): none, no grid.
        const VulkanDisplayMode& m = display.modes[*best];
        if (!(m.refresh_hz >= 1.0 && m.refresh_hz <= 1000.0)) {
            char b[96];
            std::snprintf(b, sizeof b, "%dx%d reports a refresh rate of %.3f Hz", m.width, m.height,
                          m.refresh_hz);
            return make_error("display.mode: Vulkan display \"" + display.name + "\" on " +
                              display.gpu + ": mode " + b);
        }
        return *best;
    }
    std::string list;
    for (const VulkanDisplayMode& m : display.modes) {
        char b[64];
        std::snprintf(b, sizeof b, "%s%dx%d@%.2f", list.empty() ? "" : ", ", m.width, m.height,
                      m.refresh_hz);
        list += b;
    }
    char want[64];
    std::snprintf(want, sizeof want, "%dx%d@%.2f", width, height, refresh_hz);
    return make_error("display.mode: Vulkan display \"" + display.name + "\" on " + display.gpu +
                      " has no mode " + want + "; its modes: " + (list.empty() ? "none" : list));
}

}  // namespace hmdnode
