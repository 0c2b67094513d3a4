// Small pipeline-building helpers shared by the scene and warp pipelines: shader modules from
// embedded SPIR-V and descriptor set layouts. Creation time only.
#pragma once

#include <cstddef>
#include <span>

#include "vk_memory.hpp"

namespace hmdnode::vk {

Result<ShaderModule> create_module(const DeviceContext& ctx, const uint32_t* code, size_t bytes,
                                   const char* what);
Result<DescriptorSetLayout> create_set_layout(const DeviceContext& ctx,
                                              std::span<const VkDescriptorSetLayoutBinding> b);

}  // namespace hmdnode::vk
