// The fused late-warp + lens pass, fragment stage (render/src/lens_pass.hpp): per panel pixel and
// colour channel, the eye-frame direction the lens model shows there (lens_sample() of
// render/include/hmdnode/render/lens.hpp, evaluated here in float), rotated into the rendered
// head pose and projected into the eye buffer by one matrix, then one bilinear sample (black
// outside the rendered field of view or behind the eye). MONO: one sample of the green channel's
// direction serves all three (no chromatic aberration, or its correction turned off). The eye
// buffer may hold a frame rendered at a fraction of its size (dynamic resolution): sample_rect
// scales the texture coordinate into that corner and clamps it at its last texel centre.
//
// The models are radial about a centre: d_c = base_c + f_c(r2) * q (q the offset from the centre,
// r2 = |q|^2, f_c the channel's radial factor), and the projection is linear, so with SHARED (the
// three channels share one centre and one clamp) q, r2 and the projections of the centre and of q
// are computed once and each channel adds only its factor: about 12 flops and a reciprocal per
// channel beside its sample. The vive model's K^-1 diag(1, -a, 1) is folded into `reproject` by
// the CPU. CLAMP: the panel reaches where lens_sample() clamps the model (the cutoff, or where it
// stops being defined); without it the clamp is compiled out.
#version 450

layout(constant_id = 0) const int MODEL = 0;  // 0 none, 1 poly_radial, 2 vive_dpoly3_scaled
layout(constant_id = 1) const bool MONO = false;
layout(constant_id = 2) const bool SHARED = false;
layout(constant_id = 3) const bool CLAMP = false;

layout(set = 0, binding = 0) uniform sampler2D eye;  // this eye's rendered buffer
layout(std140, set = 0, binding = 1) uniform Lens {
    vec4 center_limit[3];  // per channel: xy centre, z the r^2 the model is clamped at
    vec4 coeffs[3];
    vec4 fov;    // tan_left, tan_right, tan_up, tan_down
    vec4 panel;  // 1 / width, 1 / height, aspect (vive), 1 / aspect
    mat4 pre;    // vive: K^-1 diag(1, -aspect, 1) (upper 3x3; its row 2 says whether a ray is
                 // in front), and in column 3 the (g, 1) whose ray is straight ahead
} lens;

layout(push_constant) uniform Warp {
    mat4 reproject;    // upper 3x3: eye-frame direction (vive: (g, 1)) -> (clip.x, clip.y, clip.w)
    float layer;
    vec4 sample_rect;  // xy: the rendered fraction of the eye buffer, zw: the largest coordinate
} warp;

layout(location = 0) out vec4 out_color;

float factor(float r2, int c) {
    vec4 k = lens.coeffs[c];
    if (MODEL == 2) return 1.0 / (1.0 + r2 * (k.x + r2 * (k.y + r2 * k.z))) + k.w;
    return k.x + r2 * (k.y + r2 * (k.z + r2 * k.w));
}

// The model's offset from channel c's centre at panel position uv, clamped as lens_sample() does.
vec2 offset(vec2 uv, int c, out float r2) {
    vec2 ctr = lens.center_limit[c].xy;
    vec2 q = MODEL == 2 ? vec2(2.0 * uv.x - 1.0 - ctr.x, (2.0 * uv.y - 1.0) * lens.panel.w - ctr.y)
                        : vec2(lens.fov.x + uv.x * (lens.fov.y - lens.fov.x),
                               lens.fov.z + uv.y * (lens.fov.w - lens.fov.z)) - ctr;
    r2 = dot(q, q);
    if (CLAMP) {
        float lim = lens.center_limit[c].z;
        q *= sqrt(min(1.0, lim / max(r2, 1e-30)));
        r2 = min(r2, lim);
    }
    return q;
}

// The homogeneous eye-buffer position of channel c: base + f * dq (see above).
vec3 position(vec3 base, vec3 dq, float f) {
    return base + f * dq;
}

// Branch-free: every lane samples (clamped to the buffer's edge) and the mask blacks out what
// lies outside the rendered field of view or behind the eye; on a software rasteriser a sample
// under a divergent branch costs more than one taken by all.
vec4 fetch(vec3 h) {
    vec2 uv = h.xy * (0.5 / max(h.z, 1e-6)) + 0.5;
    vec2 inside = step(vec2(0.0), uv) * step(uv, vec2(1.0));
    float mask = inside.x * inside.y * step(1e-6, h.z);
    return mask * textureLod(eye, min(uv * warp.sample_rect.xy, warp.sample_rect.zw), 0.0);
}

// The vive model's ray for (g, 1) in front of the eye, else straight ahead (as lens_sample()).
vec3 vive_position(vec3 g1) {
    if (dot(vec3(lens.pre[0][2], lens.pre[1][2], lens.pre[2][2]), g1) >= 0.0)
        return mat3(warp.reproject) * lens.pre[3].xyz;
    return mat3(warp.reproject) * g1;
}

vec3 channel_position(vec2 uv, int c) {
    float r2;
    vec2 q = offset(uv, c, r2);
    if (MODEL == 0) return mat3(warp.reproject) * vec3(q + lens.center_limit[c].xy, -1.0);
    vec2 d = lens.center_limit[c].xy + factor(r2, c) * q;
    return MODEL == 2 ? vive_position(vec3(d, 1.0)) : mat3(warp.reproject) * vec3(d, -1.0);
}

void main() {
    vec2 uv = gl_FragCoord.xy * lens.panel.xy;
    if (MONO || MODEL == 0) {
        out_color = vec4(fetch(channel_position(uv, 1)).rgb, 1.0);
    } else if (SHARED && MODEL == 1) {
        float r2;
        vec2 q = offset(uv, 1, r2);
        vec3 base = mat3(warp.reproject) * vec3(lens.center_limit[1].xy, -1.0);
        vec3 dq = mat3(warp.reproject) * vec3(q, 0.0);
        out_color = vec4(fetch(position(base, dq, factor(r2, 0))).r,
                         fetch(position(base, dq, factor(r2, 1))).g,
                         fetch(position(base, dq, factor(r2, 2))).b, 1.0);
    } else {
        out_color = vec4(fetch(channel_position(uv, 0)).r, fetch(channel_position(uv, 1)).g,
                         fetch(channel_position(uv, 2)).b, 1.0);
    }
}
