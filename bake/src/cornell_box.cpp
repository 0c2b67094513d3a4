// The Cornell box (Goral, Torrance, Greenberg & Battaile, "Modeling the Interaction of Light
// Between Diffuse Surfaces", SIGGRAPH 1984; geometry from the Cornell data page), as quads.
//
// Departures: the light is 0.1 mm under the ceiling (548.7 instead of 548.8 mm) so it is not
// coplanar with the ceiling; reflectances and emission are RGB approximations (cornell_box.hpp);
// each quad is oriented towards the inside of the room (walls) or away from its block's centre,
// since the published vertex order is not consistent. Lightmap charts: orthogonal projection of
// each (planar) quad on its own edge frame, shelf-packed. Cost: O(quads).
#include "hmdnode/bake/cornell_box.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

namespace hmdnode {
namespace {

struct Quad {
    glm::vec3 p[4];  // millimetres
    int material;
    glm::vec3 inside;  // a point on the side the front faces (walls) ...
    bool towards;      // ... true: face towards `inside`; false: away from it (blocks)
};

// A quad's lightmap chart: its 2-D frame (metres), size in texels and place in the atlas.
struct WallChart {
    glm::vec3 o, u, v;  // world origin and unit axes
    glm::vec2 lo, size_m;
    int x = 0, y = 0, w = 0, h = 0;
};

constexpr int kPad = 3;  // texels around each chart

// The published geometry (millimetres), materials 0 white, 1 red, 2 green, 3 light; the light last.
std::vector<Quad> cornell_quads() {
    const glm::vec3 room_c(278, 274, 280), short_c(186, 82, 169), tall_c(368, 165, 351);
    return {
        // floor, ceiling, back wall (white)
        {{{552.8f, 0, 0}, {0, 0, 0}, {0, 0, 559.2f}, {549.6f, 0, 559.2f}}, 0, room_c, true},
        {{{556, 548.8f, 0}, {556, 548.8f, 559.2f}, {0, 548.8f, 559.2f}, {0, 548.8f, 0}},
         0,
         room_c,
         true},
        {{{549.6f, 0, 559.2f}, {0, 0, 559.2f}, {0, 548.8f, 559.2f}, {556, 548.8f, 559.2f}},
         0,
         room_c,
         true},
        // right wall (green, x = 0), left wall (red)
        {{{0, 0, 559.2f}, {0, 0, 0}, {0, 548.8f, 0}, {0, 548.8f, 559.2f}}, 2, room_c, true},
        {{{552.8f, 0, 0}, {549.6f, 0, 559.2f}, {556, 548.8f, 559.2f}, {556, 548.8f, 0}},
         1,
         room_c,
         true},
        // short block
        {{{130, 165, 65}, {82, 165, 225}, {240, 165, 272}, {290, 165, 114}}, 0, short_c, false},
        {{{290, 0, 114}, {290, 165, 114}, {240, 165, 272}, {240, 0, 272}}, 0, short_c, false},
        {{{130, 0, 65}, {130, 165, 65}, {290, 165, 114}, {290, 0, 114}}, 0, short_c, false},
        {{{82, 0, 225}, {82, 165, 225}, {130, 165, 65}, {130, 0, 65}}, 0, short_c, false},
        {{{240, 0, 272}, {240, 165, 272}, {82, 165, 225}, {82, 0, 225}}, 0, short_c, false},
        // tall block
        {{{423, 330, 247}, {265, 330, 296}, {314, 330, 456}, {472, 330, 406}}, 0, tall_c, false},
        {{{423, 0, 247}, {423, 330, 247}, {472, 330, 406}, {472, 0, 406}}, 0, tall_c, false},
        {{{472, 0, 406}, {472, 330, 406}, {314, 330, 456}, {314, 0, 456}}, 0, tall_c, false},
        {{{314, 0, 456}, {314, 330, 456}, {265, 330, 296}, {265, 0, 296}}, 0, tall_c, false},
        {{{265, 0, 296}, {265, 330, 296}, {423, 330, 247}, {423, 0, 247}}, 0, tall_c, false},
        // light, facing down
        {{{343, 548.7f, 227}, {343, 548.7f, 332}, {213, 548.7f, 332}, {213, 548.7f, 227}},
         3,
         {278, 0, 280},
         true},
    };
}

void add_materials(Scene& s, bool lm) {
    auto material = [&](const char* name, glm::vec3 albedo, glm::vec3 emission, bool lightmap) {
        Material m;
        m.name = name;
        m.base_color_factor = glm::vec4(albedo, 1.0f);
        m.emissive_factor = emission;
        if (lightmap) m.lightmap.texture = 0;
        s.materials.push_back(m);
    };
    material("white", {0.73f, 0.72f, 0.68f}, glm::vec3(0.0f), lm);
    material("red", {0.63f, 0.065f, 0.05f}, glm::vec3(0.0f), lm);
    material("green", {0.15f, 0.45f, 0.09f}, glm::vec3(0.0f), lm);
    material("light", {0.78f, 0.78f, 0.78f}, {17.0f, 12.0f, 4.0f}, false);
}

// Converts q to metres, orients it (see the departures above) and returns its chart, sized in
// texels when lm.
WallChart orient_and_chart(Quad& q, double texels_per_metre, bool lm) {
    for (glm::vec3& p : q.p) p *= 0.001f;
    glm::vec3 n = glm::normalize(glm::cross(q.p[1] - q.p[0], q.p[2] - q.p[0]));
    const glm::vec3 c = (q.p[0] + q.p[1] + q.p[2] + q.p[3]) * 0.25f;
    const bool faces_inside = glm::dot(n, q.inside * 0.001f - c) > 0.0f;
    if (faces_inside != q.towards) {
        std::swap(q.p[1], q.p[3]);
        n = -n;
    }
    WallChart ch;
    ch.o = q.p[0];
    ch.u = glm::normalize(q.p[1] - q.p[0]);
    ch.v = glm::cross(n, ch.u);
    glm::vec2 lo(1e9f), hi(-1e9f);
    for (const glm::vec3& p : q.p) {
        glm::vec2 t(glm::dot(p - ch.o, ch.u), glm::dot(p - ch.o, ch.v));
        lo = glm::min(lo, t);
        hi = glm::max(hi, t);
    }
    ch.lo = lo;
    ch.size_m = hi - lo;
    if (lm) {
        ch.w = std::max(1, int(std::ceil(ch.size_m.x * texels_per_metre)));
        ch.h = std::max(1, int(std::ceil(ch.size_m.y * texels_per_metre)));
    }
    return ch;
}

// Shelf-packs the charts of every quad but the last (the light, not lightmapped) into a
// square-ish atlas; returns the black, opaque atlas texture.
Texture pack_charts(std::vector<WallChart>& charts) {
    double area = 0.0;
    for (size_t qi = 0; qi + 1 < charts.size(); ++qi)
        area += double(charts[qi].w + kPad) * (charts[qi].h + kPad);
    int width = std::max(16, int(std::ceil(std::sqrt(area) * 1.15)));
    for (size_t qi = 0; qi + 1 < charts.size(); ++qi)
        width = std::max(width, charts[qi].w + 2 * kPad);
    int x = kPad, y = kPad, shelf = 0;
    for (size_t qi = 0; qi + 1 < charts.size(); ++qi) {
        WallChart& ch = charts[qi];
        if (x + ch.w + kPad > width) {
            x = kPad;
            y += shelf + kPad;
            shelf = 0;
        }
        ch.x = x;
        ch.y = y;
        x += ch.w + kPad;
        shelf = std::max(shelf, ch.h);
    }
    Texture t;
    t.name = "cornell_lightmap";
    t.width = width;
    t.height = y + shelf + kPad;
    t.rgba8.assign(size_t(t.width) * t.height * 4, 0);
    for (size_t i = 3; i < t.rgba8.size(); i += 4) t.rgba8[i] = 255;
    return t;
}

// Appends quad q (two triangles) to p, with uv1 in its chart of the atlas when `uv1`.
void add_quad(const Quad& q, const WallChart& ch, bool uv1, glm::vec2 atlas, Primitive& p) {
    const uint32_t b = uint32_t(p.positions.size());
    const glm::vec3 n = glm::normalize(glm::cross(q.p[1] - q.p[0], q.p[2] - q.p[0]));
    for (const glm::vec3& v : q.p) {
        p.positions.push_back(v);
        p.normals.push_back(n);
        if (uv1) {
            glm::vec2 t(glm::dot(v - ch.o, ch.u), glm::dot(v - ch.o, ch.v));
            t -= ch.lo;
            // The chart's world extent maps onto its w x h texels exactly.
            glm::vec2 texel(ch.x + t.x / ch.size_m.x * ch.w, ch.y + t.y / ch.size_m.y * ch.h);
            p.uv1.push_back(texel / atlas);
        }
    }
    p.indices.insert(p.indices.end(), {b, b + 1, b + 2, b, b + 2, b + 3});
}

}  // namespace

Scene cornell_box_scene(double texels_per_metre) {
    std::vector<Quad> quads = cornell_quads();
    Scene s;
    const bool lm = texels_per_metre > 0.0;
    add_materials(s, lm);

    // One mesh with a primitive per material.
    Mesh mesh;
    mesh.name = "cornell_box";
    mesh.primitives.resize(4);
    for (int k = 0; k < 4; ++k) mesh.primitives[k].material = k;

    std::vector<WallChart> charts(quads.size());
    for (size_t qi = 0; qi < quads.size(); ++qi)
        charts[qi] = orient_and_chart(quads[qi], texels_per_metre, lm);
    int atlas_w = 0, atlas_h = 0;
    if (lm) {
        s.textures.push_back(pack_charts(charts));
        atlas_w = s.textures.back().width;
        atlas_h = s.textures.back().height;
    }
    for (size_t qi = 0; qi < quads.size(); ++qi) {
        const Quad& q = quads[qi];
        add_quad(q, charts[qi], lm && q.material != 3, glm::vec2(atlas_w, atlas_h),
                 mesh.primitives[q.material]);
    }
    s.meshes.push_back(std::move(mesh));
    Node node;
    node.name = "cornell_box";
    node.mesh = 0;
    s.nodes.push_back(node);
    s.roots.push_back(0);
    return s;
}

}  // namespace hmdnode
