#include "hmdnode/bake/bvh.hpp"

#include <cmath>
#include <limits>
#include <random>

#include <gtest/gtest.h>

namespace hmdnode {
namespace {

bool brute_force(const std::vector<glm::vec3>& c, const glm::vec3& o, const glm::vec3& d,
                 float t_min, float t_max, RayHit* out) {
    bool found = false;
    float best = t_max;
    for (size_t t = 0; t < c.size() / 3; ++t) {
        glm::vec3 e1 = c[3 * t + 1] - c[3 * t], e2 = c[3 * t + 2] - c[3 * t];
        glm::vec3 p = glm::cross(d, e2);
        float det = glm::dot(e1, p);
        if (det == 0.0f) continue;
        glm::vec3 s = o - c[3 * t];
        float u = glm::dot(s, p) / det;
        glm::vec3 q = glm::cross(s, e1);
        float v = glm::dot(d, q) / det;
        float tt = glm::dot(e2, q) / det;
        if (u < 0 || v < 0 || u + v > 1 || !(tt > t_min && tt < best)) continue;
        best = tt;
        found = true;
        out->t = tt;
        out->triangle = uint32_t(t);
    }
    return found;
}

TEST(TriangleBvh, matches_brute_force_on_random_triangles) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> pos(-1.0f, 1.0f), small(-0.1f, 0.1f);
    std::vector<glm::vec3> corners;
    for (int t = 0; t < 2000; ++t) {
        glm::vec3 c(pos(rng), pos(rng), pos(rng));
        for (int k = 0; k < 3; ++k)
            corners.push_back(c + glm::vec3(small(rng), small(rng), small(rng)));
    }
    TriangleBvh bvh(corners);
    EXPECT_EQ(bvh.triangle_count(), 2000u);
    EXPECT_GT(bvh.node_count(), 2000u / 4);
    int hits = 0;
    for (int r = 0; r < 3000; ++r) {
        glm::vec3 o(2.0f * pos(rng), 2.0f * pos(rng), 2.0f * pos(rng));
        glm::vec3 d = glm::normalize(glm::vec3(pos(rng), pos(rng), pos(rng)));
        float t_max = r % 3 == 0 ? 1.0f : 100.0f;
        RayHit expected, got;
        bool e = brute_force(corners, o, d, 0.0f, t_max, &expected);
        bool g = bvh.intersect(o, d, 0.0f, t_max, &got);
        ASSERT_EQ(e, g) << "ray " << r;
        ASSERT_EQ(bvh.occluded(o, d, 0.0f, t_max), e) << "ray " << r;
        if (e) {
            ++hits;
            EXPECT_EQ(got.triangle, expected.triangle) << "ray " << r;
            EXPECT_NEAR(got.t, expected.t, 1e-5f) << "ray " << r;
        }
    }
    EXPECT_GT(hits, 300);
}

TEST(TriangleBvh, axis_parallel_rays_and_both_sides) {
    // One triangle in the plane z = 0 facing +Z.
    TriangleBvh bvh({glm::vec3(-1, -1, 0), glm::vec3(1, -1, 0), glm::vec3(0, 1, 0)});
    RayHit hit;
    ASSERT_TRUE(bvh.intersect(glm::vec3(0, 0, 5), glm::vec3(0, 0, -1), 0.0f, 10.0f, &hit));
    EXPECT_FLOAT_EQ(hit.t, 5.0f);
    EXPECT_TRUE(bvh.occluded(glm::vec3(0, 0, -5), glm::vec3(0, 0, 1), 0.0f, 10.0f));  // back side
    EXPECT_FALSE(bvh.occluded(glm::vec3(0, 0, -5), glm::vec3(0, 0, 1), 0.0f, 4.9f));  // too short
    EXPECT_FALSE(
        bvh.occluded(glm::vec3(0, 0, -5), glm::vec3(0, 0, 1), 5.1f, 10.0f));  // starts past it
    EXPECT_FALSE(bvh.occluded(glm::vec3(3, 0, 5), glm::vec3(0, 0, -1), 0.0f, 10.0f));  // misses
    EXPECT_FALSE(TriangleBvh().occluded(glm::vec3(0), glm::vec3(1, 0, 0), 0.0f, 1.0f));
}

}  // namespace
}  // namespace hmdnode
