// Late warp (and distortion without chromatic aberration), fragment stage: when every colour
// channel of the mesh shows the same direction, one bilinear sample serves all three (a third of
// warp.frag's sampling cost on a software rasteriser).
#version 450

layout(set = 0, binding = 0) uniform sampler2D eye;  // this eye's rendered buffer

layout(push_constant) uniform Warp {
    mat4 reproject;
    float layer;
    vec4 sample_rect;  // xy: the rendered fraction of the eye buffer, zw: the largest coordinate
} warp;

layout(location = 1) in vec3 in_g;

layout(location = 0) out vec4 out_color;

void main() {
    vec2 uv = in_g.xy * (0.5 / max(in_g.z, 1e-6)) + 0.5;
    vec2 inside = step(vec2(0.0), uv) * step(uv, vec2(1.0));
    float mask = inside.x * inside.y * step(1e-6, in_g.z);
    out_color = vec4(
        mask * textureLod(eye, min(uv * warp.sample_rect.xy, warp.sample_rect.zw), 0.0).rgb, 1.0);
}
