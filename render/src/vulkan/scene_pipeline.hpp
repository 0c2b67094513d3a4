// The graphics pipelines of the lightmapped scene (render/shaders/scene.vert, scene.frag): vertex
// layout, descriptor set layouts (set 0 per frame, set 1 per material), push constants (world
// matrix, dither) and four pipelines: back-face culled for single-sided materials and unculled for
// double-sided ones, each plain and dithered (the LOD cross-fade). Created once per renderer.
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

// Push constants: world is pushed per draw (offset 0), view_base per pass (offset 64), both for
// the vertex stage; dither (the fragment stage's, offset 68) per dithered draw (DrawItem::dither).
struct DrawConstants {
    glm::mat4 world;
    uint32_t view_base;
    int32_t dither;
};
static_assert(offsetof(DrawConstants, view_base) == 64);
static_assert(offsetof(DrawConstants, dither) == 68);

struct ScenePipeline {
    DescriptorSetLayout frame_layout;     // binding 0: FrameConstants (vertex)
    DescriptorSetLayout material_layout;  // 0: base colour, 1: lightmap, 2: MaterialConstants
    PipelineLayout layout;
    Pipeline single_sided;  // cull back faces; glTF front faces are counter-clockwise
    Pipeline double_sided;  // no culling
    // The same two with the cross-fade's screen-door mask (scene.frag's kDithered): only for
    // draws with a dither, since a shader that may discard loses early depth testing.
    Pipeline single_sided_dithered, double_sided_dithered;
};
constexpr uint32_t kVertexPushBytes = offsetof(DrawConstants, view_base) + sizeof(uint32_t);

// samples: the render pass's colour and depth sample count (1 or 4).
Result<ScenePipeline> create_scene_pipeline(const DeviceContext& ctx, VkRenderPass render_pass,
                                            VkSampleCountFlagBits samples);

}  // namespace hmdnode::vk
