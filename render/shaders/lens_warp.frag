// The fused late-warp + lens pass, fragment stage (render/src/lens_pass.hpp): per panel pixel and
// colour channel, the eye-frame direction the lens model shows there (lens_sample() of
// render/include/hmdnode/render/lens.hpp, evaluated here in float), rotated into the rendered
// head pose and projected into the eye buffer by one matrix, then one bilinear sample (black
// outside the rendered field of view or behind the eye). MONO: one sample of the green channel's
// direction serves all three (no chromatic aberration, or its correction turned off). The eye
// buffer may hold a frame rendered at a fraction of its size (dynamic resolution): sample_rect
// scales the texture coordinate into that corner and clamps it at its last texel centre.
// Cost: about 25 flops per channel beside each sample.
#version 450

layout(constant_id = 0) const int MODEL = 0;  // 0 none, 1 poly_radial, 2 vive_dpoly3_scaled
layout(constant_id = 1) const bool MONO = false;

layout(set = 0, binding = 0) uniform sampler2D eye;  // this eye's rendered buffer
layout(std140, set = 0, binding = 1) uniform Lens {
    vec4 center_limit[3];  // per channel: xy centre, z the r^2 the model is clamped at
    vec4 coeffs[3];
    vec4 fov;    // tan_left, tan_right, tan_up, tan_down
    vec4 panel;  // 1 / width, 1 / height, aspect (vive)
    mat4 pre;    // vive: K^-1 diag(1, -aspect, 1)
} lens;

layout(push_constant) uniform Warp {
    mat4 reproject;    // upper 3x3: eye-frame direction -> (clip.x, clip.y, clip.w)
    float layer;
    vec4 sample_rect;  // xy: the rendered fraction of the eye buffer, zw: the largest coordinate
} warp;

layout(location = 0) out vec4 out_color;

vec2 radial(vec2 q, int c) {
    float lim = lens.center_limit[c].z;
    float r2 = dot(q, q);
    if (r2 > lim) {
        q *= sqrt(lim / r2);
        r2 = lim;
    }
    vec4 k = lens.coeffs[c];
    float f = MODEL == 2 ? 1.0 / (1.0 + r2 * (k.x + r2 * (k.y + r2 * k.z))) + k.w
                         : k.x + r2 * (k.y + r2 * (k.z + r2 * k.w));
    return q * f;
}

vec3 direction(vec2 uv, int c) {
    vec2 ctr = lens.center_limit[c].xy;
    if (MODEL == 2) {
        vec2 q = vec2(2.0 * uv.x - 1.0 - ctr.x, (2.0 * uv.y - 1.0) / lens.panel.z - ctr.y);
        vec3 ray = mat3(lens.pre) * vec3(radial(q, c) + ctr, 1.0);
        return ray.z < 0.0 ? ray : vec3(0.0, 0.0, -1.0);
    }
    vec2 p = vec2(lens.fov.x + uv.x * (lens.fov.y - lens.fov.x),
                  lens.fov.z + uv.y * (lens.fov.w - lens.fov.z));
    if (MODEL == 1) p = ctr + radial(p - ctr, c);
    return vec3(p, -1.0);
}

vec4 fetch(vec3 d) {
    vec3 h = mat3(warp.reproject) * d;
    if (h.z <= 1e-6) return vec4(0.0);
    vec2 uv = h.xy / h.z * 0.5 + 0.5;
    if (any(lessThan(uv, vec2(0.0))) || any(greaterThan(uv, vec2(1.0)))) return vec4(0.0);
    return textureLod(eye, min(uv * warp.sample_rect.xy, warp.sample_rect.zw), 0.0);
}

void main() {
    vec2 uv = gl_FragCoord.xy * lens.panel.xy;
    if (MONO)
        out_color = vec4(fetch(direction(uv, 1)).rgb, 1.0);
    else
        out_color = vec4(fetch(direction(uv, 0)).r, fetch(direction(uv, 1)).g,
                         fetch(direction(uv, 2)).b, 1.0);
}
