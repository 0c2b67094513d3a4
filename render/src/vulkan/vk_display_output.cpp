// VK_KHR_display present path (Vulkan spec, "WSI: Display enumeration" and "Display surfaces",
// VK_KHR_present_wait): the chosen display's mode on the first plane that can show that display
// (vkGetDisplayPlaneSupportedDisplaysKHR) and is free or already on it, a display plane surface,
// a queue family that can present to it, and a swapchain in FIFO mode (the one mode every driver
// has: one image per vsync, never torn). Each present copies the CPU frame into a host-visible
// staging buffer, records a buffer-to-image copy with the layout transitions into the acquired
// image, submits and presents it with a VkPresentIdKHR; with VK_KHR_present_wait,
// vkWaitForPresentKHR then blocks until the image is on the display, so the time present()
// returns at is the vsync it showed at. Cost per present: one copy of the panel image on the CPU
// and one on the device; one frame in flight.
#include <vulkan/vulkan.h>

#include <algorithm>
#include <cstring>
#include <string>
#include <vector>

#include "hmdnode/render/vk_display.hpp"
#include "vk_check.hpp"
#include "vk_display_list.hpp"

namespace hmdnode {
namespace {

bool device_extension(VkPhysicalDevice gpu, const char* name) {
    uint32_t n = 0;
    vkEnumerateDeviceExtensionProperties(gpu, nullptr, &n, nullptr);
    std::vector<VkExtensionProperties> exts(n);
    vkEnumerateDeviceExtensionProperties(gpu, nullptr, &n, exts.data());
    for (const VkExtensionProperties& e : exts)
        if (std::strcmp(e.extensionName, name) == 0) return true;
    return false;
}

class Output final : public VulkanDisplayOutput {
  public:
    ~Output() override {
        if (device_) {
            vkDeviceWaitIdle(device_);
            if (fence_) vkDestroyFence(device_, fence_, nullptr);
            if (acquired_) vkDestroySemaphore(device_, acquired_, nullptr);
            if (copied_) vkDestroySemaphore(device_, copied_, nullptr);
            if (pool_) vkDestroyCommandPool(device_, pool_, nullptr);
            if (buffer_) vkDestroyBuffer(device_, buffer_, nullptr);
            if (memory_) vkFreeMemory(device_, memory_, nullptr);
            if (swapchain_) vkDestroySwapchainKHR(device_, swapchain_, nullptr);
            vkDestroyDevice(device_, nullptr);
        }
        if (surface_) vkDestroySurfaceKHR(instance_, surface_, nullptr);
        if (instance_) vkDestroyInstance(instance_, nullptr);
    }

