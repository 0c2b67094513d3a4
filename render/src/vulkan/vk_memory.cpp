// Buffers and images with dedicated allocations. Cost: one vkAllocateMemory per object (upload
// and creation time only); staging copies wait for the GPU.
#include "vk_memory.hpp"

#include <cassert>
#include <cstring>
#include <string>

#include "vk_check.hpp"

namespace hmdnode::vk {

Buffer& Buffer::operator=(Buffer&& o) noexcept {
    if (this != &o) {
        reset();
        device_ = o.device_;
        buffer_ = std::exchange(o.buffer_, VK_NULL_HANDLE);
        memory_ = std::exchange(o.memory_, VK_NULL_HANDLE);
        size_ = std::exchange(o.size_, 0);
        mapped_ = std::exchange(o.mapped_, nullptr);
        coherent_ = o.coherent_;
    }
    return *this;
}

void Buffer::reset() {
    if (buffer_) vkDestroyBuffer(device_, buffer_, nullptr);
    if (memory_) vkFreeMemory(device_, memory_, nullptr);  // note: freeing unmaps implicitly
    buffer_ = VK_NULL_HANDLE;
    memory_ = VK_NULL_HANDLE;
    mapped_ = nullptr;
    size_ = 0;
}

Status Buffer::flush() const {
    if (coherent_ || !memory_) return Status::success();
    VkMappedMemoryRange range{VK_STRUCTURE_TYPE_MAPPED_MEMORY_RANGE, nullptr, memory_, 0,
                              VK_WHOLE_SIZE};
    HMDNODE_VK_TRY(vkFlushMappedMemoryRanges(device_, 1, &range), "vkFlushMappedMemoryRanges");
    return Status::success();
}

Status Buffer::invalidate() const {
    if (coherent_ || !memory_) return Status::success();
    VkMappedMemoryRange range{VK_STRUCTURE_TYPE_MAPPED_MEMORY_RANGE, nullptr, memory_, 0,
                              VK_WHOLE_SIZE};
    HMDNODE_VK_TRY(vkInvalidateMappedMemoryRanges(device_, 1, &range),
                   "vkInvalidateMappedMemoryRanges");
    return Status::success();
}

Result<Buffer> create_buffer(const DeviceContext& ctx, VkDeviceSize size, VkBufferUsageFlags usage,
                             MemoryUse use, const char* what) {
    assert(size > 0);
    Buffer b;
    b.device_ = ctx.device;
    VkBufferCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO;
    info.size = size;
    info.usage = usage;
    info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
    HMDNODE_VK_TRY(vkCreateBuffer(ctx.device, &info, nullptr, &b.buffer_),
                   (std::string("vkCreateBuffer (") + what + ")").c_str());
    b.size_ = size;

    VkMemoryRequirements req;
    vkGetBufferMemoryRequirements(ctx.device, b.buffer_, &req);
    int type = -1;
    switch (use) {
        case MemoryUse::DeviceLocal:
            type = ctx.find_memory_type(req.memoryTypeBits, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
            if (type < 0) type = ctx.find_memory_type(req.memoryTypeBits, 0);
            break;
        case MemoryUse::Upload:
            type = ctx.find_memory_type(req.memoryTypeBits, VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT,
                                        VK_MEMORY_PROPERTY_HOST_COHERENT_BIT);
            break;
        case MemoryUse::Readback:
            type = ctx.find_memory_type(req.memoryTypeBits, VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT,
                                        VK_MEMORY_PROPERTY_HOST_CACHED_BIT);
            break;
    }
    if (type < 0) return make_error(std::string("Vulkan: no memory type for ") + what);
    assert(uint32_t(type) < ctx.memory_properties.memoryTypeCount && req.size >= size);
    const VkMemoryPropertyFlags flags = ctx.memory_properties.memoryTypes[type].propertyFlags;

    VkMemoryAllocateInfo alloc{};
    alloc.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO;
    alloc.allocationSize = req.size;
    alloc.memoryTypeIndex = uint32_t(type);
    HMDNODE_VK_TRY(vkAllocateMemory(ctx.device, &alloc, nullptr, &b.memory_),
                   (std::string("vkAllocateMemory (") + what + ")").c_str());
    HMDNODE_VK_TRY(vkBindBufferMemory(ctx.device, b.buffer_, b.memory_, 0), "vkBindBufferMemory");
    b.coherent_ = (flags & VK_MEMORY_PROPERTY_HOST_COHERENT_BIT) != 0;
    if (flags & VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT)
        HMDNODE_VK_TRY(vkMapMemory(ctx.device, b.memory_, 0, VK_WHOLE_SIZE, 0, &b.mapped_),
                       (std::string("vkMapMemory (") + what + ")").c_str());
    // Upload and read-back buffers are what the CPU maps: host-visible by their memory type.
    assert(use == MemoryUse::DeviceLocal || b.mapped_ != nullptr);
    return b;
}

Result<Buffer> create_buffer_with_data(DeviceContext& ctx, std::span<const std::byte> bytes,
                                       VkBufferUsageFlags usage, const char* what) {
    assert(!bytes.empty() && bytes.data() != nullptr);
    auto buffer = create_buffer(ctx, bytes.size(), usage | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                MemoryUse::DeviceLocal, what);
    if (!buffer) return buffer.error();
    if (buffer->mapped()) {
        std::memcpy(buffer->mapped(), bytes.data(), bytes.size());
        if (Status s = buffer->flush(); !s) return s.error();
        return buffer;
    }
    auto staging = create_buffer(ctx, bytes.size(), VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                                 MemoryUse::Upload, "staging");
    if (!staging) return staging.error();
    std::memcpy(staging->mapped(), bytes.data(), bytes.size());
    if (Status s = staging->flush(); !s) return s.error();
    Status s = ctx.submit_and_wait([&](VkCommandBuffer cmd) {
        VkBufferCopy region{0, 0, bytes.size()};
        vkCmdCopyBuffer(cmd, staging->get(), buffer->get(), 1, &region);
    });
    if (!s) return s.error();
    return buffer;
}

Image& Image::operator=(Image&& o) noexcept {
    if (this != &o) {
        reset();
        device_ = o.device_;
        image_ = std::exchange(o.image_, VK_NULL_HANDLE);
        memory_ = std::exchange(o.memory_, VK_NULL_HANDLE);
        desc_ = o.desc_;
    }
    return *this;
}

void Image::reset() {
    if (image_) vkDestroyImage(device_, image_, nullptr);
    if (memory_) vkFreeMemory(device_, memory_, nullptr);
    image_ = VK_NULL_HANDLE;
    memory_ = VK_NULL_HANDLE;
}

Result<Image> create_image(const DeviceContext& ctx, const ImageDesc& desc, const char* what) {
    assert(desc.width >= 1 && desc.height >= 1 && desc.layers >= 1);
    Image img;
    img.device_ = ctx.device;
    img.desc_ = desc;
    VkImageCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO;
    info.flags = desc.flags;
    info.imageType = VK_IMAGE_TYPE_2D;
    info.format = desc.format;
    info.extent = {desc.width, desc.height, 1};
    info.mipLevels = 1;
    info.arrayLayers = desc.layers;
    info.samples = desc.samples;
    info.tiling = VK_IMAGE_TILING_OPTIMAL;
    info.usage = desc.usage;
    info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
    info.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
    HMDNODE_VK_TRY(vkCreateImage(ctx.device, &info, nullptr, &img.image_),
                   (std::string("vkCreateImage (") + what + ")").c_str());

    VkMemoryRequirements req;
    vkGetImageMemoryRequirements(ctx.device, img.image_, &req);
    int type = ctx.find_memory_type(req.memoryTypeBits, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
    if (type < 0) type = ctx.find_memory_type(req.memoryTypeBits, 0);
    if (type < 0) return make_error(std::string("Vulkan: no memory type for ") + what);
    VkMemoryAllocateInfo alloc{};
    alloc.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO;
    alloc.allocationSize = req.size;
    alloc.memoryTypeIndex = uint32_t(type);
    HMDNODE_VK_TRY(vkAllocateMemory(ctx.device, &alloc, nullptr, &img.memory_),
                   (std::string("vkAllocateMemory (") + what + ")").c_str());
    HMDNODE_VK_TRY(vkBindImageMemory(ctx.device, img.image_, img.memory_, 0), "vkBindImageMemory");
    return img;
}

Result<Sampler> create_sampler(const DeviceContext& ctx, VkSamplerAddressMode address,
                               const char* what) {
    VkSamplerCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO;
    info.magFilter = VK_FILTER_LINEAR;
    info.minFilter = VK_FILTER_LINEAR;
    info.mipmapMode = VK_SAMPLER_MIPMAP_MODE_NEAREST;
    info.addressModeU = address;
    info.addressModeV = address;
    info.addressModeW = address;
    info.maxLod = 0.0f;
    VkSampler sampler = VK_NULL_HANDLE;
    HMDNODE_VK_TRY(vkCreateSampler(ctx.device, &info, nullptr, &sampler), what);
    return Sampler(ctx.device, sampler);
}

Result<ImageView> create_view(const DeviceContext& ctx, const Image& image, VkFormat format,
                              VkImageAspectFlags aspect, const char* what, uint32_t base_layer,
                              uint32_t layer_count) {
    assert(base_layer < image.desc().layers);
    if (layer_count == 0) layer_count = image.desc().layers - base_layer;
    assert(base_layer + layer_count <= image.desc().layers);
    VkImageViewCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO;
    info.image = image.get();
    info.viewType = layer_count > 1 ? VK_IMAGE_VIEW_TYPE_2D_ARRAY : VK_IMAGE_VIEW_TYPE_2D;
    info.format = format;
    info.subresourceRange = {aspect, 0, 1, base_layer, layer_count};
    VkImageView view = VK_NULL_HANDLE;
    HMDNODE_VK_TRY(vkCreateImageView(ctx.device, &info, nullptr, &view),
                   (std::string("vkCreateImageView (") + what + ")").c_str());
    return ImageView(ctx.device, view);
}

void record_copy_to_host(VkCommandBuffer cmd, VkImage image, uint32_t width, uint32_t height,
                         uint32_t layers, const Buffer& buffer) {
    // The buffer holds the layers' rows of 4-byte texels, one after the other.
    assert(width >= 1 && height >= 1 && layers >= 1 &&
           buffer.size() >= VkDeviceSize(width) * height * layers * 4);
    VkBufferImageCopy region{};
    region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, layers};
    region.imageExtent = {width, height, 1};
    vkCmdCopyImageToBuffer(cmd, image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, buffer.get(), 1,
                           &region);
    VkBufferMemoryBarrier to_host{};
    to_host.sType = VK_STRUCTURE_TYPE_BUFFER_MEMORY_BARRIER;
    to_host.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
    to_host.dstAccessMask = VK_ACCESS_HOST_READ_BIT;
    to_host.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    to_host.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    to_host.buffer = buffer.get();
    to_host.size = VK_WHOLE_SIZE;
    vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_HOST_BIT, 0, 0,
                         nullptr, 1, &to_host, 0, nullptr);
}

}  // namespace hmdnode::vk
