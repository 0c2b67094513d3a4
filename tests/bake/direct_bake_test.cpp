#include "hmdnode/bake/direct_bake.hpp"

#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

namespace hmdnode {
namespace {

constexpr float kPi = std::numbers::pi_v<float>;

// Floor: a 4 m x 4 m quad at y = 0 facing +Y; its uv1 chart covers texels [4, 60) of a 64 x 64 map.
constexpr int kMap = 64, kChart0 = 4;
constexpr float kTexelsPerM = 14.0f;

glm::vec2 floor_uv1(float x, float z) {
    return glm::vec2(kChart0 + (x + 2.0f) * kTexelsPerM, kChart0 + (z + 2.0f) * kTexelsPerM) /
           float(kMap);
}
// World position of a texel centre of the floor chart.
glm::vec3 texel_world(int x, int y) {
    return glm::vec3((x + 0.5f - kChart0) / kTexelsPerM - 2.0f, 0.0f,
                     (y + 0.5f - kChart0) / kTexelsPerM - 2.0f);
}
int texel_of(float world) {
    return int(std::floor((world + 2.0f) * kTexelsPerM + kChart0));
}

int add_node(Scene& s, const std::string& name, glm::dvec3 t, int mesh, bool root = true) {
    Node n;
    n.name = name;
    n.translation = t;
    n.mesh = mesh;
    s.nodes.push_back(n);
    if (root) s.roots.push_back(int(s.nodes.size()) - 1);
    return int(s.nodes.size()) - 1;
}

// A grid of (n+1)^2 vertices over the 4 m floor, with uv1 into the floor chart.
Primitive floor_grid(int n, int material) {
    Primitive p;
    for (int j = 0; j <= n; ++j)
        for (int i = 0; i <= n; ++i) {
            float x = -2.0f + 4.0f * i / n, z = -2.0f + 4.0f * j / n;
            p.positions.emplace_back(x, 0.0f, z);
            p.normals.emplace_back(0.0f, 1.0f, 0.0f);
            p.uv1.push_back(floor_uv1(x, z));
        }
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            uint32_t a = j * (n + 1) + i, b = a + 1, c = a + n + 1, d = c + 1;
            // Seen from +Y, (a, c, d) and (a, d, b) run counter-clockwise.
            p.indices.insert(p.indices.end(), {a, c, d, a, d, b});
        }
    p.material = material;
    return p;
}

// Floor (lightmapped or vertex-lit) and a point light at `light_pos` placed through a parent node.
Scene floor_scene(bool lightmapped, glm::vec3 light_pos, float intensity, int grid = 1) {
    Scene s;
    Material m;
    m.name = "floor";
    if (lightmapped) {
        Texture t;
        t.name = "lightmap";
        t.width = t.height = kMap;
        s.textures.push_back(t);
        m.lightmap.texture = 0;
    }
    s.materials.push_back(m);
    Mesh mesh;
    mesh.name = "floor";
    mesh.primitives.push_back(floor_grid(grid, 0));
    s.meshes.push_back(mesh);
    add_node(s, "floor", glm::dvec3(0.0), 0);
    if (intensity > 0.0f) {
        int parent = add_node(s, "lamp_mount", glm::dvec3(light_pos.x, 0.0, light_pos.z), -1);
        int child = add_node(s, "lamp", glm::dvec3(0.0, light_pos.y, 0.0), -1, false);
        s.nodes[parent].children.push_back(child);
        Light l;
        l.name = "lamp";
        l.intensity = intensity;
        l.node = child;
        s.lights.push_back(l);
    }
    return s;
}

// A 0.5 m square at height `y` centred at (cx, cz), facing up, in its own (non-lightmapped)
// material.
void add_occluder(Scene& s, float cx, float y, float cz) {
    Material m;
    m.name = "occluder";
    s.materials.push_back(m);
    Primitive p;
    p.positions = {{-0.25f, 0, 0.25f}, {0.25f, 0, 0.25f}, {0.25f, 0, -0.25f}, {-0.25f, 0, -0.25f}};
    p.normals.assign(4, glm::vec3(0, 1, 0));
    p.indices = {0, 1, 2, 0, 2, 3};
    p.material = int(s.materials.size()) - 1;
    Mesh mesh;
    mesh.name = "occluder";
    mesh.primitives.push_back(p);
    s.meshes.push_back(mesh);
    add_node(s, "occluder", glm::dvec3(cx, y, cz), int(s.meshes.size()) - 1);
}

// E of a point light of intensity I at height h above the floor point p: I cos(theta) / r^2.
float closed_form(glm::vec3 light, float intensity, glm::vec3 p) {
    glm::vec3 d = light - p;
    float r = glm::length(d);
    return intensity * (d.y / r) / (r * r);
}

TEST(DirectBake, lightmap_texels_match_point_light_closed_form) {
    const glm::vec3 light(0.3f, 2.0f, -0.2f);
    const float intensity = 10.0f;
    Scene s = floor_scene(true, light, intensity);
    DirectBakeOptions opt;
    DirectLighting lighting(s, opt);
    ASSERT_EQ(lighting.lights().size(), 1u);
    EXPECT_NEAR(glm::distance(lighting.lights()[0].position, light), 0.0f, 1e-6f);

    Result<std::vector<LightmapBake>> maps = bake_lightmaps(s, lighting, opt);
    ASSERT_TRUE(maps.ok()) << maps.error().message;
    ASSERT_EQ(maps->size(), 1u);
    const LightmapBake& map = (*maps)[0];
    EXPECT_EQ(map.covered_texels, 56u * 56u);
    EXPECT_EQ(map.dilated_texels, 60u * 60u - 56u * 56u);

    float max_e = 0.0f;
    for (int y = kChart0; y < kChart0 + 56; ++y)
        for (int x = kChart0; x < kChart0 + 56; ++x) {
            float expected = closed_form(light, intensity, texel_world(x, y));
            glm::vec3 e = map.irradiance[size_t(y) * kMap + x];
            ASSERT_NEAR(e.r, expected, 1e-3f * expected) << x << "," << y;
            EXPECT_EQ(e.r, e.g);
            EXPECT_EQ(e.r, e.b);
            max_e = std::max(max_e, e.r);
        }
    EXPECT_FLOAT_EQ(map.intensity, max_e);
    EXPECT_FLOAT_EQ(s.materials[0].lightmap.intensity, max_e);

    // The stored 8-bit texels times the intensity give E back within 1 % (plus half a step).
    const Texture& tex = s.textures[0];
    ASSERT_EQ(tex.rgba8.size(), size_t(kMap) * kMap * 4);
    for (int y = kChart0; y < kChart0 + 56; ++y)
        for (int x = kChart0; x < kChart0 + 56; ++x) {
            float expected = closed_form(light, intensity, texel_world(x, y));
            float decoded = tex.rgba8[(size_t(y) * kMap + x) * 4] / 255.0f * map.intensity;
            ASSERT_NEAR(decoded, expected, 0.01f * expected + 0.5f / 255.0f * map.intensity)
                << x << "," << y;
        }
    // Gutter: two dilated rings around the chart, nothing beyond.
    EXPECT_GT(tex.rgba8[(size_t(kChart0) * kMap + kChart0 - 2) * 4], 0);
    EXPECT_EQ(tex.rgba8[(size_t(kChart0) * kMap + kChart0 - 3) * 4], 0);
    EXPECT_EQ(tex.rgba8[0], 0);
    EXPECT_EQ(tex.rgba8[3], 255);
}

TEST(DirectBake, occluder_casts_shadow_where_geometry_puts_it) {
    const glm::vec3 light(0.3f, 2.0f, -0.2f);
    const float intensity = 10.0f;
    Scene s = floor_scene(true, light, intensity);
    // Half-way up, a 0.5 m square: its shadow is the 1 m square centred under the light.
    add_occluder(s, light.x, 1.0f, light.z);
    DirectBakeOptions opt;
    DirectLighting lighting(s, opt);
    Result<std::vector<LightmapBake>> maps = bake_lightmaps(s, lighting, opt);
    ASSERT_TRUE(maps.ok()) << maps.error().message;
    const LightmapBake& map = (*maps)[0];
    auto e_at = [&](float x, float z, glm::vec3* out_centre) {
        int tx = texel_of(x), ty = texel_of(z);
        *out_centre = texel_world(tx, ty);
        return map.irradiance[size_t(ty) * kMap + tx].r;
    };
    glm::vec3 c;
    EXPECT_EQ(e_at(light.x, light.z, &c), 0.0f);         // right under the light
    EXPECT_EQ(e_at(light.x + 0.4f, light.z, &c), 0.0f);  // inside the shadow, near its edge
    EXPECT_EQ(e_at(light.x, light.z - 0.4f, &c), 0.0f);
    float lit = e_at(light.x + 0.6f, light.z, &c);  // just outside
    EXPECT_NEAR(lit, closed_form(light, intensity, c), 1e-3f * lit);
    lit = e_at(light.x - 1.5f, light.z + 1.2f, &c);  // far away
    EXPECT_NEAR(lit, closed_form(light, intensity, c), 1e-3f * lit);

    // The shadowed area is the projected 1 m^2, to within the texels along its border.
    size_t dark = 0;
    for (int y = kChart0; y < kChart0 + 56; ++y)
        for (int x = kChart0; x < kChart0 + 56; ++x)
            dark += map.irradiance[size_t(y) * kMap + x].r == 0.0f;
    const float texels_per_m2 = kTexelsPerM * kTexelsPerM;
    EXPECT_NEAR(float(dark), texels_per_m2, 4.0f * kTexelsPerM + 4.0f);
}

TEST(DirectBake, texel_supersampling_softens_only_shadow_edges) {
    const glm::vec3 light(0.3f, 2.0f, -0.2f);
    const float intensity = 10.0f;
    Scene s = floor_scene(true, light, intensity);
    add_occluder(s, light.x, 1.0f, light.z);
    DirectBakeOptions opt;
    opt.texel_samples = 4;
    Result<std::vector<LightmapBake>> maps = bake_lightmaps(s, DirectLighting(s, opt), opt);
    ASSERT_TRUE(maps.ok()) << maps.error().message;
    const LightmapBake& map = (*maps)[0];
    size_t dark = 0, partial = 0;
    for (int y = kChart0; y < kChart0 + 56; ++y)
        for (int x = kChart0; x < kChart0 + 56; ++x) {
            glm::vec3 c = texel_world(x, y);
            float e = map.irradiance[size_t(y) * kMap + x].r;
            float expected = closed_form(light, intensity, c);
            // Distance of the texel centre from the shadow square's border (1 m wide, under the
            // light).
            float border = std::max(std::abs(c.x - light.x), std::abs(c.z - light.z)) - 0.5f;
            if (border < -0.75f / kTexelsPerM) {
                EXPECT_EQ(e, 0.0f) << x << "," << y;
            } else if (border > 0.75f / kTexelsPerM) {
                // The mean over the texel matches the centre value closely (E is smooth here).
                EXPECT_NEAR(e, expected, 0.01f * expected) << x << "," << y;
            }
            dark += e == 0.0f;
            partial += e > 0.05f * expected && e < 0.95f * expected;
        }
    EXPECT_GT(partial, size_t(2.0f * kTexelsPerM));  // along the 4 m border
    EXPECT_LT(dark, size_t(kTexelsPerM * kTexelsPerM));
}

TEST(DirectBake, vertex_colors_hold_irradiance_over_pi) {
    const glm::vec3 light(0.0f, 2.0f, 0.0f);
    const float intensity = 10.0f;
    Scene s = floor_scene(false, light, intensity, 8);  // vertices every 0.5 m
    add_occluder(s, 0.0f, 1.0f, 0.0f);
    DirectLighting lighting(s, DirectBakeOptions{});
    size_t baked = bake_vertex_colors(s, lighting);
    EXPECT_EQ(baked, 81u + 4u);

    const Primitive& floor = s.meshes[0].primitives[0];
    ASSERT_EQ(floor.colors.size(), floor.positions.size());
    for (size_t i = 0; i < floor.positions.size(); ++i) {
        glm::vec3 p = floor.positions[i];
        bool shadowed = std::abs(p.x) < 0.5f && std::abs(p.z) < 0.5f;
        float expected = shadowed ? 0.0f : closed_form(light, intensity, p) / kPi;
        EXPECT_NEAR(floor.colors[i].r, expected, 1e-3f * expected + 1e-7f) << p.x << "," << p.z;
        EXPECT_EQ(floor.colors[i].a, 1.0f);
    }
    // The occluder's corners see the light 1 m above their plane.
    const Primitive& occ = s.meshes[1].primitives[0];
    for (size_t i = 0; i < occ.positions.size(); ++i) {
        glm::vec3 p = occ.positions[i] + glm::vec3(0, 1, 0);
        float expected = closed_form(light, intensity, p) / kPi;
        EXPECT_NEAR(occ.colors[i].r, expected, 1e-3f * expected);
    }
}

TEST(DirectBake, vertex_and_lightmap_modes_agree) {
    const glm::vec3 light(0.5f, 1.5f, 0.25f);
    Scene lm = floor_scene(true, light, 5.0f, 8);
    Scene vx = floor_scene(false, light, 5.0f, 8);
    DirectBakeOptions opt;
    Result<std::vector<LightmapBake>> maps = bake_lightmaps(lm, DirectLighting(lm, opt), opt);
    ASSERT_TRUE(maps.ok());
    bake_vertex_colors(vx, DirectLighting(vx, opt));
    const Primitive& floor = vx.meshes[0].primitives[0];
    // Texel centres nearest to interior vertices: E differs only by the offset between the two
    // points.
    for (size_t i = 0; i < floor.positions.size(); ++i) {
        glm::vec3 p = floor.positions[i];
        if (std::abs(p.x) > 1.9f || std::abs(p.z) > 1.9f) continue;
        int tx = texel_of(p.x), ty = texel_of(p.z);
        float texel_e = (*maps)[0].irradiance[size_t(ty) * kMap + tx].r;
        float scale = closed_form(light, 5.0f, p) / closed_form(light, 5.0f, texel_world(tx, ty));
        EXPECT_NEAR(floor.colors[i].r * kPi, texel_e * scale, 1e-3f * texel_e * scale);
    }
}

TEST(DirectBake, ambient_adds_pi_times_radiance) {
    Scene s = floor_scene(true, glm::vec3(0), 0.0f, 2);
    DirectBakeOptions opt;
    opt.ambient_radiance = glm::vec3(0.1f, 0.2f, 0.3f);
    Result<std::vector<LightmapBake>> maps = bake_lightmaps(s, DirectLighting(s, opt), opt);
    ASSERT_TRUE(maps.ok());
    EXPECT_NEAR((*maps)[0].intensity, kPi * 0.3f, 1e-6f);
    const uint8_t* texel = &s.textures[0].rgba8[(size_t(20) * kMap + 20) * 4];
    EXPECT_EQ(texel[2], 255);
    EXPECT_EQ(texel[0], 85);  // 0.1 / 0.3 of 255

    Scene v = floor_scene(false, glm::vec3(0), 0.0f, 2);
    bake_vertex_colors(v, DirectLighting(v, opt));
    for (const glm::vec4& c : v.meshes[0].primitives[0].colors) {
        EXPECT_NEAR(c.r, 0.1f, 1e-6f);
        EXPECT_NEAR(c.b, 0.3f, 1e-6f);
    }
}

TEST(DirectBake, directional_light_placed_by_rotated_node) {
    Scene s = floor_scene(false, glm::vec3(0), 0.0f, 2);
    Node sun;
    sun.name = "sun";
    // A quarter turn about +X points the light's -Z straight down.
    sun.rotation = glm::angleAxis(glm::radians(-90.0), glm::dvec3(1, 0, 0));
    s.nodes.push_back(sun);
    s.roots.push_back(int(s.nodes.size()) - 1);
    glm::dvec3 fwd = sun.rotation * glm::dvec3(0, 0, -1);
    ASSERT_NEAR(fwd.y, -1.0, 1e-9);
    Light l;
    l.type = Light::Type::Directional;
    l.intensity = 2.0f;
    l.color = glm::vec3(1.0f, 0.5f, 0.25f);
    l.node = int(s.nodes.size()) - 1;
    s.lights.push_back(l);
    bake_vertex_colors(s, DirectLighting(s, DirectBakeOptions{}));
    for (const glm::vec4& c : s.meshes[0].primitives[0].colors) {
        EXPECT_NEAR(c.r * kPi, 2.0f, 1e-5f);
        EXPECT_NEAR(c.b * kPi, 0.5f, 1e-5f);
    }
}

TEST(DirectBake, reports_bad_lightmap_setup) {
    Scene s = floor_scene(true, glm::vec3(0, 2, 0), 1.0f);
    s.meshes[0].primitives[0].uv1.clear();
    Result<std::vector<LightmapBake>> r = bake_lightmaps(s, DirectLighting(s, {}), {});
    ASSERT_FALSE(r.ok());
    EXPECT_NE(r.error().message.find("TEXCOORD_1"), std::string::npos) << r.error().message;

    Scene z = floor_scene(true, glm::vec3(0, 2, 0), 1.0f);
    z.textures[0].width = 0;
    r = bake_lightmaps(z, DirectLighting(z, {}), {});
    ASSERT_FALSE(r.ok());
    EXPECT_NE(r.error().message.find("no size"), std::string::npos) << r.error().message;
}

}  // namespace
}  // namespace hmdnode
