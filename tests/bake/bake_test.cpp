// The bake pipeline against closed-form answers at lightmap texels: a point light over a plane
// (E = I cos / r^2) with the hard shadow of an occluder where geometry puts it, a plane under a
// uniform sky (E = pi Ls), a closed room lit only from outside (about 0 inside), the texels under
// a box (invalid, filled from neighbours), determinism across thread counts, and input errors.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

#include "hmdnode/bake/bake.hpp"
#include "hmdnode/bake/path_tracer.hpp"
#include "hmdnode/bake/progress_eta.hpp"
#include "hmdnode/core/gltf.hpp"

namespace hmdnode {
namespace {

constexpr float kPi = std::numbers::pi_v<float>;

struct Builder {
    Scene s;
    // mesh per material kind: 0 lightmapped floor, 1 other geometry
    Builder(glm::vec3 floor_albedo, glm::vec3 other_albedo, int lightmap_size) {
        Material floor;
        floor.name = "floor";
        floor.base_color_factor = glm::vec4(floor_albedo, 1.0f);
        floor.lightmap.texture = 0;
        Material other;
        other.name = "other";
        other.base_color_factor = glm::vec4(other_albedo, 1.0f);
        s.materials = {floor, other};
        Texture t;
        t.name = "lightmap";
        t.width = t.height = lightmap_size;
        t.rgba8.assign(size_t(lightmap_size) * lightmap_size * 4, 0);
        s.textures.push_back(t);
        for (int i = 0; i < 2; ++i) {
            Mesh m;
            m.name = i == 0 ? "floor" : "other";
            m.primitives.emplace_back();
            m.primitives[0].material = i;
            s.meshes.push_back(m);
            Node n;
            n.name = m.name;
            n.mesh = i;
            s.nodes.push_back(n);
            s.roots.push_back(i);
        }
    }
    // Quad o, o+u, o+u+v, o+v (front = u x v) into mesh k; uv1 maps u to x and v to y of the
    // whole lightmap when `uv` (floor only).
    void quad(int k, glm::vec3 o, glm::vec3 u, glm::vec3 v, bool uv) {
        Primitive& p = s.meshes[k].primitives[0];
        const uint32_t b = uint32_t(p.positions.size());
        p.positions.insert(p.positions.end(), {o, o + u, o + u + v, o + v});
        const glm::vec3 n = glm::normalize(glm::cross(u, v));
        p.normals.insert(p.normals.end(), 4, n);
        if (uv) p.uv1.insert(p.uv1.end(), {{0, 0}, {1, 0}, {1, 1}, {0, 1}});
        p.indices.insert(p.indices.end(), {b, b + 1, b + 2, b, b + 2, b + 3});
    }
    void point_light(glm::vec3 at, float intensity) {
        Node n;
        n.name = "light";
        n.translation = glm::dvec3(at);
        s.nodes.push_back(n);
        s.roots.push_back(int(s.nodes.size()) - 1);
        Light l;
        l.intensity = intensity;
        l.node = int(s.nodes.size()) - 1;
        s.lights.push_back(l);
    }
};

// The floor [-2, 2] x [-2, 2] at y = 0, normal +y; uv1 (0,0) at (-2, 0, -2), u along +z... we
// pick o = (-2,0,-2), u = (0,0,4), v = (4,0,0): texel (x, y) spans z in [-2 + 4x/W, ...] and x
// in [-2 + 4y/H, ...].
glm::vec3 floor_point(float tx, float ty, int size) {
    return {-2.0f + 4.0f * ty / size, 0.0f, -2.0f + 4.0f * tx / size};
}

TEST(Bake, PointLightOverPlaneWithHardShadow) {
    const int size = 32;
    Builder b(glm::vec3(0.0f), glm::vec3(0.0f), size);  // black: no indirect light
    b.quad(0, {-2, 0, -2}, {0, 0, 4}, {4, 0, 0}, true);
    b.quad(1, {-0.2f, 0.5f, -0.2f}, {0, 0, 0.4f}, {0.4f, 0, 0}, false);  // occluder, y = 0.5
    const float intensity = 10.0f;
    b.point_light({0, 1, 0}, intensity);
    BakeOptions o;
    o.samples = 8;
    o.strata = 2;
    o.threads = 2;
    Result<BakeReport> r = bake_scene(b.s, o);
    ASSERT_TRUE(r.ok()) << r.error().message;
    ASSERT_EQ(r->maps.size(), 1u);
    const BakedMap& m = r->maps[0];
    EXPECT_EQ(m.covered, size_t(size * size));
    EXPECT_EQ(m.invalid, 0u);
    auto formula = [&](glm::vec3 p) {
        glm::vec3 d = glm::vec3(0, 1, 0) - p;
        float rr = glm::length(d);
        return intensity * (d.y / rr) / (rr * rr);
    };
    size_t lit = 0, umbra = 0;
    for (int y = 0; y < size; ++y)
        for (int x = 0; x < size; ++x) {
            const glm::vec3 lo = floor_point(float(x), float(y), size);
            const glm::vec3 hi = floor_point(float(x + 1), float(y + 1), size);
            const float e = m.raw[size_t(y) * size + x].r;
            // The umbra of the occluder is [-0.4, 0.4]^2; its edge is hard (point light).
            const bool inside = hi.x < 0.4f && lo.x > -0.4f && hi.z < 0.4f && lo.z > -0.4f;
            const bool outside = lo.x > 0.4f || hi.x < -0.4f || lo.z > 0.4f || hi.z < -0.4f;
            if (inside) {
                EXPECT_EQ(e, 0.0f) << x << "," << y;
                ++umbra;
            } else if (outside) {
                // Mean of the formula at the 2 x 2 stratum centres.
                float ref = 0.0f;
                for (float sy : {0.25f, 0.75f})
                    for (float sx : {0.25f, 0.75f})
                        ref += 0.25f * formula(floor_point(x + sx, y + sy, size));
                EXPECT_NEAR(e, ref, 0.02f * ref) << x << "," << y;
                ++lit;
            }
        }
    EXPECT_EQ(umbra, 36u);  // 6 x 6 texels of 0.125 m fit in the 0.8 m umbra
    EXPECT_GT(lit, 900u);
}

TEST(Bake, PlaneUnderUniformSky) {
    const int size = 16;
    Builder b(glm::vec3(0.5f), glm::vec3(0.5f), size);
    b.quad(0, {-2, 0, -2}, {0, 0, 4}, {4, 0, 0}, true);
    BakeOptions o;
    o.samples = 4;
    o.sky_radiance = glm::vec3(0.2f, 0.4f, 0.8f);
    Result<BakeReport> r = bake_scene(b.s, o);
    ASSERT_TRUE(r.ok()) << r.error().message;
    const BakedMap& m = r->maps[0];
    for (size_t i = 0; i < m.raw.size(); ++i)
        for (int c = 0; c < 3; ++c) {
            const float ref = kPi * o.sky_radiance[c];
            ASSERT_NEAR(m.raw[i][c], ref, 0.02f * ref) << i;
            ASSERT_NEAR(m.final_e[i][c], ref, 0.02f * ref) << i;
        }
    // The stored texture (RGBM) decodes to E within 8-bit quantisation.
    const Material& mat = b.s.materials[0];
    ASSERT_EQ(mat.lightmap.encoding, LightmapEncoding::Rgbm);
    const std::vector<uint8_t>& t = b.s.textures[0].rgba8;
    const float decoded = t[2] / 255.0f * t[3] / 255.0f * mat.lightmap.intensity;
    EXPECT_NEAR(decoded, kPi * 0.8f, 0.01f * kPi * 0.8f);
}

// A sun shining down and sideways (5 lx) and a white sky (radiance 1), baked with 32 paths per
// texel and 3 bounces.
Result<BakeReport> bake_in_sun_and_sky(Builder& b) {
    Node sun;
    sun.rotation =
        glm::angleAxis(-1.0, glm::dvec3(1, 0, 0)) * glm::angleAxis(0.3, glm::dvec3(0, 1, 0));
    b.s.nodes.push_back(sun);
    Light l;
    l.type = Light::Type::Directional;
    l.intensity = 5.0f;
    l.node = int(b.s.nodes.size()) - 1;
    b.s.lights.push_back(l);
    BakeOptions o;
    o.samples = 32;
    o.bounces = 3;
    o.sky_radiance = glm::vec3(1.0f);
    return bake_scene(b.s, o);
}

// A closed room [-1, 1] x [0, 2] x [-1, 1] of zero-thickness double-sided walls (thin walls: the
// classic leak), a floor that runs 0.5 m past the walls, a sun and a sky outside: inside is dark,
// outside is lit.
TEST(Bake, ClosedRoomLitFromOutsideIsDarkInside) {
    const int size = 24;  // floor 3 m -> 0.125 m texels
    Builder b(glm::vec3(0.8f), glm::vec3(0.8f), size);
    b.s.materials[1].double_sided = true;
    b.quad(0, {-1.5f, 0, -1.5f}, {0, 0, 3}, {3, 0, 0}, true);
    b.quad(1, {-1, 2, -1}, {2, 0, 0}, {0, 0, 2}, false);  // ceiling, normal -y
    b.quad(1, {-1, 0, -1}, {0, 2, 0}, {0, 0, 2}, false);  // x = -1, normal +x
    b.quad(1, {1, 0, -1}, {0, 0, 2}, {0, 2, 0}, false);   // x = +1, normal -x
    b.quad(1, {-1, 0, -1}, {2, 0, 0}, {0, 2, 0}, false);  // z = -1, normal +z
    b.quad(1, {-1, 0, 1}, {0, 2, 0}, {2, 0, 0}, false);   // z = +1, normal -z
    Result<BakeReport> r = bake_in_sun_and_sky(b);
    ASSERT_TRUE(r.ok()) << r.error().message;
    const BakedMap& m = r->maps[0];
    float max_inside = 0.0f, min_outside = 1e9f;
    for (int y = 0; y < size; ++y)
        for (int x = 0; x < size; ++x) {
            // Texel (x, y): z in [-1.5 + 3x/size, ...], x in [-1.5 + 3y/size, ...].
            const float z0 = -1.5f + 3.0f * x / size, z1 = z0 + 3.0f / size;
            const float x0 = -1.5f + 3.0f * y / size, x1 = x0 + 3.0f / size;
            const size_t i = size_t(y) * size + x;
            if (x0 > -1 && x1 < 1 && z0 > -1 && z1 < 1) {
                max_inside = std::max({max_inside, m.raw[i].r, m.final_e[i].r});
            } else if (x0 > 1 || x1 < -1 || z0 > 1 || z1 < -1) {
                min_outside = std::min(min_outside, m.raw[i].r);
            }
        }
    EXPECT_GT(min_outside, 0.4f * kPi);  // about half the sky (a wall hides the rest) and more
    EXPECT_LT(max_inside, 1e-3f * min_outside);
}

// A low box standing on the floor, its sides off the texel grid: the floor texels under it see
// the back faces of its top and sides; their samples are inside a solid, so they are marked
// invalid and filled from their lit neighbours. The texels its sides cut through keep their
// visible samples only (the buried ones are left out), so they read the light of their visible
// strip next to the box (a 0.1 m wall takes (1 - d / sqrt(d^2 + 0.01)) / 2 of the sky at distance
// d) instead of half dark.
TEST(Bake, TexelsUnderABoxAreInvalidAndFilled) {
    const int size = 32;  // 4 m floor -> 0.125 m texels
    Builder b(glm::vec3(0.0f), glm::vec3(0.0f), size);
    b.quad(0, {-2, 0, -2}, {0, 0, 4}, {4, 0, 0}, true);
    const float h = 0.56f, t = 0.1f;  // box [-h, h]^2 x [0, t], outward faces, no bottom
    b.quad(1, {-h, t, -h}, {0, 0, 2 * h}, {2 * h, 0, 0}, false);  // top, +y
    b.quad(1, {-h, 0, -h}, {0, t, 0}, {2 * h, 0, 0}, false);      // z = -h: normal -z
    b.quad(1, {-h, 0, h}, {2 * h, 0, 0}, {0, t, 0}, false);       // z = +h: normal +z
    b.quad(1, {-h, 0, -h}, {0, 0, 2 * h}, {0, t, 0}, false);      // x = -h: normal -x
    b.quad(1, {h, 0, -h}, {0, t, 0}, {0, 0, 2 * h}, false);       // x = +h: normal +x
    BakeOptions o;
    o.samples = 64;
    o.sky_radiance = glm::vec3(1.0f);
    o.denoise_iterations = 0;
    Result<BakeReport> r = bake_scene(b.s, o);
    ASSERT_TRUE(r.ok()) << r.error().message;
    const BakedMap& m = r->maps[0];
    size_t invalid_under = 0;
    for (int y = 0; y < size; ++y)
        for (int x = 0; x < size; ++x) {
            const glm::vec3 lo = floor_point(float(x), float(y), size);
            const glm::vec3 hi = floor_point(float(x + 1), float(y + 1), size);
            const size_t i = size_t(y) * size + x;
            if (lo.x >= -h && hi.x <= h && lo.z >= -h && hi.z <= h) {
                invalid_under += m.valid[i] ? 0 : 1;
                EXPECT_GT(m.final_e[i].r, 0.5f) << "filled from neighbours " << x << "," << y;
            }
        }
    EXPECT_EQ(invalid_under, 64u);  // [-0.5, 0.5]^2: 8 x 8 texels lie fully under the box
    EXPECT_LE(m.invalid, 100u);     // plus at most the ring the box's sides cut through
    EXPECT_GT(m.buried_samples, 0u);
    // Texels cut by the side x = -h (x in [-0.625, -0.5]; visible: x < -0.56), along the middle
    // of that side, against the sky over their visible strip (d = -0.56 - x in [0, 0.065]), the
    // side taken as infinitely long. Their visible samples lie at x = -0.59375 (the 2 x 2
    // strata's first column; the second is under the box), d = 0.034: 0.66 of pi.
    const int row_cut = 11;  // floor_point: x = -2 + 4 y / 32
    const double d = -h - (-2.0 + 4.0 * (row_cut + 0.25) / size);
    const double expected = kPi * (1.0 + d / std::sqrt(d * d + double(t) * t)) / 2.0;
    double sum = 0.0;
    int count = 0;
    for (int col = 13; col <= 18; ++col) {
        const size_t cut = size_t(row_cut) * size + col;
        ASSERT_TRUE(m.valid[cut]) << col;
        sum += m.raw[cut].r;
        ++count;
    }
    std::printf("texels the box's side cuts: mean E %.3f, sky over their visible samples %.3f\n",
                sum / count, expected);
    EXPECT_NEAR(sum / count, expected, 0.1 * expected);
}

// The faces of the box [lo, hi] into mesh 1, facing out (inward: a room); bit f of `faces` keeps
// face f (0: x = lo, 1: x = hi, 2: y = lo, 3: y = hi, 4: z = lo, 5: z = hi); the faces in
// `lightmapped` go to mesh 0 instead, over the whole lightmap.
void box(Builder& b, glm::vec3 lo, glm::vec3 hi, bool inward, unsigned faces = 63u,
         unsigned lightmapped = 0u) {
    const glm::vec3 dx(hi.x - lo.x, 0, 0), dy(0, hi.y - lo.y, 0), dz(0, 0, hi.z - lo.z);
    struct Face {
        glm::vec3 o, u, v;  // outward: u x v points out
    };
    const Face all[6] = {{lo, dz, dy}, {{hi.x, lo.y, lo.z}, dy, dz},
                         {lo, dx, dz}, {{lo.x, hi.y, lo.z}, dz, dx},
                         {lo, dy, dx}, {{lo.x, lo.y, hi.z}, dx, dy}};
    for (unsigned f = 0; f < 6; ++f) {
        if (!(faces & (1u << f))) continue;
        const bool lm = (lightmapped & (1u << f)) != 0;
        const Face& q = all[f];
        if (inward)
            b.quad(lm ? 0 : 1, q.o, q.v, q.u, lm);
        else
            b.quad(lm ? 0 : 1, q.o, q.u, q.v, lm);
    }
}

// Two closed rooms of single-sided walls facing in, back to back on the plane x = 0 (room B's
// wall there faces -x, room A's +x), room A lit by a point light: room A's shared wall bakes as
// it does with the rooms 1 mm apart (both 11.4337). Before, with room B's triangles first, its
// validity rays met room B's wall as a back face and pushed the samples behind it into dark room
// B: all 256 texels invalid, mean 0; with the validity fix alone, paths that reached the shared
// wall were absorbed by room B's back face where Embree returned it: mean 9.72 (-15 %).
TEST(Bake, RoomsSharingAWallPlaneBakeLikeRoomsApart) {
    // other_first: room B's triangles come before room A's lightmapped wall in the traced
    // geometry, so a query that meets both walls at the same distance may return room B's.
    auto shared_wall = [](float gap, bool other_first) {
        Builder b(glm::vec3(0.6f), glm::vec3(0.6f), 16);
        box(b, {0, 0, 0}, {2, 2, 2}, true, 63u, 1u);   // room A; its wall x = 0 lightmapped
        box(b, {-2 - gap, 0, 0}, {-gap, 2, 2}, true);  // room B, unlit
        if (other_first) std::swap(b.s.roots[0], b.s.roots[1]);
        b.point_light({1.3f, 1.2f, 0.9f}, 10.0f);
        BakeOptions o;
        o.samples = 64;
        o.threads = 2;
        Result<BakeReport> r = bake_scene(b.s, o);
        EXPECT_TRUE(r.ok()) << r.error().message;
        const BakedMap& m = r->maps[0];
        double sum = 0.0;
        for (const glm::vec3& e : m.final_e) sum += double(e.r);
        std::printf(
            "gap %g m, %s first: shared wall mean E %.4f, %zu invalid texels, %zu "
            "pushed samples\n",
            double(gap), other_first ? "room B" : "room A", sum / double(m.final_e.size()),
            m.invalid, m.pushed_samples);
        EXPECT_EQ(m.covered, m.final_e.size());
        return std::pair(sum / double(m.final_e.size()), m.invalid);
    };
    for (bool other_first : {false, true}) {
        const auto [touching, touching_invalid] = shared_wall(0.0f, other_first);
        const auto [apart, apart_invalid] = shared_wall(1e-3f, other_first);
        EXPECT_GT(apart, 1.0);
        EXPECT_NEAR(touching, apart, 0.01 * apart) << other_first;
        EXPECT_EQ(touching_invalid, apart_invalid) << other_first;
    }
}

// A room of thick walls (closed boxes 0.3 m thick, single-sided faces out, no bottoms) and a
// ceiling slab, lit from outside by a sun and a sky. The walls' inner faces (|x| or |z| = 0.93)
// and outer faces (1.23) cut through floor texels (edges every 0.125 m from -1.5); every texel
// wholly inside stays dark, the ones next to the cut texels included, and the floor outside is
// lit. The texels the faces cut: no inner one lit (their samples buried in the wall are left out,
// not pushed out through the far face), no outer one darkened: each within 20 % of a reference
// traced over its visible part (8 x 8 points x 16 paths), 10 % on average. Before the inside test
// (texel_validity.cpp): 11 of 60 inner ones lit, the outer ones 0.71 of the reference on average,
// 0.52 at worst. (ClosedRoomLitFromOutsideIsDarkInside puts its walls on texel edges.)
TEST(Bake, WallsOffTexelEdgesBakeLikeTheirVisiblePart) {
    const int size = 24;  // floor 3 m -> 0.125 m texels
    const float a = 0.93f, c = 1.23f, h = 2.0f;
    Builder b(glm::vec3(0.8f), glm::vec3(0.8f), size);
    b.quad(0, {-1.5f, 0, -1.5f}, {0, 0, 3}, {3, 0, 0}, true);
    const unsigned no_bottom = 63u & ~4u;
    box(b, {a, 0, -c}, {c, h, c}, false, no_bottom);
    box(b, {-c, 0, -c}, {-a, h, c}, false, no_bottom);
    box(b, {-a, 0, a}, {a, h, c}, false, no_bottom);
    box(b, {-a, 0, -c}, {a, h, -a}, false, no_bottom);
    box(b, {-c, h, -c}, {c, h + 0.3f, c}, false);  // ceiling slab, on the walls
    Result<BakeReport> r = bake_in_sun_and_sky(b);
    ASSERT_TRUE(r.ok()) << r.error().message;
    const BakedMap& m = r->maps[0];
    // Texel (x, y): z in [-1.5 + 3x/size, ...], x in [-1.5 + 3y/size, ...].
    auto lo = [&](int i) { return -1.5f + 3.0f * float(i) / size; };
    auto hi = [&](int i) { return lo(i + 1); };
    auto inside = [&](int x, int y) {  // wholly in the room
        return lo(y) > -a && hi(y) < a && lo(x) > -a && hi(x) < a;
    };
    auto meets_room = [&](int x, int y) {
        return hi(y) > -a && lo(y) < a && hi(x) > -a && lo(x) < a;
    };
    auto outside = [&](int x, int y) {  // wholly beyond the walls
        return lo(y) > c || hi(y) < -c || lo(x) > c || hi(x) < -c;
    };
    auto meets_outside = [&](int x, int y) {
        return hi(y) > c || lo(y) < -c || hi(x) > c || lo(x) < -c;
    };
    float min_outside = 1e9f;
    for (int y = 0; y < size; ++y)
        for (int x = 0; x < size; ++x)
            if (outside(x, y)) min_outside = std::min(min_outside, m.raw[size_t(y) * size + x].r);
    EXPECT_GT(min_outside, 0.3f * kPi);
    // Wholly inside: dark, the ring next to the texels the inner faces cut included (no light
    // through the wall from denoising or filling).
    size_t inside_count = 0, inner_cut = 0, inner_leaks = 0, outer_cut = 0, outer_dark = 0;
    PathTracerOptions po;
    po.sky_radiance = glm::vec3(1.0f);
    po.bounces = 3;
    Result<PathTracer> tracer = PathTracer::build(b.s, po);  // the baked scene, sun included
    ASSERT_TRUE(tracer.ok()) << tracer.error().message;
    double ratio_sum = 0.0, worst = 1e9;
    for (int y = 0; y < size; ++y)
        for (int x = 0; x < size; ++x) {
            const size_t i = size_t(y) * size + x;
            if (inside(x, y)) {
                ++inside_count;
                EXPECT_LT(m.final_e[i].r, 1e-3f * min_outside) << x << "," << y << " inside";
            } else if (meets_room(x, y)) {
                ++inner_cut;
                inner_leaks += m.final_e[i].r >= 1e-3f * min_outside ? 1 : 0;
            } else if (meets_outside(x, y) && !outside(x, y)) {
                ++outer_cut;
                outer_dark += m.final_e[i].r < 0.75f * min_outside ? 1 : 0;
                // Reference: the mean irradiance over the texel's visible part (beyond the
                // walls), traced at 8 x 8 points of it with 16 paths each.
                Pcg32 rng(x, y);
                double sum = 0.0;
                int points = 0;
                for (int sy = 0; sy < 8; ++sy)
                    for (int sx = 0; sx < 8; ++sx) {
                        const float pz = lo(x) + (sx + 0.5f) * (hi(x) - lo(x)) / 8;
                        const float px = lo(y) + (sy + 0.5f) * (hi(y) - lo(y)) / 8;
                        if (std::abs(px) < c && std::abs(pz) < c) continue;  // under a wall
                        ++points;
                        for (int k = 0; k < 16; ++k)
                            sum += tracer->irradiance({px, 1e-4f, pz}, {0, 1, 0}, rng).r / 16.0;
                    }
                const double ref = sum / std::max(1, points);
                worst = std::min(worst, m.final_e[i].r / ref);
                ratio_sum += m.final_e[i].r / ref;
            }
        }
    std::printf(
        "texels cut by an inner face: %zu of %zu lit; by an outer face: %zu of %zu below "
        "0.75 x the darkest outside texel; baked / reference on the outer cut texels: mean %.3f, "
        "lowest %.3f\n",
        inner_leaks, inner_cut, outer_dark, outer_cut, ratio_sum / double(outer_cut), worst);
    EXPECT_EQ(inner_leaks, 0u);
    EXPECT_EQ(outer_dark, 0u);
    EXPECT_NEAR(ratio_sum / double(outer_cut), 1.0, 0.1);
    EXPECT_GT(worst, 0.8);
    EXPECT_EQ(inside_count, 196u);  // 14 x 14
    EXPECT_EQ(inner_cut, 60u);      // the ring of the 16 x 16 texels that meet the room
    EXPECT_EQ(outer_cut, 76u);      // the ring of the 20 x 20 texels that do not lie wholly outside
}

// A plane cut into two charts along x = 0, lit by a point light off to one side: without seam
// blending the two sides of the cut read different light (about 7 %); with it, bilinear lookups
// along the cut agree on both sides.
TEST(Bake, SeamBlendingMakesBothSidesOfASplitEdgeAgree) {
    auto run = [](int seam_iterations) {
        Builder b(glm::vec3(0.0f), glm::vec3(0.0f), 16);
        Texture& t = b.s.textures[0];
        t.width = 32;
        t.rgba8.assign(32 * 16 * 4, 0);
        Primitive& p = b.s.meshes[0].primitives[0];
        // Chart A: x in [-1, 0] -> texels x [2, 14); chart B: x in [0, 1] -> [18, 30); z in
        // [-0.5, 0.5] -> texels y [2, 14). Normal +y (u = +z... use o + z-edge first).
        auto chart = [&](float x0, float tx0) {
            const uint32_t base = uint32_t(p.positions.size());
            p.positions.insert(
                p.positions.end(),
                {{x0, 0, -0.5f}, {x0, 0, 0.5f}, {x0 + 1, 0, 0.5f}, {x0 + 1, 0, -0.5f}});
            p.normals.insert(p.normals.end(), 4, glm::vec3(0, 1, 0));
            p.uv1.insert(p.uv1.end(), {{tx0 / 32, 2.0f / 16},
                                       {tx0 / 32, 14.0f / 16},
                                       {(tx0 + 12) / 32, 14.0f / 16},
                                       {(tx0 + 12) / 32, 2.0f / 16}});
            p.indices.insert(p.indices.end(), {base, base + 1, base + 2, base, base + 2, base + 3});
        };
        chart(-1.0f, 2.0f);
        chart(0.0f, 18.0f);
        b.point_light({0.3f, 1.0f, 0.0f}, 10.0f);
        BakeOptions o;
        o.samples = 4;
        o.seam_iterations = seam_iterations;
        Result<BakeReport> r = bake_scene(b.s, o);
        EXPECT_TRUE(r.ok()) << r.error().message;
        return *r;
    };
    auto lookup = [](const BakedMap& m, glm::vec2 texel) {
        const float x = texel.x - 0.5f, y = texel.y - 0.5f;
        const int x0 = int(std::floor(x)), y0 = int(std::floor(y));
        const float fx = x - x0, fy = y - y0;
        auto at = [&](int xi, int yi) { return m.final_e[size_t(yi) * m.width + xi].r; };
        return (1 - fy) * ((1 - fx) * at(x0, y0) + fx * at(x0 + 1, y0)) +
               fy * ((1 - fx) * at(x0, y0 + 1) + fx * at(x0 + 1, y0 + 1));
    };
    const BakeReport plain = run(0), blended = run(BakeOptions{}.seam_iterations);
    EXPECT_EQ(blended.maps[0].seams, 1u);  // the edge x = 0
    float worst_plain = 0.0f, worst_blended = 0.0f;
    for (float ty = 2.5f; ty < 13.6f; ty += 0.5f) {
        const float a0 = lookup(plain.maps[0], {14, ty}), b0 = lookup(plain.maps[0], {18, ty});
        const float a1 = lookup(blended.maps[0], {14, ty}), b1 = lookup(blended.maps[0], {18, ty});
        worst_plain = std::max(worst_plain, std::abs(a0 - b0) / b0);
        worst_blended = std::max(worst_blended, std::abs(a1 - b1) / b1);
    }
    EXPECT_GT(worst_plain, 0.04f);
    EXPECT_LT(worst_blended, 0.01f);
}

TEST(Bake, DeterministicForASeedAcrossThreadCounts) {
    const int size = 16;
    auto run = [&](int threads, uint64_t seed) {
        Builder b(glm::vec3(0.5f), glm::vec3(0.7f), size);
        b.quad(0, {-2, 0, -2}, {0, 0, 4}, {4, 0, 0}, true);
        b.quad(1, {-0.5f, 0.8f, -0.5f}, {0, 0, 1}, {1, 0, 0}, false);
        b.point_light({0.3f, 2, 0}, 5.0f);
        BakeOptions o;
        o.samples = 8;
        o.threads = threads;
        o.seed = seed;
        o.sky_radiance = glm::vec3(0.1f);
        Result<BakeReport> r = bake_scene(b.s, o);
        EXPECT_TRUE(r.ok());
        return r->maps[0].final_e;
    };
    const std::vector<glm::vec3> a = run(1, 42), b2 = run(2, 42), c = run(2, 43);
    EXPECT_EQ(a, b2);
    EXPECT_NE(a, c);
}

TEST(Bake, NoLightIsAClearError) {
    Builder b(glm::vec3(0.5f), glm::vec3(0.5f), 8);
    b.quad(0, {-2, 0, -2}, {0, 0, 4}, {4, 0, 0}, true);
    Result<BakeReport> r = bake_scene(b.s, BakeOptions{});
    ASSERT_FALSE(r.ok());
    EXPECT_NE(r.error().message.find("no KHR_lights_punctual light"), std::string::npos);
}

TEST(Bake, NonFinitePositionNamesTheMesh) {
    Builder b(glm::vec3(0.5f), glm::vec3(0.5f), 8);
    b.quad(0, {-2, 0, -2}, {0, 0, 4}, {4, 0, 0}, true);
    b.quad(1, {0, 1, 0}, {1, 0, 0}, {0, 0, 1}, false);
    b.s.meshes[1].primitives[0].positions[1].y = INFINITY;
    BakeOptions o;
    o.sky_radiance = glm::vec3(1.0f);
    Result<BakeReport> r = bake_scene(b.s, o);
    ASSERT_FALSE(r.ok());
    EXPECT_NE(r.error().message.find("'other'"), std::string::npos) << r.error().message;
    EXPECT_NE(r.error().message.find("vertex 1"), std::string::npos) << r.error().message;
}

TEST(Bake, VertexLightIsIrradiance) {
    Builder b(glm::vec3(0.5f), glm::vec3(0.5f), 8);
    b.quad(1, {-1, 0, -1}, {0, 0, 2}, {2, 0, 0}, false);  // unlightmapped plane, normal +y
    BakeOptions o;
    o.samples = 8;
    o.sky_radiance = glm::vec3(0.3f, 0.6f, 0.9f);
    Result<BakeReport> r = bake_scene(b.s, o);
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_EQ(r->vertices, 4u);
    const float pi = std::numbers::pi_v<float>;
    ASSERT_EQ(b.s.meshes[1].primitives[0].light.size(), 4u);
    for (const glm::vec3& c : b.s.meshes[1].primitives[0].light)  // E = pi Ls
        for (int k = 0; k < 3; ++k)
            EXPECT_NEAR(c[k], pi * o.sky_radiance[k], 0.02f * pi * o.sky_radiance[k]);
    // E above 1 (here up to 2.8) round-trips through the .glb exactly: _LIGHT_0 is float.
    const std::filesystem::path path =
        std::filesystem::temp_directory_path() / "hmdnode_bake_test_vertex_light.glb";
    b.s.meshes.erase(b.s.meshes.begin());  // the empty floor mesh, which glTF cannot hold
    b.s.nodes.erase(b.s.nodes.begin());
    b.s.nodes[0].mesh = 0;
    b.s.roots = {0};
    const Status saved = save_glb(b.s, path);
    ASSERT_TRUE(saved.ok()) << saved.error().message;
    Result<Scene> back = load_gltf(path);
    std::filesystem::remove(path);
    ASSERT_TRUE(back.ok()) << back.error().message;
    const Primitive& p = back->meshes[0].primitives[0];
    EXPECT_EQ(p.light, b.s.meshes[0].primitives[0].light);
    EXPECT_TRUE(p.colors.empty());
    float peak = 0.0f;
    for (const glm::vec3& c : p.light) peak = std::max(peak, c.b);
    EXPECT_GT(peak, 2.5f);
}

// A closed box of albedo rho = 0.9 that emits Le = 1 everywhere (the furnace): E = pi Le / (1 -
// rho) at every texel. At the default settings (no bounce limit, Russian roulette) the bake's
// mean is within 2 % of it; an explicit --bounces 3 keeps sum_{k<=3} rho^k = 3.439 of the 10 and
// warns about it (rho^4 = 66 %).
Scene furnace_scene(float rho) {
    Scene s;
    Material m;
    m.name = "furnace";
    m.base_color_factor = glm::vec4(rho, rho, rho, 1.0f);
    m.emissive_factor = glm::vec3(1.0f);
    s.materials.push_back(m);
    Mesh mesh;
    mesh.name = "box";
    Primitive& p = mesh.primitives.emplace_back();
    p.material = 0;
    auto quad = [&](glm::vec3 o, glm::vec3 u, glm::vec3 v) {
        const uint32_t b = uint32_t(p.positions.size());
        p.positions.insert(p.positions.end(), {o, o + u, o + u + v, o + v});
        p.normals.insert(p.normals.end(), 4, glm::normalize(glm::cross(u, v)));
        p.indices.insert(p.indices.end(), {b, b + 1, b + 2, b, b + 2, b + 3});
    };
    const float h = 0.5f, e = 1.0f;
    quad({-h, -h, -h}, {0, 0, e}, {e, 0, 0});
    quad({-h, h, -h}, {e, 0, 0}, {0, 0, e});
    quad({-h, -h, -h}, {0, e, 0}, {0, 0, e});
    quad({h, -h, -h}, {0, 0, e}, {0, e, 0});
    quad({-h, -h, -h}, {e, 0, 0}, {0, e, 0});
    quad({-h, -h, h}, {0, e, 0}, {e, 0, 0});
    s.meshes.push_back(mesh);
    Node n;
    n.name = "box";
    n.mesh = 0;
    s.nodes.push_back(n);
    s.roots.push_back(0);
    return s;
}

// The mean green channel of `e` (the map's final_e by default) over its valid texels.
double mean_valid(const BakedMap& m, const std::vector<glm::vec3>* e = nullptr) {
    const std::vector<glm::vec3>& v = e ? *e : m.final_e;
    double sum = 0.0;
    size_t count = 0;
    for (size_t i = 0; i < m.valid.size(); ++i)
        if (m.valid[i]) {
            sum += v[i].g;
            ++count;
        }
    return count ? sum / double(count) : 0.0;
}

bool mentions_bounces(const std::vector<std::string>& warnings) {
    for (const std::string& w : warnings)
        if (w.find("bounces") != std::string::npos) return true;
    return false;
}

TEST(Bake, FurnaceOfAlbedo09ConvergesAtTheDefaults) {
    const float rho = 0.9f;
    Scene s = furnace_scene(rho);
    BakeOptions o;  // the defaults, with an atlas so that the box has texels
    o.texels_per_metre = 8.0;
    o.threads = 2;
    Result<BakeReport> r = bake_scene(s, o);
    ASSERT_TRUE(r.ok()) << r.error().message;
    ASSERT_EQ(r->maps.size(), 1u);
    const double expected = kPi / (1.0 - rho);
    const double mean = mean_valid(r->maps[0]);
    std::printf("furnace rho 0.9, defaults: mean E %.3f, closed form %.3f (%+.2f %%)\n", mean,
                expected, 100.0 * (mean / expected - 1.0));
    EXPECT_NEAR(mean, expected, 0.02 * expected);
    EXPECT_FALSE(mentions_bounces(r->warnings));

    Scene t = furnace_scene(rho);
    o.bounces = 3;
    r = bake_scene(t, o);
    ASSERT_TRUE(r.ok()) << r.error().message;
    const double truncated = kPi * (1.0 - std::pow(rho, 4.0)) / (1.0 - rho);
    EXPECT_NEAR(mean_valid(r->maps[0]), truncated, 0.02 * truncated);
    ASSERT_TRUE(mentions_bounces(r->warnings));
    bool named = false;
    for (const std::string& w : r->warnings)
        named |= w.find("65.6 %") != std::string::npos && w.find("rho = 0.90") != std::string::npos;
    EXPECT_TRUE(named) << r->warnings.back();
}

// Firefly clamping's bias, bounded with the furnace's closed form E = pi Le / (1 - rho): the same
// bake (same seed, so the same paths) with and without the clamp at the demo scene's settings
// (32 paths per texel, factor 8; Russian roulette, whose long paths are the furnace's heavy tail,
// and the demo's 2 bounces). The clamp only lowers paths, so the paired difference of the means
// is the bias of this run with far less noise than either mean: <= 0.5 % of the closed form at
// every albedo (measured: 0.04-0.07 % with Russian roulette, 0 with 2 bounces; factor 4 gave
// 0.9-2.3 %). The unclamped mean is the closed form within its noise (1 %).
TEST(Bake, FireflyClampBiasIsUnderHalfAPercentInTheFurnace) {
    for (const int bounces : {-1, 2})
        for (const float rho : {0.5f, 0.7f, 0.9f}) {
            BakeOptions o;
            o.texels_per_metre = 24.0;
            o.samples = 32;
            o.bounces = bounces;
            o.denoise_iterations = 0;
            o.threads = 2;
            Scene s = furnace_scene(rho);
            Result<BakeReport> free = bake_scene(s, o);
            ASSERT_TRUE(free.ok()) << free.error().message;
            o.firefly_factor = 8.0f;
            Scene t = furnace_scene(rho);
            Result<BakeReport> clamped = bake_scene(t, o);
            ASSERT_TRUE(clamped.ok()) << clamped.error().message;
            const double expected =
                bounces < 0 ? kPi / (1.0 - rho)
                            : kPi * (1.0 - std::pow(double(rho), bounces + 1)) / (1.0 - rho);
            const double unbiased = mean_valid(free->maps[0], &free->maps[0].raw),
                         biased = mean_valid(clamped->maps[0], &clamped->maps[0].raw);
            const double bias = (unbiased - biased) / expected;
            std::printf(
                "furnace rho %.1f, bounces %d: closed form %.4f, unclamped %.4f (%+.2f %%), "
                "clamped %.4f: clamp bias %.3f %%\n",
                rho, bounces, expected, unbiased, 100.0 * (unbiased / expected - 1.0), biased,
                100.0 * bias);
            EXPECT_NEAR(unbiased, expected, 0.01 * expected);
            EXPECT_GE(bias, 0.0);
            EXPECT_LE(bias, 0.005) << "rho " << rho << ", bounces " << bounces;
        }
}

// The second filter pass: at 16 paths per texel the furnace's texels scatter by 16 % (Russian
// roulette); filtering the indirect part by the variance-guided A-trous cuts the scatter over the
// texels by more than 4x (measured 12x) and leaves the mean within 0.5 % (measured -0.37 %; the
// edge stop darkens skewed noise a little: -0.56 % at 8 paths, -0.08 % at 32).
TEST(Bake, IndirectFilterCutsTheFurnacesNoiseAndKeepsItsMean) {
    BakeOptions o;
    o.texels_per_metre = 16.0;
    o.samples = 16;
    o.threads = 2;
    Scene s = furnace_scene(0.7f);
    Result<BakeReport> r = bake_scene(s, o);
    ASSERT_TRUE(r.ok()) << r.error().message;
    const BakedMap& m = r->maps[0];
    auto spread = [&](const std::vector<glm::vec3>& e, double& mean) {
        double s1 = 0.0, s2 = 0.0, n = 0.0;
        for (size_t i = 0; i < e.size(); ++i)
            if (m.valid[i]) {
                s1 += e[i].g;
                s2 += double(e[i].g) * e[i].g;
                n += 1.0;
            }
        mean = s1 / n;
        return std::sqrt(std::max(0.0, s2 / n - mean * mean));
    };
    double raw_mean = 0.0, final_mean = 0.0;
    const double raw_sd = spread(m.raw, raw_mean), final_sd = spread(m.final_e, final_mean);
    std::printf(
        "furnace rho 0.7, 16 paths: texel spread %.3f raw, %.3f filtered (mean %.4f, "
        "%.4f)\n",
        raw_sd, final_sd, raw_mean, final_mean);
    EXPECT_GT(raw_sd, 4.0 * final_sd);
    EXPECT_NEAR(final_mean, raw_mean, 0.005 * raw_mean);
}

// The warning's threshold: rho^(n+1) > 2 %. At rho = 0.5, 5 bounces drop 1.6 % (quiet), 4 drop
// 3.1 % (warns).
TEST(Bake, BounceLimitWarnsOnlyAboveTwoPercent) {
    for (int bounces : {4, 5}) {
        Scene s = furnace_scene(0.5f);
        BakeOptions o;
        o.texels_per_metre = 4.0;
        o.samples = 4;
        o.bounces = bounces;
        Result<BakeReport> r = bake_scene(s, o);
        ASSERT_TRUE(r.ok()) << r.error().message;
        EXPECT_EQ(mentions_bounces(r->warnings), bounces == 4) << bounces;
    }
}

// The progress bar's time left: nothing until 3 % more work and half a second since the first
// report, then the measured rate extrapolated (here a steady 10 %/s after 2 s of loading).
TEST(Bake, ProgressClockGivesNoEstimateUntilItCanTell) {
    ProgressClock eta;
    EXPECT_LT(eta.seconds_left(2.0, 0.0001), 0.0);  // first report: the rate starts here
    EXPECT_LT(eta.seconds_left(2.01, 0.001), 0.0);  // 0.1 % done: no 315,345 s guess
    EXPECT_LT(eta.seconds_left(2.2, 0.0201), 0.0);  // 2 % done
    EXPECT_NEAR(eta.seconds_left(2.6, 0.0601), 0.9399 * 0.6 / 0.06, 1e-9);
    EXPECT_NEAR(eta.seconds_left(7.0, 0.5001), 0.4999 * 5.0 / 0.5,
                1e-9);  // loading time not counted
    EXPECT_EQ(eta.seconds_left(12.0, 1.0), 0.0);
}

// Lights that cannot be physical are errors naming the light; an emissive material that no
// traced mesh uses is a warning, and nothing to bake when it is the only light.
TEST(Bake, NegativeLightsAreErrorsAndUnusedEmissionAWarning) {
    for (int bad = 0; bad < 3; ++bad) {
        Builder b(glm::vec3(0.5f), glm::vec3(0.5f), 8);
        b.quad(0, {-1, 0, -1}, {0, 0, 2}, {2, 0, 0}, true);
        Light l;
        l.name = "lamp";
        if (bad == 0) l.intensity = -5.0f;
        if (bad == 1) l.color.g = std::numeric_limits<float>::quiet_NaN();
        if (bad == 2) l.range = -1.0f;
        b.s.lights.push_back(l);
        Result<BakeReport> r = bake_scene(b.s, BakeOptions{});
        ASSERT_FALSE(r.ok()) << bad;
        EXPECT_NE(r.error().message.find("light 0 'lamp'"), std::string::npos) << r.error().message;
    }
    Builder b(glm::vec3(0.5f), glm::vec3(0.5f), 8);
    b.quad(0, {-1, 0, -1}, {0, 0, 2}, {2, 0, 0}, true);
    Material glow;
    glow.name = "glow";
    glow.emissive_factor = glm::vec3(4.0f);
    b.s.materials.push_back(glow);  // no primitive uses it
    Result<BakeReport> r = bake_scene(b.s, BakeOptions{});
    ASSERT_FALSE(r.ok());
    EXPECT_NE(r.error().message.find("nothing to bake"), std::string::npos) << r.error().message;
    EXPECT_NE(r.error().message.find("'glow' is emissive but no mesh"), std::string::npos)
        << r.error().message;
    BakeOptions o;
    o.samples = 2;
    o.sky_radiance = glm::vec3(1.0f);
    r = bake_scene(b.s, o);
    ASSERT_TRUE(r.ok()) << r.error().message;
    ASSERT_FALSE(r->warnings.empty());
    EXPECT_NE(r->warnings[0].find("material 2 'glow' is emissive but no mesh"), std::string::npos)
        << r->warnings[0];
}

// A double-sided divider (x = 0, front facing +x) lit by a point light on its back side (x = -1):
// it used to be baked for its front side only, black on the lit side. Now it is two sheets under
// a single-sided material, the back sheet (normal -x) lit as the closed form says and the front
// one dark; as lightmap texels (atlas) and as vertex light.
Scene divider_scene() {
    Scene s;
    Material m;
    m.name = "divider";
    m.double_sided = true;
    s.materials.push_back(m);
    Mesh mesh;
    mesh.name = "divider";
    Primitive& p = mesh.primitives.emplace_back();
    p.material = 0;
    p.positions = {{0, -0.5f, -0.5f}, {0, 0.5f, -0.5f}, {0, 0.5f, 0.5f}, {0, -0.5f, 0.5f}};
    p.normals.assign(4, glm::vec3(1, 0, 0));  // (y, z) winding: front = +x
    p.indices = {0, 1, 2, 0, 2, 3};
    s.meshes.push_back(mesh);
    Node n;
    n.name = "divider";
    n.mesh = 0;
    Node lamp;
    lamp.name = "lamp";
    lamp.translation = {-1, 0, 0};
    s.nodes = {n, lamp};
    s.roots = {0, 1};
    Light l;
    l.name = "bulb";
    l.intensity = 10.0f;
    l.node = 1;
    s.lights.push_back(l);
    return s;
}

TEST(Bake, DoubleSidedSurfacesGetLightOnEachSide) {
    const float pi_free_e = 10.0f;  // E at the divider's centre: I / r^2, r = 1
    for (bool vertex : {false, true}) {
        Scene s = divider_scene();
        BakeOptions o;
        o.samples = 4;
        o.vertex = vertex;
        o.texels_per_metre = vertex ? 0.0 : 16.0;
        Result<BakeReport> r = bake_scene(s, o);
        ASSERT_TRUE(r.ok()) << r.error().message;
        EXPECT_EQ(r->two_sided_primitives, 1u);
        const Primitive& p = s.meshes[0].primitives[0];
        ASSERT_EQ(p.triangle_count(), 4u);  // front and back sheets
        EXPECT_FALSE(s.materials[size_t(p.material)].double_sided);
        // The back sheet's triangles face -x (reversed winding).
        const glm::vec3 a = p.positions[p.indices[6]], b = p.positions[p.indices[7]],
                        c = p.positions[p.indices[8]];
        EXPECT_LT(glm::cross(b - a, c - a).x, 0.0f);
        // E at a sheet's point: from the light on its side only (x = -1), I cos / r^2.
        auto expected = [&](glm::vec3 q, bool back) {
            if (!back) return 0.0f;
            const glm::vec3 d = glm::vec3(-1, 0, 0) - q;  // to the light; cos = 1 / r
            const float r2 = glm::dot(d, d);
            return pi_free_e / (r2 * std::sqrt(r2));
        };
        if (vertex) {
            ASSERT_EQ(p.light.size(), 8u);
            // Least squares over two triangles does not interpolate the peaked I cos / r^2: the
            // back sheet's vertices are lit (at least the corners' point value), the front's
            // exactly dark.
            for (size_t v = 0; v < 8; ++v) {
                if (v < 4)
                    EXPECT_EQ(p.light[v].r, 0.0f) << "front vertex " << v;
                else
                    EXPECT_GT(p.light[v].r, expected(p.positions[v], true)) << "back vertex " << v;
            }
        } else {
            ASSERT_EQ(r->maps.size(), 1u);
            const BakedMap& m = r->maps[0];
            // Sample each sheet's texel under the centroid of its first triangle.
            for (int sheet = 0; sheet < 2; ++sheet) {
                const uint32_t* t = &p.indices[size_t(sheet) * 6];
                const glm::vec2 uv = (p.uv1[t[0]] + p.uv1[t[1]] + p.uv1[t[2]]) / 3.0f;
                const glm::vec3 q =
                    (p.positions[t[0]] + p.positions[t[1]] + p.positions[t[2]]) / 3.0f;
                const int x = int(uv.x * m.width), y = int(uv.y * m.height);
                const float e = m.final_e[size_t(y) * m.width + x].r;
                EXPECT_NEAR(e, expected(q, sheet == 1), 0.05f * pi_free_e) << "sheet " << sheet;
            }
        }
    }
    // Off: one sheet, still double-sided (the old behaviour).
    Scene s = divider_scene();
    BakeOptions o;
    o.samples = 2;
    o.vertex = true;
    o.two_sided = false;
    Result<BakeReport> r = bake_scene(s, o);
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_EQ(s.meshes[0].primitives[0].triangle_count(), 2u);
    EXPECT_TRUE(s.materials[0].double_sided);
}

}  // namespace
}  // namespace hmdnode
