// Scene vertex shader: both eyes in one multiview pass; gl_ViewIndex picks the eye's
// projection * view from the per-frame uniform buffer. In per-eye mode (no multiview, one pass per
// eye) gl_ViewIndex is 0 and view_base names the eye. Cost: two mat4 * vec4 per vertex per eye.
#version 450
#extension GL_EXT_multiview : require

layout(set = 0, binding = 0) uniform Frame {
    mat4 view_projection[2];  // 0 = left eye, 1 = right eye
} frame;

layout(push_constant) uniform Draw {
    mat4 world;      // per draw
    uint view_base;  // per pass: 0 with multiview, else the eye of this pass
} draw;

layout(location = 0) in vec3 in_position;
layout(location = 2) in vec2 in_uv0;
layout(location = 3) in vec2 in_uv1;
layout(location = 4) in vec4 in_color;
layout(location = 5) in vec3 in_light;  // _LIGHT_0 / pi, 1 without baked vertex light

layout(location = 0) out vec2 out_uv0;
layout(location = 1) out vec2 out_uv1;
layout(location = 2) out vec4 out_color;
layout(location = 3) out vec3 out_light;

void main() {
    out_uv0 = in_uv0;
    out_uv1 = in_uv1;
    out_color = in_color;
    out_light = in_light;
    gl_Position = frame.view_projection[gl_ViewIndex + draw.view_base] * (draw.world * vec4(in_position, 1.0));
}
