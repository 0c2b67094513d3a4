// The GLES backend's shaders. Each mirrors the Vulkan shader of the same name in render/shaders/
// (read those for the maths and its sources); a change to one must be made to the other, and
// tests/render/cross_backend_test.cpp compares the pixels of the two backends.
#include "gles_shaders.hpp"

namespace hmdnode::gles {

// scene.vert: u_view_projection is the eye's projection * view (one pass per eye).
const char* const kSceneVertex = R"(#version 300 es
uniform mat4 u_view_projection;
uniform mat4 u_world;
layout(location = 0) in vec3 in_position;
layout(location = 2) in vec2 in_uv0;
layout(location = 3) in vec2 in_uv1;
layout(location = 4) in vec4 in_color;
layout(location = 5) in vec3 in_light;
out vec2 v_uv0;
out vec2 v_uv1;
out vec4 v_color;
out vec3 v_light;
void main() {
    v_uv0 = in_uv0;
    v_uv1 = in_uv1;
    v_color = in_color;
    v_light = in_light;
    gl_Position = u_view_projection * (u_world * vec4(in_position, 1.0));
}
)";

// scene.frag: the shading contract of docs/formats.md, RGBM lightmaps decoded before filtering.
const char* const kSceneFragment = R"(#version 300 es
precision highp float;
precision highp int;
uniform highp sampler2D base_color_texture;  // sRGB texture, repeat
uniform highp sampler2D lightmap_texture;    // UNORM texture, clamp to edge
uniform vec4 u_base_color_factor;
uniform vec4 u_lightmap;  // x intensity, y uv set, z 1 when lightmapped, w 1 when RGBM
uniform vec4 u_emissive;
in vec2 v_uv0;
in vec2 v_uv1;
in vec4 v_color;
in vec3 v_light;
layout(location = 0) out vec4 out_color;
const float kInvPi = 0.31830988618379067;
vec3 rgbm_texel(ivec2 p, ivec2 size) {
    vec4 t = texelFetch(lightmap_texture, clamp(p, ivec2(0), size - 1), 0);
    return t.rgb * t.a;
}
vec3 rgbm_bilinear(vec2 uv) {
    ivec2 size = textureSize(lightmap_texture, 0);
    vec2 x = uv * vec2(size) - 0.5;
    vec2 x0 = floor(x);
    vec2 f = x - x0;
    ivec2 p = ivec2(x0);
    return mix(mix(rgbm_texel(p, size), rgbm_texel(p + ivec2(1, 0), size), f.x),
               mix(rgbm_texel(p + ivec2(0, 1), size), rgbm_texel(p + ivec2(1, 1), size), f.x),
               f.y);
}
// The LOD cross-fade's screen-door mask, as scene.frag: u_dither = +k keeps the pixels of rank < k
// in Bayer's 4x4 tile, -k those of rank >= k, 0 all. Only in the program built with DITHERED
// (a discard in the shader would cost every draw its early depth test).
#ifdef DITHERED
uniform int u_dither;
const int kBayer4[16] = int[16](0, 8, 2, 10, 12, 4, 14, 6, 3, 11, 1, 9, 15, 7, 13, 5);
#endif
void main() {
#ifdef DITHERED
    if (u_dither != 0) {
        ivec2 p = ivec2(gl_FragCoord.xy) & 3;
        int rank = kBayer4[p.y * 4 + p.x];
        if ((rank < abs(u_dither)) != (u_dither > 0)) discard;
    }
#endif
    vec4 albedo = u_base_color_factor * texture(base_color_texture, v_uv0) * v_color;
    vec3 rgb = albedo.rgb * v_light;
    if (u_lightmap.z > 0.5) {
        vec2 uv = u_lightmap.y > 0.5 ? v_uv1 : v_uv0;
        vec3 texel = u_lightmap.w > 0.5 ? rgbm_bilinear(uv) : texture(lightmap_texture, uv).rgb;
        vec3 irradiance = texel * u_lightmap.x;
        rgb = albedo.rgb * irradiance * kInvPi;
    }
    out_color = vec4(rgb + u_emissive.rgb, 1.0);
}
)";

// warp.vert: per channel, the display direction rotated and projected into the eye buffer.
const char* const kWarpVertex = R"(#version 300 es
uniform mat4 u_reproject;
layout(location = 0) in vec2 in_ndc;
layout(location = 1) in vec2 in_tangent_r;
layout(location = 2) in vec2 in_tangent_g;
layout(location = 3) in vec2 in_tangent_b;
out vec3 v_r;
out vec3 v_g;
out vec3 v_b;
void main() {
    v_r = (u_reproject * vec4(in_tangent_r, -1.0, 0.0)).xyz;
    v_g = (u_reproject * vec4(in_tangent_g, -1.0, 0.0)).xyz;
    v_b = (u_reproject * vec4(in_tangent_b, -1.0, 0.0)).xyz;
    gl_Position = vec4(in_ndc, 0.0, 1.0);
}
)";

// warp.frag: three bilinear samples, black outside the rendered field of view or behind the eye
// (branch-free: every lane samples, a mask blacks out the outside).
const char* const kWarpFragment = R"(#version 300 es
precision highp float;
uniform highp sampler2D eye;  // sRGB decode skipped: filters the encoded bytes, as Vulkan's
uniform vec4 u_sample_rect;   // dynamic resolution: xy the rendered fraction, zw the largest uv
in vec3 v_r;
in vec3 v_g;
in vec3 v_b;
layout(location = 0) out vec4 out_color;
float fetch(vec3 h, int channel) {
    vec2 uv = h.xy * (0.5 / max(h.z, 1e-6)) + 0.5;
    vec2 inside = step(vec2(0.0), uv) * step(uv, vec2(1.0));
    float mask = inside.x * inside.y * step(1e-6, h.z);
    return mask * textureLod(eye, min(uv * u_sample_rect.xy, u_sample_rect.zw), 0.0)[channel];
}
void main() {
    out_color = vec4(fetch(v_r, 0), fetch(v_g, 1), fetch(v_b, 2), 1.0);
}
)";

