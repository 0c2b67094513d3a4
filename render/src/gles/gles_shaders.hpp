// GLSL ES 3.00 versions of the Vulkan backend's shaders (render/shaders/*): the same maths, line
// for line, with uniforms in place of push constants and descriptor sets, and one pass per eye in
// place of multiview. Compiled by the driver when the GLES renderer is created.
#pragma once

namespace hmdnode::gles {

// Attribute locations of the scene program (scene.vert's, gpu::Vertex).
enum SceneAttribute { kPosition = 0, kUv0 = 2, kUv1 = 3, kColor = 4, kLight = 5 };
// Attribute locations of the warp program (warp.vert's, DistortionVertex).
enum WarpAttribute { kNdc = 0, kTangentR = 1, kTangentG = 2, kTangentB = 3 };

extern const char* const kSceneVertex;
extern const char* const kSceneFragment;
extern const char* const kWarpVertex;
extern const char* const kWarpFragment;      // per-channel sampling (chromatic aberration)
extern const char* const kWarpMonoFragment;  // one sample per pixel
// The fused pass (render/shaders/lens_warp.*): no vertex input; the fragment source needs
// "#version 300 es" and "#define MODEL m" / "#define MONO 0|1" before it.
extern const char* const kLensWarpVertex;
extern const char* const kLensWarpFragmentBody;

}  // namespace hmdnode::gles
