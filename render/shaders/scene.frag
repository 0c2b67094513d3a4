// Scene fragment shader, the project's shading contract (docs/formats.md):
//   albedo = base_color_factor * texture(base_color, uv0) * COLOR_0
//   lightmapped: rgb = albedo.rgb * E / pi, E = texture(lightmap, uv_n).rgb * intensity
//   otherwise:   rgb = albedo.rgb * _LIGHT_0 / pi (vertex-baked E; unlit, factor 1, without)
//   then:        rgb += emissiveFactor (emitted radiance, relative to white)
// Writes linear colour with alpha 1; the sRGB attachment encodes. Cost: one or two texture
// fetches per fragment.
#version 450

layout(set = 1, binding = 0) uniform sampler2D base_color_texture;  // sRGB view, repeat
layout(set = 1, binding = 1) uniform sampler2D lightmap_texture;    // UNORM view, clamp to edge
layout(set = 1, binding = 2) uniform MaterialConstants {
    vec4 base_color_factor;
    // x = lightmap intensity, y = lightmap uv set (0 or 1), z = 1 when the material has a lightmap
    vec4 lightmap;
    vec4 emissive;  // rgb = emissiveFactor
} material;

layout(location = 0) in vec2 in_uv0;
layout(location = 1) in vec2 in_uv1;
layout(location = 2) in vec4 in_color;
layout(location = 3) in vec3 in_light;  // _LIGHT_0 / pi, 1 without baked vertex light

layout(location = 0) out vec4 out_color;

const float kInvPi = 0.31830988618379067;

void main() {
    vec4 albedo = material.base_color_factor * texture(base_color_texture, in_uv0) * in_color;
    vec3 rgb = albedo.rgb * in_light;
    // note: the branch is uniform per draw (a material constant), so the implicit derivatives of
    // the lightmap fetch stay defined.
    if (material.lightmap.z > 0.5) {
        vec2 uv = material.lightmap.y > 0.5 ? in_uv1 : in_uv0;
        vec3 irradiance = texture(lightmap_texture, uv).rgb * material.lightmap.x;
        rgb = albedo.rgb * irradiance * kInvPi;
    }
    out_color = vec4(rgb + material.emissive.rgb, 1.0);
}