    Status init(const VulkanDisplayOutputConfig& config) {
        Result<VkInstance> instance = vkdisplay::create_instance();
        if (!instance.ok()) return instance.error();
        instance_ = *instance;
        std::vector<vkdisplay::FoundDisplay> found;
        if (instance_) found = vkdisplay::enumerate(instance_);
        std::vector<VulkanDisplayInfo> infos;
        for (const vkdisplay::FoundDisplay& f : found) infos.push_back(f.info);
        Result<VulkanDisplayInfo> chosen = choose_vulkan_display(infos, config.display);
        if (!chosen.ok()) return chosen.error();
        const vkdisplay::FoundDisplay* d = nullptr;
        for (const vkdisplay::FoundDisplay& f : found)
            if (f.info.name == chosen->name && f.info.gpu == chosen->gpu) d = &f;
        info_ = d->info;
        gpu_ = d->gpu;
        Result<size_t> m =
            choose_vulkan_display_mode(info_, config.width, config.height, config.refresh_hz);
        if (!m.ok()) return m.error();
        mode_ = info_.modes[*m];
        const std::string where = "Vulkan display \"" + info_.name + "\" on " + info_.gpu;

        // A plane that can show the display, free or already showing it.
        uint32_t nplanes = 0;
        vkGetPhysicalDeviceDisplayPlanePropertiesKHR(gpu_, &nplanes, nullptr);
        std::vector<VkDisplayPlanePropertiesKHR> planes(nplanes);
        vkGetPhysicalDeviceDisplayPlanePropertiesKHR(gpu_, &nplanes, planes.data());
        int plane = -1;
        for (uint32_t i = 0; i < nplanes && plane < 0; ++i) {
            if (planes[i].currentDisplay != VK_NULL_HANDLE &&
                planes[i].currentDisplay != d->display)
                continue;
            uint32_t nd = 0;
            vkGetDisplayPlaneSupportedDisplaysKHR(gpu_, i, &nd, nullptr);
            std::vector<VkDisplayKHR> ds(nd);
            vkGetDisplayPlaneSupportedDisplaysKHR(gpu_, i, &nd, ds.data());
            for (VkDisplayKHR x : ds)
                if (x == d->display) plane = int(i);
        }
        if (plane < 0)
            return make_error(where + ": none of its GPU's " + std::to_string(nplanes) +
                              " display planes can show it (all in use by other displays?)");
        VkDisplayPlaneCapabilitiesKHR caps{};
        HMDNODE_VK_TRY(vkGetDisplayPlaneCapabilitiesKHR(gpu_, d->modes[*m], uint32_t(plane), &caps),
                       "vkGetDisplayPlaneCapabilitiesKHR");
        VkDisplaySurfaceCreateInfoKHR sci{};
        sci.sType = VK_STRUCTURE_TYPE_DISPLAY_SURFACE_CREATE_INFO_KHR;
        sci.displayMode = d->modes[*m];
        sci.planeIndex = uint32_t(plane);
        sci.planeStackIndex = planes[size_t(plane)].currentStackIndex;
        sci.transform = VK_SURFACE_TRANSFORM_IDENTITY_BIT_KHR;
        sci.globalAlpha = 1.0f;
        sci.alphaMode =
            (caps.supportedAlpha & VK_DISPLAY_PLANE_ALPHA_OPAQUE_BIT_KHR)
                ? VK_DISPLAY_PLANE_ALPHA_OPAQUE_BIT_KHR
                : VkDisplayPlaneAlphaFlagBitsKHR(caps.supportedAlpha & -caps.supportedAlpha);
        sci.imageExtent = {uint32_t(mode_.width), uint32_t(mode_.height)};
        HMDNODE_VK_TRY(vkCreateDisplayPlaneSurfaceKHR(instance_, &sci, nullptr, &surface_),
                       "vkCreateDisplayPlaneSurfaceKHR");

        // A queue family that can copy (every graphics or transfer one) and present there.
        uint32_t nq = 0;
        vkGetPhysicalDeviceQueueFamilyProperties(gpu_, &nq, nullptr);
        std::vector<VkQueueFamilyProperties> qs(nq);
        vkGetPhysicalDeviceQueueFamilyProperties(gpu_, &nq, qs.data());
        int family = -1;
        for (uint32_t i = 0; i < nq && family < 0; ++i) {
            VkBool32 ok = VK_FALSE;
            vkGetPhysicalDeviceSurfaceSupportKHR(gpu_, i, surface_, &ok);
            if (ok && (qs[i].queueFlags & (VK_QUEUE_GRAPHICS_BIT | VK_QUEUE_TRANSFER_BIT)))
                family = int(i);
        }
        if (family < 0) return make_error(where + ": no queue family can present to it");
        if (!device_extension(gpu_, VK_KHR_SWAPCHAIN_EXTENSION_NAME))
            return make_error(where + ": its GPU has no VK_KHR_swapchain");

        // VK_KHR_present_id + VK_KHR_present_wait where offered (both, with their features).
        VkPhysicalDevicePresentIdFeaturesKHR id_features{};
        id_features.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PRESENT_ID_FEATURES_KHR;
        VkPhysicalDevicePresentWaitFeaturesKHR wait_features{};
        wait_features.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PRESENT_WAIT_FEATURES_KHR;
        if (device_extension(gpu_, VK_KHR_PRESENT_ID_EXTENSION_NAME) &&
            device_extension(gpu_, VK_KHR_PRESENT_WAIT_EXTENSION_NAME)) {
            id_features.pNext = &wait_features;
            VkPhysicalDeviceFeatures2 f2{};
            f2.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2;
            f2.pNext = &id_features;
            vkGetPhysicalDeviceFeatures2(gpu_, &f2);
            present_wait_ = id_features.presentId && wait_features.presentWait;
        }
        std::vector<const char*> exts = {VK_KHR_SWAPCHAIN_EXTENSION_NAME};
        if (present_wait_) {
            exts.push_back(VK_KHR_PRESENT_ID_EXTENSION_NAME);
            exts.push_back(VK_KHR_PRESENT_WAIT_EXTENSION_NAME);
        }
        const float priority = 1.0f;
        VkDeviceQueueCreateInfo qci{};
        qci.sType = VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO;
        qci.queueFamilyIndex = uint32_t(family);
        qci.queueCount = 1;
        qci.pQueuePriorities = &priority;
        VkDeviceCreateInfo dci{};
        dci.sType = VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO;
        dci.pNext = present_wait_ ? &id_features : nullptr;
        id_features.pNext = &wait_features;
        wait_features.pNext = nullptr;
        dci.queueCreateInfoCount = 1;
        dci.pQueueCreateInfos = &qci;
        dci.enabledExtensionCount = uint32_t(exts.size());
        dci.ppEnabledExtensionNames = exts.data();
        HMDNODE_VK_TRY(vkCreateDevice(gpu_, &dci, nullptr, &device_), "vkCreateDevice (display)");
        vkGetDeviceQueue(device_, uint32_t(family), 0, &queue_);
        if (present_wait_)
            wait_for_present_ = reinterpret_cast<PFN_vkWaitForPresentKHR>(
                vkGetDeviceProcAddr(device_, "vkWaitForPresentKHR"));
        present_wait_ = wait_for_present_ != nullptr;

        if (Status st = create_swapchain(where); !st.ok()) return st;
        return create_staging();
    }

