// Owning wrappers of Vulkan objects: a generic move-only handle, buffers and images with their
// own memory allocation (one vkAllocateMemory each: scenes have few, large resources), image views
// and the bilinear sampler. Creation allocates; nothing here runs on the frame path except
// map-less accessors.
#pragma once

#include <vulkan/vulkan.h>

#include <cstddef>
#include <span>
#include <utility>

#include "hmdnode/core/result.hpp"
#include "vk_device.hpp"

namespace hmdnode::vk {

template <class T>
using DestroyFn = void (*)(VkDevice, T, const VkAllocationCallbacks*);

// A non-dispatchable Vulkan object destroyed with `destroy` when the handle goes.
template <class T, DestroyFn<T> destroy>
class Handle {
  public:
    Handle() = default;
    Handle(VkDevice device, T handle) : device_(device), handle_(handle) {}
    Handle(const Handle&) = delete;
    Handle& operator=(const Handle&) = delete;
    Handle(Handle&& o) noexcept
        : device_(o.device_), handle_(std::exchange(o.handle_, VK_NULL_HANDLE)) {}
    Handle& operator=(Handle&& o) noexcept {
        if (this != &o) {
            reset();
            device_ = o.device_;
            handle_ = std::exchange(o.handle_, VK_NULL_HANDLE);
        }
        return *this;
    }
    ~Handle() { reset(); }

    void reset() {
        if (handle_ != VK_NULL_HANDLE) destroy(device_, handle_, nullptr);
        handle_ = VK_NULL_HANDLE;
    }
    T get() const { return handle_; }
    operator T() const { return handle_; }

  private:
    VkDevice device_ = VK_NULL_HANDLE;
    T handle_ = VK_NULL_HANDLE;
};

using ShaderModule = Handle<VkShaderModule, vkDestroyShaderModule>;
using DescriptorSetLayout = Handle<VkDescriptorSetLayout, vkDestroyDescriptorSetLayout>;
using DescriptorPool = Handle<VkDescriptorPool, vkDestroyDescriptorPool>;
using PipelineLayout = Handle<VkPipelineLayout, vkDestroyPipelineLayout>;
using Pipeline = Handle<VkPipeline, vkDestroyPipeline>;
using RenderPass = Handle<VkRenderPass, vkDestroyRenderPass>;
using Framebuffer = Handle<VkFramebuffer, vkDestroyFramebuffer>;
using Sampler = Handle<VkSampler, vkDestroySampler>;
using ImageView = Handle<VkImageView, vkDestroyImageView>;
using Fence = Handle<VkFence, vkDestroyFence>;

// Where a buffer lives.
enum class MemoryUse {
    DeviceLocal,  // GPU memory; host-visible too when the device has such memory (lavapipe, UMA)
    Upload,       // host-visible, written by the CPU, read by the GPU (mapped)
    Readback,     // host-visible, preferably cached, written by the GPU, read by the CPU (mapped)
};

class Buffer {
  public:
    Buffer() = default;
    Buffer(const Buffer&) = delete;
    Buffer& operator=(const Buffer&) = delete;
    Buffer(Buffer&& o) noexcept { *this = std::move(o); }
    Buffer& operator=(Buffer&& o) noexcept;
    ~Buffer() { reset(); }
    void reset();

    VkBuffer get() const { return buffer_; }
    VkDeviceSize size() const { return size_; }
    // Persistently mapped pointer, null when the memory is not host-visible.
    void* mapped() const { return mapped_; }
    // For non-coherent memory: makes CPU writes visible to the device / device writes to the CPU.
    Status flush() const;
    Status invalidate() const;

    friend Result<Buffer> create_buffer(const DeviceContext& ctx, VkDeviceSize size,
                                        VkBufferUsageFlags usage, MemoryUse use, const char* what);

  private:
    VkDevice device_ = VK_NULL_HANDLE;
    VkBuffer buffer_ = VK_NULL_HANDLE;
    VkDeviceMemory memory_ = VK_NULL_HANDLE;
    VkDeviceSize size_ = 0;
    void* mapped_ = nullptr;
    bool coherent_ = true;
};

// `what` names the buffer in error messages. size > 0.
Result<Buffer> create_buffer(const DeviceContext& ctx, VkDeviceSize size, VkBufferUsageFlags usage,
                             MemoryUse use, const char* what);

// A device-local buffer holding `bytes`: written through the mapping when the memory is
// host-visible, else through a staging buffer and a copy (the call then waits for the GPU).
Result<Buffer> create_buffer_with_data(DeviceContext& ctx, std::span<const std::byte> bytes,
                                       VkBufferUsageFlags usage, const char* what);

struct ImageDesc {
    uint32_t width = 1, height = 1, layers = 1;
    VkFormat format = VK_FORMAT_R8G8B8A8_UNORM;
    VkImageUsageFlags usage = 0;
    VkImageCreateFlags flags = 0;  // e.g. MUTABLE_FORMAT for sRGB + UNORM views of one image
    VkSampleCountFlagBits samples = VK_SAMPLE_COUNT_1_BIT;  // > 1: a multisampled attachment
};

// A 2D (array) image with optimal tiling in device-local memory.
class Image {
  public:
    Image() = default;
    Image(const Image&) = delete;
    Image& operator=(const Image&) = delete;
    Image(Image&& o) noexcept { *this = std::move(o); }
    Image& operator=(Image&& o) noexcept;
    ~Image() { reset(); }
    void reset();

    VkImage get() const { return image_; }
    const ImageDesc& desc() const { return desc_; }

    friend Result<Image> create_image(const DeviceContext& ctx, const ImageDesc& desc,
                                      const char* what);

  private:
    VkDevice device_ = VK_NULL_HANDLE;
    VkImage image_ = VK_NULL_HANDLE;
    VkDeviceMemory memory_ = VK_NULL_HANDLE;
    ImageDesc desc_;
};

Result<Image> create_image(const DeviceContext& ctx, const ImageDesc& desc, const char* what);

// A view of layer_count layers of `image` from base_layer (0 = all), 2D for one layer and 2D array
// for more, in `format`.
Result<ImageView> create_view(const DeviceContext& ctx, const Image& image, VkFormat format,
                              VkImageAspectFlags aspect, const char* what, uint32_t base_layer = 0,
                              uint32_t layer_count = 0);

// A bilinear sampler: linear minification and magnification, nearest mip level, level 0 only,
// `address` on all three axes. `what` names the call in errors.
Result<Sampler> create_sampler(const DeviceContext& ctx, VkSamplerAddressMode address,
                               const char* what);

// Records a copy of `layers` layers of a colour image (TRANSFER_SRC_OPTIMAL) into a host-visible
// buffer, layer after layer, rows top to bottom, and the barrier that makes it visible to the host.
void record_copy_to_host(VkCommandBuffer cmd, VkImage image, uint32_t width, uint32_t height,
                         uint32_t layers, const Buffer& buffer);

}  // namespace hmdnode::vk
