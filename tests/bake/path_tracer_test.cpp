// The Embree path tracer against closed-form answers: the furnace (closed box, albedo rho,
// emission Le: radiance Le / (1 - rho) everywhere), a plane under a uniform sky (E = pi Ls), a
// point light (E = I cos / r^2), KHR_lights_punctual's range window and spot cone, lights placed
// by their nodes, and the Monte Carlo error falling as 1 / sqrt(N).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include "hmdnode/bake/bake.hpp"
#include "hmdnode/bake/cornell_box.hpp"
#include "hmdnode/bake/path_tracer.hpp"

namespace hmdnode {
namespace {

constexpr float kPi = std::numbers::pi_v<float>;

// Adds the quad o, o+u, o+u+v, o+v (front side = u x v) to primitive 0 of mesh 0.
void add_quad(Scene& s, glm::vec3 o, glm::vec3 u, glm::vec3 v) {
    Primitive& p = s.meshes[0].primitives[0];
    const uint32_t b = uint32_t(p.positions.size());
    p.positions.insert(p.positions.end(), {o, o + u, o + u + v, o + v});
    const glm::vec3 n = glm::normalize(glm::cross(u, v));
    p.normals.insert(p.normals.end(), 4, n);
    p.indices.insert(p.indices.end(), {b, b + 1, b + 2, b, b + 2, b + 3});
}

Scene one_mesh_scene(const Material& m) {
    Scene s;
    s.materials.push_back(m);
    Mesh mesh;
    mesh.name = "test";
    mesh.primitives.emplace_back();
    mesh.primitives[0].material = 0;
    s.meshes.push_back(mesh);
    Node n;
    n.mesh = 0;
    s.nodes.push_back(n);
    s.roots.push_back(0);
    return s;
}

// Inward-facing unit-size cube [-h, h]^3.
void add_inward_box(Scene& s, float h) {
    const float e = 2 * h;
    add_quad(s, {-h, -h, -h}, {0, 0, e}, {e, 0, 0});  // floor, normal +y
    add_quad(s, {-h, h, -h}, {e, 0, 0}, {0, 0, e});   // ceiling, normal -y
    add_quad(s, {-h, -h, -h}, {0, e, 0}, {0, 0, e});  // x = -h, normal +x
    add_quad(s, {h, -h, -h}, {0, 0, e}, {0, e, 0});   // x = +h, normal -x
    add_quad(s, {-h, -h, -h}, {e, 0, 0}, {0, e, 0});  // z = -h, normal +z
    add_quad(s, {-h, -h, h}, {0, e, 0}, {e, 0, 0});   // z = +h, normal -z
}

Scene furnace(float rho, float le) {
    Material m;
    m.name = "furnace";
    m.base_color_factor = glm::vec4(rho, rho, rho, 1.0f);
    m.emissive_factor = glm::vec3(le);
    Scene s = one_mesh_scene(m);
    add_inward_box(s, 0.5f);
    return s;
}

// The furnace's irradiance at three wall points (a floor centre, a floor corner, a wall), each the
// mean of n paths, within 2 % of `expected`.
void expect_furnace_irradiance(const PathTracer& t, Pcg32 rng, int n, double expected) {
    const glm::vec3 pts[] = {{0, -0.5f, 0}, {0.49f, -0.5f, 0.49f}, {0.5f, 0.2f, -0.3f}};
    const glm::vec3 ns[] = {{0, 1, 0}, {0, 1, 0}, {-1, 0, 0}};
    for (int k = 0; k < 3; ++k) {
        double sum = 0.0;
        for (int i = 0; i < n; ++i) sum += t.irradiance(pts[k], ns[k], rng).r;
        EXPECT_NEAR(sum / n, expected, 0.02 * expected) << "point " << k;
    }
}

TEST(PathTracer, InwardBoxNormalsPointInside) {
    Scene s = furnace(0.5f, 1.0f);
    const Primitive& p = s.meshes[0].primitives[0];
    for (size_t i = 0; i < p.positions.size(); ++i)
        EXPECT_LT(glm::dot(p.normals[i], p.positions[i]), 0.0f) << i;
}

TEST(PathTracer, FurnaceRadianceIsLeOverOneMinusRho) {
    const float rho = 0.5f, le = 1.0f;
    Scene s = furnace(rho, le);
    PathTracerOptions o;
    o.bounces = 200;  // truncation rho^200: nothing; Russian roulette keeps it unbiased
    Result<PathTracer> t = PathTracer::build(s, o);
    ASSERT_TRUE(t.ok()) << t.error().message;
    EXPECT_EQ(t->triangle_count(), 12u);
    EXPECT_EQ(t->emissive_triangle_count(), 12u);
    const double expected = le / (1.0 - rho);
    // Camera rays from several points in several directions.
    const glm::vec3 origins[] = {{0, 0, 0}, {0.3f, -0.2f, 0.1f}, {-0.45f, 0.45f, 0.4f}};
    for (int oi = 0; oi < 3; ++oi) {
        Pcg32 rng(7, oi);
        double sum = 0.0;
        const int n = 4000;
        for (int i = 0; i < n; ++i) {
            float z = 1 - 2 * rng.uniform(), phi = 2 * kPi * rng.uniform();
            float r = std::sqrt(1 - z * z);
            glm::vec3 d(r * std::cos(phi), r * std::sin(phi), z);
            sum += t->radiance(origins[oi], d, rng).g;
        }
        EXPECT_NEAR(sum / n, expected, 0.02 * expected) << "origin " << oi;
    }
    // Irradiance at wall points: E = pi L.
    expect_furnace_irradiance(*t, Pcg32(9, 1), 4000, kPi * expected);
}

// The default options set no bounce limit: Russian roulette alone ends the paths, and the
// furnace of albedo 0.9 (where 3 bounces would give only 1 - 0.9^4 = 34 % of the light) converges
// to Le / (1 - rho).
TEST(PathTracer, FurnaceOfAlbedo09ConvergesWithTheDefaultOptions) {
    const float rho = 0.9f, le = 1.0f;
    Scene s = furnace(rho, le);
    Result<PathTracer> t = PathTracer::build(s, PathTracerOptions{});
    ASSERT_TRUE(t.ok()) << t.error().message;
    EXPECT_LT(t->options().bounces, 0);
    EXPECT_NEAR(t->mean_albedo(), rho, 1e-6);
    expect_furnace_irradiance(*t, Pcg32(11, 3), 20000, kPi * le / (1.0 - rho));
}

TEST(PathTracer, PlaneUnderUniformSkyGetsPiLs) {
    Material m;
    m.base_color_factor = glm::vec4(0.7f, 0.7f, 0.7f, 1.0f);
    Scene s = one_mesh_scene(m);
    add_quad(s, {-1, 0, -1}, {0, 0, 2}, {2, 0, 0});  // normal +y
    PathTracerOptions o;
    o.sky_radiance = glm::vec3(0.5f, 1.0f, 2.0f);
    o.bounces = 4;
    Result<PathTracer> t = PathTracer::build(s, o);
    ASSERT_TRUE(t.ok()) << t.error().message;
    Pcg32 rng(1, 2);
    glm::dvec3 sum(0.0);
    const int n = 256;
    for (int i = 0; i < n; ++i) sum += glm::dvec3(t->irradiance({0.3f, 0, -0.2f}, {0, 1, 0}, rng));
    const glm::dvec3 e = sum / double(n);
    for (int c = 0; c < 3; ++c)
        EXPECT_NEAR(e[c], kPi * o.sky_radiance[c], 0.02 * kPi * o.sky_radiance[c]);
}

TEST(PathTracer, PointLightOverPlaneAndItsShadow) {
    Material m;
    m.base_color_factor = glm::vec4(0.0f, 0.0f, 0.0f, 1.0f);  // black: no indirect light
    Scene s = one_mesh_scene(m);
    add_quad(s, {-2, 0, -2}, {0, 0, 4}, {4, 0, 0});                 // floor
    add_quad(s, {-0.2f, 0.5f, -0.2f}, {0, 0, 0.4f}, {0.4f, 0, 0});  // occluder at y = 0.5
    Node ln;
    ln.translation = glm::dvec3(0.0, 1.0, 0.0);
    s.nodes.push_back(ln);
    Light l;
    l.intensity = 10.0f;
    l.node = 1;
    s.lights.push_back(l);
    Result<PathTracer> t = PathTracer::build(s, PathTracerOptions{});
    ASSERT_TRUE(t.ok()) << t.error().message;
    Pcg32 rng(3, 3);
    for (float x : {0.5f, 0.8f, 1.5f}) {
        const glm::vec3 p(x, 0, 0.1f);
        const glm::vec3 d = glm::vec3(0, 1, 0) - p;
        const float r = glm::length(d);
        const float expected = 10.0f * (d.y / r) / (r * r);
        EXPECT_NEAR(t->irradiance(p, {0, 1, 0}, rng).r, expected, 0.02f * expected) << x;
    }
    // Umbra: the occluder's shadow spans [-0.4, 0.4]^2 on the floor.
    for (float x : {0.0f, 0.3f, -0.35f})
        EXPECT_EQ(t->irradiance({x, 0, 0.1f}, {0, 1, 0}, rng).r, 0.0f);
}

// Punctual lights are placed by their node's world transform (through the parent chain) and
// follow KHR_lights_punctual: range window max(0, 1 - (r / range)^4), spot cone
// clamp((cos - cos_outer) / (cos_inner - cos_outer), 0, 1)^2, directional lights I * colour * cos.
TEST(PathTracer, PunctualLightsPlacedByTheirNodesWithRangeAndCone) {
    Material m;
    m.base_color_factor = glm::vec4(0.0f, 0.0f, 0.0f, 1.0f);  // black: direct light only
    Scene s = one_mesh_scene(m);
    add_quad(s, {-4, 0, -4}, {0, 0, 8}, {8, 0, 0});  // floor, normal +y
    // A point light 2 m above (0.3, -0.2) through a parent "mount" node and its child.
    const glm::vec3 lamp(0.3f, 2.0f, -0.2f);
    Node mount, child;
    mount.translation = glm::dvec3(lamp.x, 0.0, lamp.z);
    mount.children.push_back(2);
    child.translation = glm::dvec3(0.0, lamp.y, 0.0);
    s.nodes.push_back(mount);
    s.nodes.push_back(child);
    s.roots.push_back(1);
    Light l;
    l.intensity = 10.0f;
    l.range = 4.0f;
    l.node = 2;
    s.lights.push_back(l);
    Result<PathTracer> t = PathTracer::build(s, PathTracerOptions{});
    ASSERT_TRUE(t.ok()) << t.error().message;
    Pcg32 rng(7, 7);
    for (float x : {0.3f, 1.0f, 2.5f, 3.9f}) {
        const glm::vec3 p(x, 0, 0.1f);
        const glm::vec3 d = lamp - p;
        const float r = glm::length(d), q = r / l.range;
        const float expected = 10.0f * (d.y / r) / (r * r) * std::max(0.0f, 1.0f - q * q * q * q);
        EXPECT_NEAR(t->direct_irradiance(p, {0, 1, 0}, rng).r, expected, 1e-4f * expected + 1e-7f)
            << x;
    }

    // The same light as a spot pointing straight down (a quarter turn about +X turns -Z to -Y):
    // full inside the inner cone, nothing outside the outer one, the squared ramp between.
    s.nodes[2].rotation = glm::angleAxis(glm::radians(-90.0), glm::dvec3(1, 0, 0));
    s.lights[0].type = Light::Type::Spot;
    s.lights[0].range = 0.0f;
    s.lights[0].inner_cone_rad = 0.2f;
    s.lights[0].outer_cone_rad = 0.6f;
    t = PathTracer::build(s, PathTracerOptions{});
    ASSERT_TRUE(t.ok()) << t.error().message;
    for (float x : {0.3f, 0.5f, 0.9f, 1.2f, 2.0f}) {
        const glm::vec3 p(x, 0, lamp.z);
        const glm::vec3 d = lamp - p;
        const float r = glm::length(d), cos_axis = d.y / r;
        const float ramp =
            std::clamp((cos_axis - std::cos(0.6f)) / (std::cos(0.2f) - std::cos(0.6f)), 0.0f, 1.0f);
        const float expected = 10.0f * cos_axis / (r * r) * ramp * ramp;
        EXPECT_NEAR(t->direct_irradiance(p, {0, 1, 0}, rng).r, expected, 1e-4f * expected + 1e-7f)
            << x;
    }

    // A coloured directional light, pointed down by its node's rotation.
    s.lights[0] = Light{};
    s.lights[0].type = Light::Type::Directional;
    s.lights[0].intensity = 2.0f;
    s.lights[0].color = glm::vec3(1.0f, 0.5f, 0.25f);
    s.lights[0].node = 2;
    t = PathTracer::build(s, PathTracerOptions{});
    ASSERT_TRUE(t.ok()) << t.error().message;
    const glm::vec3 e = t->direct_irradiance({-1.0f, 0.0f, 1.5f}, {0, 1, 0}, rng);
    EXPECT_NEAR(e.r, 2.0f, 1e-5f);
    EXPECT_NEAR(e.g, 1.0f, 1e-5f);
    EXPECT_NEAR(e.b, 0.5f, 1e-5f);
}

TEST(PathTracer, ErrorFallsAsInverseSqrtOfSamples) {
    const float rho = 0.5f, le = 1.0f;
    Scene s = furnace(rho, le);
    PathTracerOptions o;
    o.bounces = 200;
    Result<PathTracer> t = PathTracer::build(s, o);
    ASSERT_TRUE(t.ok());
    const double truth = kPi * le / (1.0 - rho);
    const int counts[] = {4, 16, 64, 256};
    const int runs = 48;
    std::vector<double> lx, ly;
    for (int ci = 0; ci < 4; ++ci) {
        double se = 0.0;
        for (int run = 0; run < runs; ++run) {
            Pcg32 rng(11, uint64_t(ci) * 1000 + run);
            double sum = 0.0;
            for (int i = 0; i < counts[ci]; ++i)
                sum += t->irradiance({0.45f, -0.5f, 0.45f}, {0, 1, 0}, rng).r;
            const double err = sum / counts[ci] - truth;
            se += err * err;
        }
        lx.push_back(std::log(double(counts[ci])));
        ly.push_back(std::log(std::sqrt(se / runs)));
    }
    double mx = 0, my = 0;
    for (int i = 0; i < 4; ++i) {
        mx += lx[i] / 4;
        my += ly[i] / 4;
    }
    double sxy = 0, sxx = 0;
    for (int i = 0; i < 4; ++i) {
        sxy += (lx[i] - mx) * (ly[i] - my);
        sxx += (lx[i] - mx) * (lx[i] - mx);
    }
    const double slope = sxy / sxx;
    EXPECT_NEAR(slope, -0.5, 0.15)
        << "RMS errors " << std::exp(ly[0]) << " ... " << std::exp(ly[3]);
}

TEST(PathTracer, NonFinitePositionIsAnErrorNamingTheMesh) {
    Material m;
    Scene s = one_mesh_scene(m);
    add_quad(s, {0, 0, 0}, {1, 0, 0}, {0, 0, 1});
    s.meshes[0].primitives[0].positions[2].x = NAN;
    Result<PathTracer> t = PathTracer::build(s, PathTracerOptions{});
    ASSERT_FALSE(t.ok());
    EXPECT_NE(t.error().message.find("'test'"), std::string::npos) << t.error().message;
    EXPECT_NE(t.error().message.find("vertex 2"), std::string::npos) << t.error().message;
}

TEST(PathTracer, SameSeedSameResult) {
    Scene s = furnace(0.5f, 1.0f);
    Result<PathTracer> t = PathTracer::build(s, PathTracerOptions{});
    ASSERT_TRUE(t.ok());
    Pcg32 a(5, 17), b(5, 17);
    for (int i = 0; i < 100; ++i)
        EXPECT_EQ(t->irradiance({0, -0.5f, 0}, {0, 1, 0}, a),
                  t->irradiance({0, -0.5f, 0}, {0, 1, 0}, b));
}

// irradiance_split is the same estimate as irradiance (same random numbers) cut in two: the
// direct part is the furnace's first term pi Le, the indirect part its other terms,
// pi Le rho / (1 - rho) on average.
TEST(PathTracer, SplitIrradianceIsTheSameEstimateInTwoParts) {
    const float rho = 0.5f;
    Scene s = furnace(rho, 1.0f);
    Result<PathTracer> t = PathTracer::build(s, PathTracerOptions{});
    ASSERT_TRUE(t.ok());
    Pcg32 a(5, 17), b(5, 17);
    double direct = 0.0, indirect = 0.0;
    const int n = 20000;
    for (int i = 0; i < n; ++i) {
        glm::vec3 ind(0.0f);
        const glm::vec3 d = t->irradiance_split({0, -0.5f, 0}, {0, 1, 0}, a, ind);
        const glm::vec3 whole = t->irradiance({0, -0.5f, 0}, {0, 1, 0}, b);
        ASSERT_NEAR(d.g + ind.g, whole.g, 1e-4f * (1.0f + whole.g)) << i;
        direct += d.g;
        indirect += ind.g;
    }
    EXPECT_NEAR(direct / n, kPi, 0.02 * kPi);
    EXPECT_NEAR(indirect / n, kPi * rho / (1 - rho), 0.03 * kPi * rho / (1 - rho));
}

// The throughput bench's reference: rays recorded during a bake (every kind the baker casts) and
// replayed through raw Embree give the same answers as single rays, packets of 8 and streams.
TEST(PathTracer, RecordedRaysReplayAlikeAsSinglePacketAndStream) {
    Scene s = cornell_box_scene(16.0);
    Result<PathTracer> t = PathTracer::build(s, PathTracerOptions{});
    ASSERT_TRUE(t.ok());
    BakeOptions o;
    o.samples = 4;
    o.threads = 2;
    start_ray_recording(1);
    Result<BakeReport> r = bake_scene(s, o);
    const std::vector<RecordedRay> rays = stop_ray_recording();
    ASSERT_TRUE(r.ok()) << r.error().message;
    size_t mix[4] = {0, 0, 0, 0};
    for (const RecordedRay& x : rays) ++mix[int(x.kind)];
    EXPECT_GT(mix[int(RayKind::Bounce)], 0u);
    EXPECT_GT(mix[int(RayKind::Shadow)], 0u);
    EXPECT_GT(mix[int(RayKind::Short)], 0u);
    // Every ray the bake counted was recorded (coplanar re-queries are not in its count).
    EXPECT_EQ(rays.size() - mix[int(RayKind::Coplanar)], r->rays);
    const ReplayTiming single = t->replay_rays(rays, 2, ReplayMode::Single);
    const ReplayTiming packet = t->replay_rays(rays, 1, ReplayMode::Packet8);
    const ReplayTiming stream = t->replay_rays(rays, 2, ReplayMode::Stream);
    EXPECT_EQ(single.rays, rays.size());
    EXPECT_GT(single.hits, 0u);
    EXPECT_EQ(packet.hits, single.hits);
    EXPECT_EQ(stream.hits, single.hits);
    start_ray_recording(4);  // every 4th of each thread
    Scene s2 = cornell_box_scene(16.0);
    o.threads = 1;
    ASSERT_TRUE(bake_scene(s2, o).ok());
    const size_t quarter = stop_ray_recording().size();
    EXPECT_NEAR(double(quarter), double(rays.size()) / 4.0, 0.01 * double(rays.size()));
}

// The baker traces a texel's paths as one batch, their shadow rays as one Embree stream, and a
// texel's validity rays as another: the same floats, ray counts and hits as one path (one ray) at
// a time, on the Cornell box (emitter samples blocked by the boxes) with a point light added.
TEST(PathTracer, BatchedPathsAndRaysMatchOneAtATimeExactly) {
    Scene s = cornell_box_scene(16.0);
    Node lamp;
    lamp.translation = glm::dvec3(0.1, 0.4, 0.05);
    s.nodes.push_back(lamp);
    s.roots.push_back(int(s.nodes.size() - 1));
    Light l;
    l.intensity = 2.0f;
    l.node = int(s.nodes.size() - 1);
    s.lights.push_back(l);
    Result<PathTracer> t = PathTracer::build(s, PathTracerOptions{});
    ASSERT_TRUE(t.ok()) << t.error().message;
    ASSERT_EQ(t->punctual_light_count(), 1u);
    const glm::vec3 lo = t->bounds_min(), ext = t->bounds_max() - t->bounds_min();
    Pcg32 where(3, 9);
    std::vector<glm::vec3> p, n;
    for (int i = 0; i < 48; ++i) {
        p.push_back(lo + ext * glm::vec3(where.uniform(), 0.0f, where.uniform()));  // the floor
        p.back().y += 1e-3f * ext.y;
        n.push_back(i % 3 == 0 ? glm::vec3(0, 1, 0) : glm::normalize(glm::vec3(0.2f, 1, -0.1f)));
    }
    Pcg32 a(11, 4), b(11, 4);
    std::vector<glm::vec3> direct(p.size()), indirect(p.size());
    uint64_t rays_batch = 0, rays_one = 0;
    t->irradiance_batch(p.size(), p.data(), n.data(), a, direct.data(), indirect.data(),
                        &rays_batch);
    for (size_t i = 0; i < p.size(); ++i) {
        glm::vec3 ind(0.0f);
        const glm::vec3 d = t->irradiance_split(p[i], n[i], b, ind, &rays_one);
        EXPECT_EQ(d, direct[i]) << i;
        EXPECT_EQ(ind, indirect[i]) << i;
    }
    EXPECT_EQ(rays_batch, rays_one);
    EXPECT_EQ(a.uniform(), b.uniform());  // the same random numbers used
    std::vector<glm::vec3> total(p.size());
    Pcg32 c(11, 4), e(11, 4);
    t->irradiance_batch(p.size(), p.data(), n.data(), c, total.data());
    for (size_t i = 0; i < p.size(); ++i) EXPECT_EQ(t->irradiance(p[i], n[i], e), total[i]) << i;

    std::vector<TraceQuery> q;
    for (int i = 0; i < 256; ++i) {
        const glm::vec3 o = lo + ext * glm::vec3(where.uniform(), where.uniform(), where.uniform());
        const float z = 1.0f - 2.0f * where.uniform(), phi = 2.0f * kPi * where.uniform();
        const float r = std::sqrt(std::max(0.0f, 1.0f - z * z));
        q.push_back(TraceQuery{o,
                               {r * std::cos(phi), r * std::sin(phi), z},
                               0.0f,
                               i % 2 ? 0.1f * ext.x : std::numeric_limits<float>::infinity()});
    }
    std::vector<std::optional<TraceHit>> hits(q.size());
    t->intersect_batch(q.size(), q.data(), hits.data());
    size_t found = 0, back = 0;
    for (size_t i = 0; i < q.size(); ++i) {
        const std::optional<TraceHit> one =
            t->intersect(q[i].origin, q[i].dir, q[i].t_near, q[i].t_far);
        ASSERT_EQ(one.has_value(), hits[i].has_value()) << i;
        if (!one) continue;
        ++found;
        back += one->front ? 0 : 1;
        EXPECT_EQ(one->triangle, hits[i]->triangle) << i;
        EXPECT_EQ(one->t, hits[i]->t) << i;
        EXPECT_EQ(one->front, hits[i]->front) << i;
    }
    EXPECT_GT(found, 64u);
    EXPECT_GT(back, 0u);  // points inside the boxes: back faces, with their re-query
}

}  // namespace
}  // namespace hmdnode
