// Scene fragment shader, the project's shading contract (docs/formats.md):
//   albedo = base_color_factor * texture(base_color, uv0) * COLOR_0
//   lightmapped: rgb = albedo.rgb * E / pi, E = texture(lightmap, uv_n).rgb * intensity
//                (RGBM: E = bilinear over the 4 texels of rgb * a * intensity, decoded before
//                filtering, since filtering rgb and a apart is not the filtered product)
//   otherwise:   rgb = albedo.rgb * _LIGHT_0 / pi (vertex-baked E; unlit, factor 1, without)
//   then:        rgb += emissiveFactor (emitted radiance, relative to white)
// Writes linear colour with alpha 1; the sRGB attachment encodes. Cost: one or two texture
// fetches per fragment (five with an RGBM lightmap).
//
// LOD cross-fade (docs/lod-selection.md, "No pops"): in the pipelines built with kDithered, a draw
// keeps only part of its pixels, a screen-door mask over a 4x4 ordered-dither (Bayer) tile of
// ranks 0..15: dither = +k keeps the pixels of rank < k, dither = -k those of rank >= k (0: all).
// The old level drawn with -k and the new one with +k cover each pixel exactly once. The mask is
// per pixel (discard drops all of a pixel's MSAA samples). Pipelines without kDithered compile the
// test away, so ordinary draws keep early depth testing.
#version 450

layout(set = 1, binding = 0) uniform sampler2D base_color_texture;  // sRGB view, repeat
layout(set = 1, binding = 1) uniform sampler2D lightmap_texture;    // UNORM view, clamp to edge
layout(set = 1, binding = 2) uniform MaterialConstants {
    vec4 base_color_factor;
    // x = lightmap intensity, y = lightmap uv set (0 or 1), z = 1 when the material has a
    // lightmap, w = 1 when it is RGBM-encoded (0: linear)
    vec4 lightmap;
    vec4 emissive;  // rgb = emissiveFactor
} material;

layout(constant_id = 0) const bool kDithered = false;
layout(push_constant) uniform Fade {
    layout(offset = 68) int dither;  // after the vertex stage's world matrix and view_base
} fade;

layout(location = 0) in vec2 in_uv0;
layout(location = 1) in vec2 in_uv1;
layout(location = 2) in vec4 in_color;
layout(location = 3) in vec3 in_light;  // _LIGHT_0 / pi, 1 without baked vertex light

layout(location = 0) out vec4 out_color;

const float kInvPi = 0.31830988618379067;

// One RGBM texel, E / intensity = rgb * a, clamped to the edge like the lightmap sampler.
vec3 rgbm_texel(ivec2 p, ivec2 size) {
    vec4 t = texelFetch(lightmap_texture, clamp(p, ivec2(0), size - 1), 0);
    return t.rgb * t.a;
}

// Bilinear lookup of an RGBM lightmap at uv (texel centres at (i + 0.5) / size).
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

// Bayer's 4x4 ordered-dither ranks: any k consecutive ranks spread evenly over the tile.
const int kBayer4[16] = int[16](0, 8, 2, 10, 12, 4, 14, 6, 3, 11, 1, 9, 15, 7, 13, 5);

void main() {
    // note: lavapipe of Mesa 22.x "inlines" a uniform that alone decides a branch: it compiles a
    // new shader whenever such a value changes (each material or dither switch, every frame) and
    // keeps every one of them (about 1 MB and several ms each: the daemon grew by gigabytes). So
    // each branch below also reads `live` (gl_FragCoord.w > 0: true for every fragment), which
    // no driver can fold, and ints are combined with & (no short circuit, no branch on the
    // uniform part alone). tests/render/renderer_test.cpp holds the memory flat.
    const int live = int(gl_FragCoord.w > 0.0);
    if (kDithered && (int(fade.dither != 0) & live) != 0) {
        ivec2 p = ivec2(gl_FragCoord.xy) & 3;
        int rank = kBayer4[p.y * 4 + p.x];
        if ((rank < abs(fade.dither)) != (fade.dither > 0)) discard;
    }
    vec4 albedo = material.base_color_factor * texture(base_color_texture, in_uv0) * in_color;
    vec3 rgb = albedo.rgb * in_light;
    // note: the branch is uniform per draw (a material constant), so the implicit derivatives of
    // the lightmap fetch stay defined.
    if ((int(material.lightmap.z > 0.5) & live) != 0) {
        vec2 uv = material.lightmap.y > 0.5 ? in_uv1 : in_uv0;
        vec3 texel;
        if ((int(material.lightmap.w > 0.5) & live) != 0)
            texel = rgbm_bilinear(uv);
        else
            texel = texture(lightmap_texture, uv).rgb;
        vec3 irradiance = texel * material.lightmap.x;
        rgb = albedo.rgb * irradiance * kInvPi;
    }
    out_color = vec4(rgb + material.emissive.rgb, 1.0);
}
