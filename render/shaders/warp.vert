// Late warp + lens distortion, vertex stage: one distortion-mesh vertex per panel grid point
// (render/include/hmdnode/render/lens.hpp). Each vertex carries, per colour channel, the tangent
// (tx, ty) of the view direction that panel point must show in the displayed head pose's eye frame;
// the push-constant matrix rotates that direction into the rendered pose's eye frame and projects
// it with the eye buffer's projection (rows x, y, w of clip space). The fragment stage divides,
// so the rotational reprojection is exact per pixel (a rotation is linear in homogeneous
// directions) and only the lens model is interpolated across a cell. Cost: three mat3 * vec3 per
// vertex.
#version 450

layout(push_constant) uniform Warp {
    mat4 reproject;  // upper 3x3: direction (tx, ty, -1) -> (clip.x, clip.y, clip.w) of the eye buffer
    float layer;     // eye buffer layer: 0 left, 1 right
} warp;

layout(location = 0) in vec2 in_ndc;
layout(location = 1) in vec2 in_tangent_r;
layout(location = 2) in vec2 in_tangent_g;
layout(location = 3) in vec2 in_tangent_b;

layout(location = 0) out vec3 out_r;
layout(location = 1) out vec3 out_g;
layout(location = 2) out vec3 out_b;

void main() {
    out_r = (warp.reproject * vec4(in_tangent_r, -1.0, 0.0)).xyz;
    out_g = (warp.reproject * vec4(in_tangent_g, -1.0, 0.0)).xyz;
    out_b = (warp.reproject * vec4(in_tangent_b, -1.0, 0.0)).xyz;
    gl_Position = vec4(in_ndc, 0.0, 1.0);
}