// warp_mono.frag: one sample serves all three channels.
const char* const kWarpMonoFragment = R"(#version 300 es
precision highp float;
uniform highp sampler2D eye;
uniform vec4 u_sample_rect;
in vec3 v_r;
in vec3 v_g;
in vec3 v_b;
layout(location = 0) out vec4 out_color;
void main() {
    vec2 uv = v_g.xy * (0.5 / max(v_g.z, 1e-6)) + 0.5;
    vec2 inside = step(vec2(0.0), uv) * step(uv, vec2(1.0));
    float mask = inside.x * inside.y * step(1e-6, v_g.z);
    out_color =
        vec4(mask * textureLod(eye, min(uv * u_sample_rect.xy, u_sample_rect.zw), 0.0).rgb, 1.0);
}
)";

// lens_warp.vert: one triangle over the whole panel, from the vertex index.
const char* const kLensWarpVertex = R"(#version 300 es
void main() {
    vec2 p = vec2((gl_VertexID << 1) & 2, gl_VertexID & 2);
    gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);
}
)";

// lens_warp.frag without its #version line: the renderer puts `#version 300 es` and the
// definitions of MODEL (0 none, 1 poly_radial, 2 vive), MONO, SHARED and CLAMP (0, 1) before it.
// Window row 0 is the panel's first row here as in Vulkan (see gles_renderer.cpp), so
// gl_FragCoord gives the same panel position. The same maths as the Vulkan shader, line for line.
const char* const kLensWarpFragmentBody = R"(
precision highp float;
uniform highp sampler2D eye;
uniform vec4 u_center_limit[3];
uniform vec4 u_coeffs[3];
uniform vec4 u_fov;
uniform vec4 u_panel;
uniform vec3 u_pre_row2;   // vive: row 2 of K^-1 diag(1, -a, 1)
uniform vec3 u_ahead;      // vive: the (g, 1) whose ray is straight ahead
uniform mat3 u_reproject;  // vive: with K^-1 diag(1, -a, 1) folded in
uniform vec4 u_sample_rect;
uniform vec2 u_origin;  // the eye's viewport origin in the target (side by side on scan-out)
layout(location = 0) out vec4 out_color;
float factor(float r2, int c) {
    vec4 k = u_coeffs[c];
#if MODEL == 2
    return 1.0 / (1.0 + r2 * (k.x + r2 * (k.y + r2 * k.z))) + k.w;
#else
    return k.x + r2 * (k.y + r2 * (k.z + r2 * k.w));
#endif
}
vec2 offset(vec2 uv, int c, out float r2) {
    vec2 ctr = u_center_limit[c].xy;
#if MODEL == 2
    vec2 q = vec2(2.0 * uv.x - 1.0 - ctr.x, (2.0 * uv.y - 1.0) * u_panel.w - ctr.y);
#else
    vec2 q = vec2(u_fov.x + uv.x * (u_fov.y - u_fov.x), u_fov.z + uv.y * (u_fov.w - u_fov.z)) - ctr;
#endif
    r2 = dot(q, q);
#if CLAMP
    float lim = u_center_limit[c].z;
    q *= sqrt(min(1.0, lim / max(r2, 1e-30)));
    r2 = min(r2, lim);
#endif
    return q;
}
vec4 fetch(vec3 h) {
    vec2 uv = h.xy * (0.5 / max(h.z, 1e-6)) + 0.5;
    vec2 inside = step(vec2(0.0), uv) * step(uv, vec2(1.0));
    float mask = inside.x * inside.y * step(1e-6, h.z);
    return mask * textureLod(eye, min(uv * u_sample_rect.xy, u_sample_rect.zw), 0.0);
}
vec3 channel_position(vec2 uv, int c) {
    float r2;
    vec2 q = offset(uv, c, r2);
#if MODEL == 0
    return u_reproject * vec3(q + u_center_limit[c].xy, -1.0);
#else
    vec2 d = u_center_limit[c].xy + factor(r2, c) * q;
#if MODEL == 2
    vec3 g1 = vec3(d, 1.0);
    return u_reproject * (dot(u_pre_row2, g1) >= 0.0 ? u_ahead : g1);
#else
    return u_reproject * vec3(d, -1.0);
#endif
#endif
}
void main() {
    vec2 uv = (gl_FragCoord.xy - u_origin) * u_panel.xy;
#if MONO || MODEL == 0
    out_color = vec4(fetch(channel_position(uv, 1)).rgb, 1.0);
#elif SHARED && MODEL == 1
    float r2;
    vec2 q = offset(uv, 1, r2);
    vec3 base = u_reproject * vec3(u_center_limit[1].xy, -1.0);
    vec3 dq = u_reproject * vec3(q, 0.0);
    out_color = vec4(fetch(base + factor(r2, 0) * dq).r, fetch(base + factor(r2, 1) * dq).g,
                     fetch(base + factor(r2, 2) * dq).b, 1.0);
#else
    out_color = vec4(fetch(channel_position(uv, 0)).r, fetch(channel_position(uv, 1)).g,
                     fetch(channel_position(uv, 2)).b, 1.0);
#endif
}
)";

}  // namespace hmdnode::gles
