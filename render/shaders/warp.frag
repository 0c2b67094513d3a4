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

// Branch-free (every lane samples, a mask blacks out the outside), as lens_warp.frag.
float fetch(vec3 h, int channel) {
    vec2 uv = h.xy * (0.5 / max(h.z, 1e-6)) + 0.5;
    vec2 inside = step(vec2(0.0), uv) * step(uv, vec2(1.0));
    float mask = inside.x * inside.y * step(1e-6, h.z);
    return mask * textureLod(eye, min(uv * warp.sample_rect.xy, warp.sample_rect.zw), 0.0)[channel];
}

void main() {
    out_color = vec4(fetch(in_r, 0), fetch(in_g, 1), fetch(in_b, 2), 1.0);
}
