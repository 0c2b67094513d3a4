// Per-vertex light carried from a base mesh onto a coarse level (lod/attribute_transfer.hpp),
// against closed forms: a footprint mean of a linear field over a symmetric footprint is the
// field at its centre; a constant stays constant; the two sides of a thin sheet stay apart.
#include <gtest/gtest.h>

#include <cmath>

#include "hmdnode/lod/attribute_transfer.hpp"

using namespace hmdnode;

namespace {

// An n x n grid of quads on the plane y = h over [-1, 1]^2, normals (0, ny, 0), light f(x, z).
Primitive grid(int n, float h, float ny, glm::vec3 (*f)(float, float)) {
    Primitive p;
    for (int j = 0; j <= n; ++j)
        for (int i = 0; i <= n; ++i) {
            const float x = -1.0f + 2.0f * float(i) / float(n),
                        z = -1.0f + 2.0f * float(j) / float(n);
            p.positions.emplace_back(x, h, z);
            p.normals.emplace_back(0.0f, ny, 0.0f);
            if (f) p.light.push_back(f(x, z));
        }
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            const uint32_t a = uint32_t(j * (n + 1) + i), b = a + 1, c = a + uint32_t(n + 1),
                           d = c + 1;
            p.indices.insert(p.indices.end(), {a, c, b, b, c, d});
        }
    return p;
}

glm::vec3 linear(float x, float z) {
    return glm::vec3(2.0f + x, 3.0f - 0.5f * z, 1.0f + x + z);
}
// The linear field with a +-0.5 checkerboard on the 64 x 64 grid: noise a footprint averages out
// and a nearest-vertex pick keeps.
glm::vec3 noisy(float x, float z) {
    const int i = int(std::lround((x + 1.0f) * 32.0f)), j = int(std::lround((z + 1.0f) * 32.0f));
    return linear(x, z) + glm::vec3((i + j) % 2 ? 0.5f : -0.5f);
}
glm::vec3 constant(float, float) {
    return glm::vec3(0.25f, 0.5f, 4.0f);
}
glm::vec3 zero(float, float) {
    return glm::vec3(0.0f);
}

}  // namespace

TEST(AttributeTransfer, ALinearFieldIsKeptAtInteriorVerticesAndAConstantEverywhere) {
    const Primitive base = grid(64, 0.0f, 1.0f, linear);
    const Primitive coarse = grid(4, 0.0f, 1.0f, nullptr);
    Result<std::vector<glm::vec3>> light = transfer_vertex_light(base, coarse);
    ASSERT_TRUE(light.ok()) << light.error().message;
    ASSERT_EQ(light->size(), coarse.positions.size());
    for (int j = 1; j < 4; ++j)
        for (int i = 1; i < 4; ++i) {
            const size_t v = size_t(j * 5 + i);
            const glm::vec3 p = coarse.positions[v];
            const glm::vec3 want = linear(p.x, p.z), got = (*light)[v];
            // Interior footprints are symmetric except for the triangulation's diagonal edges,
            // which lengthen the mean edge, not the footprint's symmetry.
            EXPECT_NEAR(got.x, want.x, 1e-3) << i << "," << j;
            EXPECT_NEAR(got.y, want.y, 1e-3) << i << "," << j;
            EXPECT_NEAR(got.z, want.z, 1e-3) << i << "," << j;
        }
    // Noise per base vertex is filtered: a footprint holds about 50 base vertices.
    Result<std::vector<glm::vec3>> filtered =
        transfer_vertex_light(grid(64, 0.0f, 1.0f, noisy), coarse);
    ASSERT_TRUE(filtered.ok());
    const glm::vec3 centre = (*filtered)[12];  // the vertex at (0, 0)
    EXPECT_NEAR(centre.x, 2.0f, 0.05f);
    EXPECT_NEAR(centre.z, 1.0f, 0.05f);
    const Primitive flat = grid(64, 0.0f, 1.0f, constant);
    Result<std::vector<glm::vec3>> c = transfer_vertex_light(flat, coarse);
    ASSERT_TRUE(c.ok());
    for (const glm::vec3& l : *c) {
        EXPECT_NEAR(l.x, 0.25f, 1e-6);
        EXPECT_NEAR(l.z, 4.0f, 1e-6);
    }
}

TEST(AttributeTransfer, TheTwoSidesOfAThinSheetStayApart) {
    // A lit top (light 1) and a dark underside (light 0) 1 mm apart, far closer than a footprint.
    Primitive base = grid(32, 0.0005f, 1.0f, constant);
    const Primitive under = grid(32, -0.0005f, -1.0f, zero);
    const uint32_t offset = uint32_t(base.positions.size());
    base.positions.insert(base.positions.end(), under.positions.begin(), under.positions.end());
    base.normals.insert(base.normals.end(), under.normals.begin(), under.normals.end());
    base.light.insert(base.light.end(), under.light.begin(), under.light.end());
    for (uint32_t i : under.indices) base.indices.push_back(i + offset);
    const Primitive top = grid(2, 0.0f, 1.0f, nullptr), bottom = grid(2, 0.0f, -1.0f, nullptr);
    Result<std::vector<glm::vec3>> up = transfer_vertex_light(base, top);
    Result<std::vector<glm::vec3>> down = transfer_vertex_light(base, bottom);
    ASSERT_TRUE(up.ok() && down.ok());
    for (const glm::vec3& l : *up) EXPECT_FLOAT_EQ(l.z, 4.0f);
    for (const glm::vec3& l : *down) EXPECT_FLOAT_EQ(l.z, 0.0f);
}

TEST(AttributeTransfer, MissingLightOrNormalsAreNamed) {
    const Primitive coarse = grid(2, 0.0f, 1.0f, nullptr);
    Result<std::vector<glm::vec3>> r = transfer_vertex_light(coarse, coarse);
    ASSERT_FALSE(r.ok());
    EXPECT_NE(r.error().message.find("no per-vertex light"), std::string::npos);
    Primitive no_normals = grid(4, 0.0f, 1.0f, constant);
    no_normals.normals.clear();
    r = transfer_vertex_light(no_normals, coarse);
    ASSERT_FALSE(r.ok());
    EXPECT_NE(r.error().message.find("base mesh has no normals"), std::string::npos);
    Primitive level = coarse;
    level.normals.pop_back();
    r = transfer_vertex_light(grid(4, 0.0f, 1.0f, constant), level);
    ASSERT_FALSE(r.ok());
    EXPECT_NE(r.error().message.find("level has no normals"), std::string::npos);
}
