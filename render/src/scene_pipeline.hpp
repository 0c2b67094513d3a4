// The graphics pipelines of the lightmapped scene (render/shaders/scene.vert, scene.frag): vertex
// layout, descriptor set layouts (set 0 per frame, set 1 per material), push constants (world
// matrix) and two pipelines, back-face culled for single-sided materials and unculled for
// double-sided ones. Created once per renderer.
#pragma once

#include <cstddef>

#include <glm/glm.hpp>

#include "scene_geometry.hpp"
#include "vk_memory.hpp"

namespace hmdnode::vk {

using gpu::Vertex;

// Set 0, binding 0 (std140).
struct FrameConstants {
    glm::mat4 view_projection[2];  // projection * view, eye 0 = left
};

// Set 1, binding 2 (std140).
using gpu::MaterialConstants;

// Push constants: world is pushed per draw (offset 0), view_base per pass (offset 64).
struct DrawConstants {
    glm::mat4 world;
    uint32_t view_base;
};
static_assert(offsetof(DrawConstants, view_base) == 64);

struct ScenePipeline {
    DescriptorSetLayout frame_layout;     // binding 0: FrameConstants (vertex)
    DescriptorSetLayout material_layout;  // 0: base colour, 1: lightmap, 2: MaterialConstants
    PipelineLayout layout;
    Pipeline single_sided;  // cull back faces; glTF front faces are counter-clockwise
    Pipeline double_sided;  // no culling
};
constexpr uint32_t kPushConstantBytes = offsetof(DrawConstants, view_base) + sizeof(uint32_t);

Result<ScenePipeline> create_scene_pipeline(const DeviceContext& ctx, VkRenderPass render_pass);

}  // namespace hmdnode::vk
