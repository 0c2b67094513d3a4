// Shader modules and descriptor set layouts (see vk_shader.hpp). Cost: one Vulkan call each.
#include "vk_shader.hpp"

#include "vk_check.hpp"

namespace hmdnode::vk {

Result<ShaderModule> create_module(const DeviceContext& ctx, const uint32_t* code, size_t bytes,
                                   const char* what) {
    VkShaderModuleCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO;
    info.codeSize = bytes;
    info.pCode = code;
    VkShaderModule module = VK_NULL_HANDLE;
    HMDNODE_VK_TRY(vkCreateShaderModule(ctx.device, &info, nullptr, &module), what);
    return ShaderModule(ctx.device, module);
}

Result<DescriptorSetLayout> create_set_layout(const DeviceContext& ctx,
                                              std::span<const VkDescriptorSetLayoutBinding> b) {
    VkDescriptorSetLayoutCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO;
    info.bindingCount = uint32_t(b.size());
    info.pBindings = b.data();
    VkDescriptorSetLayout layout = VK_NULL_HANDLE;
    HMDNODE_VK_TRY(vkCreateDescriptorSetLayout(ctx.device, &info, nullptr, &layout),
                   "vkCreateDescriptorSetLayout");
    return DescriptorSetLayout(ctx.device, layout);
}

}  // namespace hmdnode::vk