    const VulkanDisplayInfo& display() const override { return info_; }
    VulkanDisplayMode mode() const override { return mode_; }
    bool present_wait() const override { return present_wait_; }
    std::string describe() const override { return description_; }

    Status present(const ImageRGBA8& image) override {
        if (image.width != int(extent_.width) || image.height != int(extent_.height))
            return make_error("vk-display present: a " + std::to_string(image.width) + "x" +
                              std::to_string(image.height) + " frame for the " +
                              std::to_string(extent_.width) + "x" + std::to_string(extent_.height) +
                              " swapchain");
        // One frame in flight: the copy before has left the staging buffer.
        HMDNODE_VK_TRY(vkWaitForFences(device_, 1, &fence_, VK_TRUE, UINT64_MAX),
                       "vkWaitForFences (display)");
        uint32_t index = 0;
        VkResult r = vkAcquireNextImageKHR(device_, swapchain_, UINT64_MAX, acquired_,
                                           VK_NULL_HANDLE, &index);
        if (r != VK_SUCCESS && r != VK_SUBOPTIMAL_KHR) return lost("vkAcquireNextImageKHR", r);
        vkResetFences(device_, 1, &fence_);
        // RGBA8 rows into the swapchain's layout (B8G8R8A8 swaps red and blue).
        auto* dst = static_cast<uint8_t*>(mapped_);
        const size_t n = size_t(image.width) * size_t(image.height);
        if (bgra_) {
            for (size_t i = 0; i < n; ++i) {
                const uint8_t* s = image.pixels.data() + 4 * i;
                dst[4 * i + 0] = s[2];
                dst[4 * i + 1] = s[1];
                dst[4 * i + 2] = s[0];
                dst[4 * i + 3] = 255;
            }
        } else {
            std::memcpy(dst, image.pixels.data(), 4 * n);
        }
        if (!coherent_) {
            VkMappedMemoryRange range{};
            range.sType = VK_STRUCTURE_TYPE_MAPPED_MEMORY_RANGE;
            range.memory = memory_;
            range.size = VK_WHOLE_SIZE;
            vkFlushMappedMemoryRanges(device_, 1, &range);
        }
        vkResetCommandBuffer(cmd_, 0);
        VkCommandBufferBeginInfo bi{};
        bi.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
        bi.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
        vkBeginCommandBuffer(cmd_, &bi);
        VkImageMemoryBarrier b{};
        b.sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER;
        b.srcQueueFamilyIndex = b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
        b.image = images_[index];
        b.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
        b.oldLayout = VK_IMAGE_LAYOUT_UNDEFINED;
        b.newLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
        b.dstAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
        vkCmdPipelineBarrier(cmd_, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT,
                             0, 0, nullptr, 0, nullptr, 1, &b);
        VkBufferImageCopy copy{};
        copy.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
        copy.imageExtent = {extent_.width, extent_.height, 1};
        vkCmdCopyBufferToImage(cmd_, buffer_, images_[index], VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                               1, &copy);
        b.oldLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
        b.newLayout = VK_IMAGE_LAYOUT_PRESENT_SRC_KHR;
        b.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
        b.dstAccessMask = 0;
        vkCmdPipelineBarrier(cmd_, VK_PIPELINE_STAGE_TRANSFER_BIT,
                             VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, 0, 0, nullptr, 0, nullptr, 1,
                             &b);
        HMDNODE_VK_TRY(vkEndCommandBuffer(cmd_), "vkEndCommandBuffer (display)");
        const VkPipelineStageFlags wait_stage = VK_PIPELINE_STAGE_TRANSFER_BIT;
        VkSubmitInfo si{};
        si.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
        si.waitSemaphoreCount = 1;
        si.pWaitSemaphores = &acquired_;
        si.pWaitDstStageMask = &wait_stage;
        si.commandBufferCount = 1;
        si.pCommandBuffers = &cmd_;
        si.signalSemaphoreCount = 1;
        si.pSignalSemaphores = &copied_;
        HMDNODE_VK_TRY(vkQueueSubmit(queue_, 1, &si, fence_), "vkQueueSubmit (display)");
        const uint64_t id = ++present_id_;
        VkPresentIdKHR pid{};
        pid.sType = VK_STRUCTURE_TYPE_PRESENT_ID_KHR;
        pid.swapchainCount = 1;
        pid.pPresentIds = &id;
        VkPresentInfoKHR pi{};
        pi.sType = VK_STRUCTURE_TYPE_PRESENT_INFO_KHR;
        pi.pNext = present_wait_ ? &pid : nullptr;
        pi.waitSemaphoreCount = 1;
        pi.pWaitSemaphores = &copied_;
        pi.swapchainCount = 1;
        pi.pSwapchains = &swapchain_;
        pi.pImageIndices = &index;
        r = vkQueuePresentKHR(queue_, &pi);
        if (r != VK_SUCCESS && r != VK_SUBOPTIMAL_KHR) return lost("vkQueuePresentKHR", r);
        if (present_wait_) {
            r = wait_for_present_(device_, swapchain_, id, 1'000'000'000);  // 1 s
            if (r == VK_TIMEOUT)
                return make_error("vk-display: present " + std::to_string(id) +
                                  " not shown within 1 s (vkWaitForPresentKHR)");
            if (r != VK_SUCCESS && r != VK_SUBOPTIMAL_KHR) return lost("vkWaitForPresentKHR", r);
        }
        return {};
    }

  private:
    Status lost(const char* what, VkResult r) {
        if (r == VK_ERROR_OUT_OF_DATE_KHR || r == VK_ERROR_SURFACE_LOST_KHR)
            return make_error(std::string("vk-display: ") + what + ": " + vk::result_name(r) +
                              ": the display \"" + info_.name +
                              "\" was lost (unplugged, or its mode changed)");
        return vk::vk_error(what, r);
    }

    Status create_swapchain(const std::string& where) {
        VkSurfaceCapabilitiesKHR caps{};
        HMDNODE_VK_TRY(vkGetPhysicalDeviceSurfaceCapabilitiesKHR(gpu_, surface_, &caps),
                       "vkGetPhysicalDeviceSurfaceCapabilitiesKHR");
        if (!(caps.supportedUsageFlags & VK_IMAGE_USAGE_TRANSFER_DST_BIT))
            return make_error(where + ": its swapchain images cannot be copied to");
        uint32_t nf = 0;
        vkGetPhysicalDeviceSurfaceFormatsKHR(gpu_, surface_, &nf, nullptr);
        std::vector<VkSurfaceFormatKHR> formats(nf);
        vkGetPhysicalDeviceSurfaceFormatsKHR(gpu_, surface_, &nf, formats.data());
        // The frames are sRGB-encoded already: a UNORM format passes them through unchanged.
        const VkSurfaceFormatKHR* format = nullptr;
        for (const VkSurfaceFormatKHR& f : formats)
            if (!format &&
                (f.format == VK_FORMAT_B8G8R8A8_UNORM || f.format == VK_FORMAT_R8G8B8A8_UNORM))
                format = &f;
        if (!format) {
            std::string list;
            for (const VkSurfaceFormatKHR& f : formats)
                list += (list.empty() ? "" : ", ") + std::to_string(int(f.format));
            return make_error(where +
                              ": no B8G8R8A8_UNORM or R8G8B8A8_UNORM swapchain format "
                              "(VkFormat values offered: " +
                              (list.empty() ? "none" : list) + ")");
        }
        bgra_ = format->format == VK_FORMAT_B8G8R8A8_UNORM;
        extent_ = caps.currentExtent.width != UINT32_MAX
                      ? caps.currentExtent
                      : VkExtent2D{uint32_t(mode_.width), uint32_t(mode_.height)};
        uint32_t count = std::max(caps.minImageCount, 3u);
        if (caps.maxImageCount && count > caps.maxImageCount) count = caps.maxImageCount;
        VkSwapchainCreateInfoKHR ci{};
        ci.sType = VK_STRUCTURE_TYPE_SWAPCHAIN_CREATE_INFO_KHR;
        ci.surface = surface_;
        ci.minImageCount = count;
        ci.imageFormat = format->format;
        ci.imageColorSpace = format->colorSpace;
        ci.imageExtent = extent_;
        ci.imageArrayLayers = 1;
        ci.imageUsage = VK_IMAGE_USAGE_TRANSFER_DST_BIT;
        ci.imageSharingMode = VK_SHARING_MODE_EXCLUSIVE;
        ci.preTransform = VK_SURFACE_TRANSFORM_IDENTITY_BIT_KHR;
        ci.compositeAlpha = VK_COMPOSITE_ALPHA_OPAQUE_BIT_KHR;
        ci.presentMode = VK_PRESENT_MODE_FIFO_KHR;  // required of every driver
        ci.clipped = VK_TRUE;
        HMDNODE_VK_TRY(vkCreateSwapchainKHR(device_, &ci, nullptr, &swapchain_),
                       "vkCreateSwapchainKHR (display)");
        uint32_t ni = 0;
        vkGetSwapchainImagesKHR(device_, swapchain_, &ni, nullptr);
        images_.resize(ni);
        vkGetSwapchainImagesKHR(device_, swapchain_, &ni, images_.data());
        description_ = std::string(bgra_ ? "B8G8R8A8_UNORM" : "R8G8B8A8_UNORM") + ", " +
                       std::to_string(ni) + " images, FIFO, " +
                       (present_wait_ ? "present_wait" : "no present_wait");
        return {};
    }

    Status create_staging() {
        VkBufferCreateInfo bci{};
        bci.sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO;
        bci.size = VkDeviceSize(extent_.width) * extent_.height * 4;
        bci.usage = VK_BUFFER_USAGE_TRANSFER_SRC_BIT;
        HMDNODE_VK_TRY(vkCreateBuffer(device_, &bci, nullptr, &buffer_),
                       "vkCreateBuffer (display staging)");
        VkMemoryRequirements req{};
        vkGetBufferMemoryRequirements(device_, buffer_, &req);
        VkPhysicalDeviceMemoryProperties mp{};
        vkGetPhysicalDeviceMemoryProperties(gpu_, &mp);
        int type = -1;
        for (int pass = 0; pass < 2 && type < 0; ++pass)
            for (uint32_t i = 0; i < mp.memoryTypeCount && type < 0; ++i) {
                const VkMemoryPropertyFlags f = mp.memoryTypes[i].propertyFlags;
                const VkMemoryPropertyFlags want =
                    VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT |
                    (pass == 0 ? VK_MEMORY_PROPERTY_HOST_COHERENT_BIT : 0);
                if ((req.memoryTypeBits & (1u << i)) && (f & want) == want) type = int(i);
            }
        if (type < 0)
            return make_error("vk-display: no host-visible memory for the staging buffer");
        coherent_ = mp.memoryTypes[type].propertyFlags & VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
        VkMemoryAllocateInfo ai{};
        ai.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO;
        ai.allocationSize = req.size;
        ai.memoryTypeIndex = uint32_t(type);
        HMDNODE_VK_TRY(vkAllocateMemory(device_, &ai, nullptr, &memory_),
                       "vkAllocateMemory (display staging)");
        HMDNODE_VK_TRY(vkBindBufferMemory(device_, buffer_, memory_, 0), "vkBindBufferMemory");
        HMDNODE_VK_TRY(vkMapMemory(device_, memory_, 0, VK_WHOLE_SIZE, 0, &mapped_),
                       "vkMapMemory (display staging)");
        VkCommandPoolCreateInfo pci{};
        pci.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
        pci.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
        HMDNODE_VK_TRY(vkCreateCommandPool(device_, &pci, nullptr, &pool_), "vkCreateCommandPool");
        VkCommandBufferAllocateInfo cai{};
        cai.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
        cai.commandPool = pool_;
        cai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
        cai.commandBufferCount = 1;
        HMDNODE_VK_TRY(vkAllocateCommandBuffers(device_, &cai, &cmd_), "vkAllocateCommandBuffers");
        VkSemaphoreCreateInfo sci{};
        sci.sType = VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO;
        HMDNODE_VK_TRY(vkCreateSemaphore(device_, &sci, nullptr, &acquired_), "vkCreateSemaphore");
        HMDNODE_VK_TRY(vkCreateSemaphore(device_, &sci, nullptr, &copied_), "vkCreateSemaphore");
        VkFenceCreateInfo fci{};
        fci.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
        fci.flags = VK_FENCE_CREATE_SIGNALED_BIT;
        HMDNODE_VK_TRY(vkCreateFence(device_, &fci, nullptr, &fence_), "vkCreateFence");
        return {};
    }

    VulkanDisplayInfo info_;
    VulkanDisplayMode mode_;
    std::string description_;
    VkInstance instance_ = VK_NULL_HANDLE;
    VkPhysicalDevice gpu_ = VK_NULL_HANDLE;
    VkSurfaceKHR surface_ = VK_NULL_HANDLE;
    VkDevice device_ = VK_NULL_HANDLE;
    VkQueue queue_ = VK_NULL_HANDLE;
    VkSwapchainKHR swapchain_ = VK_NULL_HANDLE;
    std::vector<VkImage> images_;
    VkExtent2D extent_{};
    bool bgra_ = true, coherent_ = true, present_wait_ = false;
    PFN_vkWaitForPresentKHR wait_for_present_ = nullptr;
    uint64_t present_id_ = 0;
    VkBuffer buffer_ = VK_NULL_HANDLE;
    VkDeviceMemory memory_ = VK_NULL_HANDLE;
    void* mapped_ = nullptr;
    VkCommandPool pool_ = VK_NULL_HANDLE;
    VkCommandBuffer cmd_ = VK_NULL_HANDLE;
    VkSemaphore acquired_ = VK_NULL_HANDLE, copied_ = VK_NULL_HANDLE;
    VkFence fence_ = VK_NULL_HANDLE;
};

}  // namespace

Result<std::unique_ptr<VulkanDisplayOutput>> create_vulkan_display_output(
    const VulkanDisplayOutputConfig& config) {
    auto out = std::make_unique<Output>();
    if (Status st = out->init(config); !st.ok()) return st.error();
    return std::unique_ptr<VulkanDisplayOutput>(std::move(out));
}

}  // namespace hmdnode
