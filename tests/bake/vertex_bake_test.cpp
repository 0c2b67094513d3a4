#include "hmdnode/bake/vertex_bake.hpp"

#include <cmath>
#include <cstdio>
#include <map>
#include <numbers>
#include <random>

#include <gtest/gtest.h>
#include <glm/gtc/matrix_transform.hpp>

namespace hmdnode {
namespace {

// An n x n jittered grid over [-s/2, s/2]^2 in the plane y = 0, facing +y, with normals and a uv0
// that is a linear function of the position.
Primitive plane(int n, float s, float jitter, unsigned seed = 5) {
    Primitive p;
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(-jitter, jitter);
    for (int j = 0; j <= n; ++j)
        for (int i = 0; i <= n; ++i) {
            glm::vec3 v(s * (float(i) / n - 0.5f), 0.0f, s * (float(j) / n - 0.5f));
            if (i > 0 && i < n && j > 0 && j < n)
                v += glm::vec3(u(rng), 0.0f, u(rng)) * s / float(n);
            p.positions.push_back(v);
            p.normals.push_back({0.0f, 1.0f, 0.0f});
            p.uv0.push_back({v.x * 0.25f + 0.5f, v.z * 0.5f});
        }
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            uint32_t a = uint32_t(j * (n + 1) + i), b = a + 1, c = a + uint32_t(n + 1), d = c + 1;
            for (uint32_t v : {a, c, d, a, d, b}) p.indices.push_back(v);
        }
    return p;
}

glm::vec3 linear_field(const glm::vec3& p, const glm::vec3&) {
    return {2.0f + 0.5f * p.x - 0.25f * p.z, 1.0f + 0.1f * p.x + 0.3f * p.y, 3.0f - 0.7f * p.z};
}

TEST(VertexBake, LeastSquaresReproducesALinearFieldAngleWeightingDoesNot) {
    const Primitive p = plane(6, 4.0f, 0.3f);
    // Place it in the world: scaled, rotated, moved; the field is defined in world space.
    glm::dmat4 world = glm::translate(glm::dmat4(1.0), glm::dvec3(1, 2, 3)) *
                       glm::rotate(glm::dmat4(1.0), 0.4, glm::dvec3(0, 1, 0)) *
                       glm::scale(glm::dmat4(1.0), glm::dvec3(1.5));
    auto ls = vertex_irradiance_least_squares(p, world, linear_field, 4);
    auto aw = vertex_irradiance_angle_weighted(p, world, linear_field, 4);
    ASSERT_TRUE(ls.ok()) << ls.error().message;
    ASSERT_TRUE(aw.ok()) << aw.error().message;
    double ls_max = 0.0, aw_max = 0.0;
    for (size_t v = 0; v < p.positions.size(); ++v) {
        const glm::vec3 wp = glm::vec3(world * glm::dvec4(glm::dvec3(p.positions[v]), 1.0));
        const glm::vec3 truth = linear_field(wp, {});
        for (int c = 0; c < 3; ++c) {
            EXPECT_NEAR((*ls)[v][c], truth[c], 1e-4) << "vertex " << v;
            ls_max = std::max(ls_max, double(std::abs((*ls)[v][c] - truth[c])));
            aw_max = std::max(aw_max, double(std::abs((*aw)[v][c] - truth[c])));
        }
    }
    // Angle weighting averages face means (the field at face centroids): biased at the border,
    // where the centroids all lie inside, by about |grad f| x (edge / 3).
    EXPECT_GT(aw_max, 0.05) << "angle weighting unexpectedly exact";
    std::printf("linear field: max vertex error least squares %.2e, angle weighted %.3f\n", ls_max,
                aw_max);
}

TEST(VertexBake, PointLightLeastSquaresHasLowerL2ErrorThanAngleWeighting) {
    // E = I cos(theta) / r^2 from a point light of I = 10 cd, 1 m above a 4 m plane.
    const glm::vec3 light(0.3f, 1.0f, -0.2f);
    const float I = 10.0f;
    IrradianceOracle point = [&](const glm::vec3& x, const glm::vec3& n) {
        const glm::vec3 d = light - x;
        const float r2 = glm::dot(d, d);
        return glm::vec3(I * std::max(0.0f, glm::dot(n, d / std::sqrt(r2))) / r2);
    };
    for (int n : {4, 8, 16}) {
        const Primitive p = plane(n, 4.0f, 0.2f);
        const glm::dmat4 world(1.0);
        auto ls = vertex_irradiance_least_squares(p, world, point, 4);
        auto aw = vertex_irradiance_angle_weighted(p, world, point, 4);
        ASSERT_TRUE(ls.ok() && aw.ok());
        // Error measured with a finer rule than the one the fit used.
        const double e_ls = vertex_l2_error(p, world, point, *ls, 16);
        const double e_aw = vertex_l2_error(p, world, point, *aw, 16);
        std::vector<glm::vec3> at_vertices;
        for (auto& v : p.positions) at_vertices.push_back(point(v, {0, 1, 0}));
        const double e_pt = vertex_l2_error(p, world, point, at_vertices, 16);
        std::printf(
            "point light, %2d x %2d grid: RMS error of E (lux) least squares %.4f, angle "
            "weighted %.4f, point samples at vertices %.4f\n",
            n, n, e_ls, e_aw, e_pt);
        EXPECT_LT(e_ls, e_aw);
        EXPECT_LT(e_ls, e_pt);
    }
}

TEST(VertexBake, BakeStoresEInLightAndClampsNegatives) {
    Primitive p = plane(2, 1.0f, 0.0f);
    VertexBakeOptions o;
    o.method = VertexBakeMethod::AngleWeighted;
    auto r = bake_vertex_irradiance(
        p, glm::dmat4(1.0),
        [](const glm::vec3&, const glm::vec3&) {
            return glm::vec3(std::numbers::pi_v<float>, 2.0f * std::numbers::pi_v<float>, -1.0f);
        },
        o);
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_EQ(r->vertices, 9u);
    ASSERT_EQ(p.light.size(), 9u);
    EXPECT_TRUE(p.colors.empty());  // a real vertex colour would be left alone
    for (const auto& c : p.light) {
        EXPECT_NEAR(c.r, std::numbers::pi_v<float>, 1e-5f);
        EXPECT_NEAR(c.g, 2.0f * std::numbers::pi_v<float>, 1e-5f);
        EXPECT_EQ(c.b, 0.0f);
    }
}

TEST(VertexBake, NormalsComeFromTheWorldTransform) {
    Primitive p = plane(1, 1.0f, 0.0f);
    // Rotate the plane to face +x; the oracle returns the normal's x.
    const glm::dmat4 world =
        glm::rotate(glm::dmat4(1.0), -std::numbers::pi / 2, glm::dvec3(0, 0, 1));
    auto e = vertex_irradiance_least_squares(
        p, world, [](const glm::vec3&, const glm::vec3& n) { return glm::vec3(n.x); }, 2);
    ASSERT_TRUE(e.ok());
    for (auto& v : *e) EXPECT_NEAR(v.x, 1.0f, 1e-5f);
    // Without normals the face normal is used (winding a, c, d faces +y before rotation).
    p.normals.clear();
    e = vertex_irradiance_angle_weighted(
        p, world, [](const glm::vec3&, const glm::vec3& n) { return glm::vec3(n.x); }, 2);
    ASSERT_TRUE(e.ok());
    for (auto& v : *e) EXPECT_NEAR(v.x, 1.0f, 1e-5f);
}

TEST(VertexBake, SplitLongEdgesIsConformingAndInterpolates) {
    Primitive p = plane(1, 2.0f, 0.0f);  // 2 triangles, edges 2 m and 2.83 m
    // Split the quad's vertices at a seam: duplicate vertex 0 for the second triangle.
    p.positions.push_back(p.positions[0]);
    p.normals.push_back(p.normals[0]);
    p.uv0.push_back(p.uv0[0]);
    p.indices[3] = 4;
    const size_t added = split_long_edges(p, 0.3);
    EXPECT_GT(added, 50u);
    double area = 0.0;
    std::map<std::pair<std::tuple<float, float, float>, std::tuple<float, float, float>>, int>
        edges;
    auto key = [](const glm::vec3& v) { return std::make_tuple(v.x, v.y, v.z); };
    for (size_t f = 0; f < p.triangle_count(); ++f) {
        const glm::vec3 a = p.positions[p.indices[3 * f]], b = p.positions[p.indices[3 * f + 1]],
                        c = p.positions[p.indices[3 * f + 2]];
        const glm::vec3 cr = glm::cross(b - a, c - a);
        EXPECT_GT(cr.y, 0.0f) << "winding kept";
        area += 0.5 * glm::length(cr);
        const glm::vec3 t[3] = {a, b, c};
        for (int e = 0; e < 3; ++e) {
            EXPECT_LE(glm::length(t[e] - t[(e + 1) % 3]), 0.3f + 1e-5f);
            auto k0 = key(t[e]), k1 = key(t[(e + 1) % 3]);
            edges[std::minmax(k0, k1)]++;
        }
    }
    EXPECT_NEAR(area, 4.0, 1e-4);
    // Conforming: every interior edge has two triangles, border edges (|x| or |z| = 1) one.
    for (const auto& [k, count] : edges) {
        const auto& [a, b] = k;
        const bool border =
            (std::get<0>(a) == std::get<0>(b) && std::abs(std::get<0>(a)) == 1.0f) ||
            (std::get<2>(a) == std::get<2>(b) && std::abs(std::get<2>(a)) == 1.0f);
        EXPECT_EQ(count, border ? 1 : 2);
    }
    // Attributes interpolated: uv0 stays the same linear function of the position.
    for (size_t v = 0; v < p.positions.size(); ++v) {
        EXPECT_NEAR(p.uv0[v].x, p.positions[v].x * 0.25f + 0.5f, 1e-5f);
        EXPECT_NEAR(p.uv0[v].y, p.positions[v].z * 0.5f, 1e-5f);
        EXPECT_NEAR(glm::length(p.normals[v]), 1.0f, 1e-5f);
    }
}

TEST(VertexBake, SplittingReducesTheErrorOfTheAngleWeightedBake) {
    const glm::vec3 light(0.0f, 0.5f, 0.0f);
    IrradianceOracle point = [&](const glm::vec3& x, const glm::vec3& n) {
        const glm::vec3 d = light - x;
        const float r2 = glm::dot(d, d);
        return glm::vec3(std::max(0.0f, glm::dot(n, d / std::sqrt(r2))) / r2);
    };
    Primitive coarse = plane(2, 4.0f, 0.0f), fine = coarse;
    VertexBakeOptions o;
    o.method = VertexBakeMethod::AngleWeighted;
    o.max_edge_m = 0.25;
    auto r = bake_vertex_irradiance(fine, glm::dmat4(1.0), point, o);
    ASSERT_TRUE(r.ok());
    EXPECT_GT(r->triangles_added, 0u);
    auto c = vertex_irradiance_angle_weighted(coarse, glm::dmat4(1.0), point, 4);
    auto f = vertex_irradiance_angle_weighted(fine, glm::dmat4(1.0), point, 4);
    ASSERT_TRUE(c.ok() && f.ok());
    EXPECT_LT(vertex_l2_error(fine, glm::dmat4(1.0), point, *f, 8),
              0.5 * vertex_l2_error(coarse, glm::dmat4(1.0), point, *c, 8));
}

TEST(VertexBake, SeamWeightPullsSplitVerticesTogether) {
    // Two halves of a plane meeting at x = 0 with their own copies of the seam vertices, under a
    // field that jumps there: without the seam term the two copies take the two sides' values.
    Primitive p = plane(4, 2.0f, 0.0f);
    const size_t nv = p.positions.size();
    std::map<uint32_t, uint32_t> copy;
    for (size_t f = 0; f < p.triangle_count(); ++f) {
        float cx = 0.0f;
        for (int k = 0; k < 3; ++k) cx += p.positions[p.indices[3 * f + k]].x;
        if (cx <= 0.0f) continue;  // left half keeps the originals
        for (int k = 0; k < 3; ++k) {
            uint32_t& v = p.indices[3 * f + k];
            if (p.positions[v].x != 0.0f) continue;
            auto [it, inserted] = copy.emplace(v, uint32_t(p.positions.size()));
            if (inserted) {
                p.positions.push_back(p.positions[v]);
                p.normals.push_back(p.normals[v]);
                p.uv0.push_back(p.uv0[v]);
            }
            v = it->second;
        }
    }
    ASSERT_EQ(p.positions.size(), nv + 5);
    auto step = [](const glm::vec3& x, const glm::vec3&) {
        return glm::vec3(x.x < 0.0f ? 1.0f : 3.0f);
    };
    auto gap = [&](const std::vector<glm::vec3>& c) {
        double g = 0.0;
        for (auto [a, b] : copy) g = std::max(g, double(std::abs(c[a].x - c[b].x)));
        return g;
    };
    auto free = vertex_irradiance_least_squares(p, glm::dmat4(1.0), step, 4, 0.0);
    auto tied = vertex_irradiance_least_squares(p, glm::dmat4(1.0), step, 4, 100.0);
    ASSERT_TRUE(free.ok() && tied.ok());
    EXPECT_GT(gap(*free), 1.9);  // about 3 - 1
    EXPECT_LT(gap(*tied), 0.05);
    for (auto [a, b] : copy) {  // the shared value lies between the two sides'
        EXPECT_GT((*tied)[a].x, 1.2f);
        EXPECT_LT((*tied)[a].x, 2.8f);
    }
}

TEST(VertexBake, ErrorsAreReported) {
    Primitive p = plane(1, 1.0f, 0.0f);
    auto oracle = [](const glm::vec3&, const glm::vec3&) { return glm::vec3(1.0f); };
    EXPECT_FALSE(vertex_irradiance_least_squares(p, glm::dmat4(1.0), oracle, 1).ok());
    p.positions[2].x = std::nanf("");
    auto r = vertex_irradiance_angle_weighted(p, glm::dmat4(1.0), oracle, 2);
    ASSERT_FALSE(r.ok());
    EXPECT_NE(r.error().message.find("vertex 2"), std::string::npos);
}

}  // namespace
}  // namespace hmdnode
