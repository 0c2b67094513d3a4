// Late warp + lens distortion, fragment stage: per channel, the homogeneous eye-buffer position
// from the vertex stage is divided and mapped to texture coordinates, and that channel is sampled
// (bilinear, black outside the rendered field of view or behind the eye). Three samples per pixel.
#version 450

layout(set = 0, binding = 0) uniform sampler2D eye;  // this eye's rendered buffer

layout(push_constant) uniform Warp {
    mat4 reproject;
    float layer;
    vec4 sample_rect;  // xy: the rendered fraction of the eye buffer, zw: the largest coordinate
} warp;

layout(location = 0) in vec3 in_r;
layout(location = 1) in vec3 in_g;
layout(location = 2) in vec3 in_b;

layout(location = 0) out vec4 out_color;

float fetch(vec3 h, int channel) {
    if (h.z <= 1e-6) return 0.0;
    vec2 uv = h.xy / h.z * 0.5 + 0.5;
    if (any(lessThan(uv, vec2(0.0))) || any(greaterThan(uv, vec2(1.0)))) return 0.0;
    return textureLod(eye, min(uv * warp.sample_rect.xy, warp.sample_rect.zw), 0.0)[channel];
}

void main() {
    out_color = vec4(fetch(in_r, 0), fetch(in_g, 1), fetch(in_b, 2), 1.0);
}
