// The edge-collapse algorithms (qem, curvature-qem, formula1, melax) on small meshes with known
// answers: flat grid, cube, sphere, UV seam, borders, flips, manifoldness.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <map>
#include <set>
#include <string>
#include <system_error>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "hmdnode/core/obj.hpp"
#include "hmdnode/lod/progressive_mesh.hpp"
#include "hmdnode/lod/simplify.hpp"
#include "lod/test_meshes.hpp"

namespace hmdnode {
namespace {

const char* const kAlgorithms[] = {"qem", "curvature-qem", "formula1", "melax"};

// [0,1]^2 at z = height(x, y), n x n quads, 2 n^2 triangles, counter-clockwise seen from +Z.
template <class Height>
Primitive grid(int n, Height height) {
    Primitive p;
    for (int j = 0; j <= n; ++j) {
        for (int i = 0; i <= n; ++i) {
            const float x = float(i) / float(n), y = float(j) / float(n);
            p.positions.emplace_back(x, y, height(x, y));
        }
    }
    auto at = [n](int i, int j) { return uint32_t(j * (n + 1) + i); };
    for (int j = 0; j < n; ++j) {
        for (int i = 0; i < n; ++i) {
            p.indices.insert(p.indices.end(), {at(i, j), at(i + 1, j), at(i + 1, j + 1)});
            p.indices.insert(p.indices.end(), {at(i, j), at(i + 1, j + 1), at(i, j + 1)});
        }
    }
    return p;
}
Primitive flat_grid(int n) {
    return grid(n, [](float, float) { return 0.0f; });
}

// The cube [-1,1]^3, each face an n x n grid, vertices shared along the cube's edges, outward
// counter-clockwise faces. n = 1: the 12-triangle cube of Lazányi 2003, Figure 5
// (docs/references.md).
Primitive cube(int n) {
    Primitive p;
    std::map<std::array<int, 3>, uint32_t> ids;
    auto vertex = [&](std::array<int, 3> g) {  // g in [0, n]^3
        auto [it, added] = ids.emplace(g, uint32_t(p.positions.size()));
        if (added) {
            p.positions.emplace_back(2.0f * g[0] / n - 1.0f, 2.0f * g[1] / n - 1.0f,
                                     2.0f * g[2] / n - 1.0f);
        }
        return it->second;
    };
    for (int axis = 0; axis < 3; ++axis) {
        for (int side = 0; side < 2; ++side) {
            const int u = (axis + 1) % 3, v = (axis + 2) % 3;
            for (int j = 0; j < n; ++j) {
                for (int i = 0; i < n; ++i) {
                    auto corner = [&](int di, int dj) {
                        std::array<int, 3> g{};
                        g[axis] = side * n, g[u] = i + di, g[v] = j + dj;
                        return vertex(g);
                    };
                    const uint32_t a = corner(0, 0), b = corner(1, 0), c = corner(1, 1),
                                   d = corner(0, 1);
                    if (side == 1) {
                        p.indices.insert(p.indices.end(), {a, b, c, a, c, d});
                    } else {
                        p.indices.insert(p.indices.end(), {a, c, b, a, d, c});
                    }
                }
            }
        }
    }
    return p;
}

// Icosahedron subdivided `levels` times, on the unit sphere (20 * 4^levels triangles).
Primitive sphere(int levels) {
    return test::unit_icosphere(levels);
}

Primitive simplify_one(const Primitive& in, const char* algorithm, size_t target,
                       SimplifyOptions options = {}) {
    const size_t targets[] = {target};
    Result<std::vector<SimplifiedLevel>> r = simplify(in, algorithm, targets, options);
    EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().message);
    return r.ok() ? r->front().primitive : Primitive{};
}

glm::dvec3 face_normal(const Primitive& p, size_t f) {
    const glm::dvec3 a = p.positions[p.indices[3 * f]], b = p.positions[p.indices[3 * f + 1]],
                     c = p.positions[p.indices[3 * f + 2]];
    return glm::cross(b - a, c - a);
}

std::set<std::array<float, 3>> position_set(const Primitive& p) {
    std::set<std::array<float, 3>> s;
    for (uint32_t i : p.indices) s.insert({p.positions[i].x, p.positions[i].y, p.positions[i].z});
    return s;
}

// Edges by position (welded), with their face count; and whether each directed edge is unique.
struct EdgeCensus {
    std::map<std::pair<std::array<float, 3>, std::array<float, 3>>, int> faces;
    bool oriented = true;     // every directed edge appears once
    bool degenerate = false;  // a face with two equal positions
    bool duplicate = false;   // two faces on the same three positions
};
EdgeCensus census(const Primitive& p) {
    EdgeCensus c;
    std::set<std::pair<std::array<float, 3>, std::array<float, 3>>> directed;
    std::set<std::array<std::array<float, 3>, 3>> triples;
    auto key = [&](uint32_t i) {
        return std::array<float, 3>{p.positions[i].x, p.positions[i].y, p.positions[i].z};
    };
    for (size_t f = 0; f < p.triangle_count(); ++f) {
        std::array<std::array<float, 3>, 3> t{key(p.indices[3 * f]), key(p.indices[3 * f + 1]),
                                              key(p.indices[3 * f + 2])};
        if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) c.degenerate = true;
        for (int k = 0; k < 3; ++k) {
            const auto a = t[k], b = t[(k + 1) % 3];
            if (!directed.insert({a, b}).second) c.oriented = false;
            ++c.faces[std::minmax(a, b)];
        }
        std::sort(t.begin(), t.end());
        if (!triples.insert(t).second) c.duplicate = true;
    }
    return c;
}

// Adjacent face pairs (sharing an edge, by position) whose unit normals' dot product is below
// -0.8 (the engine's kFoldCosine): two faces folded onto each other by more than 143 degrees.
size_t folded_pairs(const Primitive& p) {
    using Key = std::array<float, 3>;
    auto key = [&](uint32_t i) {
        return Key{p.positions[i].x, p.positions[i].y, p.positions[i].z};
    };
    std::map<std::pair<Key, Key>, std::vector<size_t>> edges;
    for (size_t f = 0; f < p.triangle_count(); ++f) {
        for (int k = 0; k < 3; ++k) {
            const Key a = key(p.indices[3 * f + k]), b = key(p.indices[3 * f + (k + 1) % 3]);
            edges[std::minmax(a, b)].push_back(f);
        }
    }
    size_t folded = 0;
    for (const auto& [edge, faces] : edges) {
        if (faces.size() != 2) continue;
        const glm::dvec3 n0 = face_normal(p, faces[0]), n1 = face_normal(p, faces[1]);
        const double l0 = glm::length(n0), l1 = glm::length(n1);
        if (l0 > 0.0 && l1 > 0.0 && glm::dot(n0, n1) / (l0 * l1) < -0.8) ++folded;
    }
    return folded;
}

TEST(EdgeCollapse, FlatGridReducesToTwoTrianglesWithZeroErrorAndKeepsItsCorners) {
    const Primitive in = flat_grid(20);
    const size_t targets[] = {2};
    Result<std::vector<SimplifiedLevel>> r = simplify(in, "qem", targets);
    ASSERT_TRUE(r.ok()) << r.error().message;
    const Primitive& out = r->front().primitive;
    ASSERT_EQ(out.triangle_count(), 2u);
    EXPECT_EQ(r->front().estimated_error, 0.0);
    const std::set<std::array<float, 3>> corners{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}};
    EXPECT_EQ(position_set(out), corners);
    double area = 0.0;
    for (size_t f = 0; f < 2; ++f) {
        const glm::dvec3 n = face_normal(out, f);
        EXPECT_GT(n.z, 0.0);  // still facing +Z
        area += 0.5 * glm::length(n);
    }
    EXPECT_DOUBLE_EQ(area, 1.0);  // the two triangles cover the square
}

TEST(EdgeCollapse, CubeKeepsItsEightCornersUnderMelaxAndQem) {
    const Primitive in = cube(4);  // 192 triangles
    std::set<std::array<float, 3>> corners;
    for (float x : {-1.0f, 1.0f})
        for (float y : {-1.0f, 1.0f})
            for (float z : {-1.0f, 1.0f}) corners.insert({x, y, z});
    for (const char* algorithm : {"melax", "qem"}) {
        const Primitive out = simplify_one(in, algorithm, 12);
        EXPECT_EQ(out.triangle_count(), 12u) << algorithm;
        EXPECT_EQ(position_set(out), corners) << algorithm;
        const EdgeCensus c = census(out);
        EXPECT_TRUE(c.oriented && !c.degenerate && !c.duplicate) << algorithm;
    }
}

// Lazányi 2003, Figure 5: on the 12-triangle cube a face diagonal has parallel face normals, so
// Formula 1 rates it cheapest (cost = its length), pulling a corner across the face; Melax rates
// the diagonal 0.5 * 2 sqrt 2 and a cube edge 0.5 * 2, and takes a cube edge first. The diagonal's
// collapse leaves faces 135 degrees apart, short of the engine's fold limit (143 degrees), so it
// stays allowed, and its level has no folded pair.
TEST(EdgeCollapse, Formula1CollapsesTheCubeDiagonalFirstMelaxDoesNot) {
    const Primitive in = cube(1);
    ASSERT_EQ(in.triangle_count(), 12u);
    auto first_collapse_length = [&](const char* algorithm) {
        const size_t targets[] = {10};
        Result<ProgressiveMeshBuild> b = build_progressive_mesh(in, algorithm, targets);
        EXPECT_TRUE(b.ok()) << (b.ok() ? "" : b.error().message);
        if (!b.ok() || b->mesh.splits.empty()) return -1.0;
        EXPECT_EQ(b->levels[0].primitive.triangle_count(), 10u) << algorithm;
        EXPECT_EQ(position_set(b->levels[0].primitive).size(), 7u) << algorithm;  // a corner gone
        EXPECT_EQ(folded_pairs(b->levels[0].primitive), 0u) << algorithm;
        const VertexSplit& first = b->mesh.splits.back();  // splits run coarse to fine
        return double(glm::length(first.removed.position - first.kept_position));
    };
    EXPECT_NEAR(first_collapse_length("formula1"), 2.0 * std::sqrt(2.0), 1e-6);
    EXPECT_NEAR(first_collapse_length("melax"), 2.0, 1e-6);
}

// Formula 1 keeps no corner guarantee on the tessellated cube (it is "short-sighted"), Melax
// does: reduced to 12 triangles, Formula 1 has lost at least one corner of the cube.
TEST(EdgeCollapse, Formula1LosesCubeCornersWhereMelaxKeepsThem) {
    const Primitive out = simplify_one(cube(4), "formula1", 12);
    std::set<std::array<float, 3>> corners;
    for (float x : {-1.0f, 1.0f})
        for (float y : {-1.0f, 1.0f})
            for (float z : {-1.0f, 1.0f}) corners.insert({x, y, z});
    const std::set<std::array<float, 3>> got = position_set(out);
    size_t kept = 0;
    for (const auto& c : corners) kept += got.count(c);
    EXPECT_LT(kept, 8u);
}

TEST(EdgeCollapse, SphereErrorFallsAsItsTriangleCountRises) {
    const Primitive in = sphere(4);  // 5120 triangles
    const size_t targets[] = {1500, 500, 150};
    Result<std::vector<SimplifiedLevel>> r = simplify(in, "qem", targets);
    ASSERT_TRUE(r.ok()) << r.error().message;
    std::vector<double> vertex_error, surface_error;
    for (size_t l = 0; l < 3; ++l) {
        const Primitive& p = (*r)[l].primitive;
        EXPECT_LE(p.triangle_count(), targets[l]);
        EXPECT_GE(p.triangle_count(), targets[l] - 1);
        double ve = 0.0, se = 0.0;
        for (uint32_t i : p.indices)
            ve = std::max(ve, std::abs(glm::length(glm::dvec3(p.positions[i])) - 1.0));
        for (size_t f = 0; f < p.triangle_count(); ++f) {  // distance to the sphere: | |x| - 1 |
            const glm::dvec3 a = p.positions[p.indices[3 * f]],
                             b = p.positions[p.indices[3 * f + 1]],
                             c = p.positions[p.indices[3 * f + 2]];
            for (int i = 0; i <= 4; ++i)
                for (int j = 0; i + j <= 4; ++j) {
                    const glm::dvec3 x = a + (b - a) * (i / 4.0) + (c - a) * (j / 4.0);
                    se = std::max(se, std::abs(glm::length(x) - 1.0));
                }
        }
        vertex_error.push_back(ve);
        surface_error.push_back(se);
    }
    EXPECT_LT(surface_error[0], surface_error[1]);
    EXPECT_LT(surface_error[1], surface_error[2]);
    EXPECT_LT(vertex_error[0], vertex_error[2]);
    // A sphere with ~150 faces: chords of about 0.35 rad, sagitta 1 - cos(0.175) = 0.015.
    EXPECT_LT(surface_error[2], 0.05);
    EXPECT_LT(vertex_error[2], 0.03);  // optimal placement stays near the surface
    EXPECT_GT(surface_error[0], 0.0);
}

// A flat grid whose left and right halves are separate UV charts (vertices on x = 0.5
// duplicated): uv1 = (0.45 x / 0.5, y) on the left, (0.55 + 0.45 (x - 0.5) / 0.5, y) on the right;
// uv0 = (x, y) everywhere except a second seam in uv0 only along y = 0.5 on the right half.
Primitive seamed_grid(int n) {
    Primitive p;
    auto chart_uv1 = [](float x, float y, bool right) {
        return right ? glm::vec2(0.55f + 0.9f * (x - 0.5f), y) : glm::vec2(0.9f * x, y);
    };
    std::map<std::array<int, 3>, uint32_t> ids;  // (i, j, chart)
    auto vertex = [&](int i, int j, bool right) {
        auto [it, added] =
            ids.emplace(std::array<int, 3>{i, j, right}, uint32_t(p.positions.size()));
        if (added) {
            const float x = float(i) / float(n), y = float(j) / float(n);
            p.positions.emplace_back(x, y, 0.0f);
            p.normals.emplace_back(0.0f, 0.0f, 1.0f);
            p.uv0.emplace_back(x, y);
            p.uv1.push_back(chart_uv1(x, y, right));
            p.colors.emplace_back(x, y, 1.0f, 1.0f);
        }
        return it->second;
    };
    for (int j = 0; j < n; ++j) {
        for (int i = 0; i < n; ++i) {
            const bool right = i >= n / 2;
            const uint32_t a = vertex(i, j, right), b = vertex(i + 1, j, right),
                           c = vertex(i + 1, j + 1, right), d = vertex(i, j + 1, right);
            p.indices.insert(p.indices.end(), {a, b, c, a, c, d});
        }
    }
    return p;
}

TEST(EdgeCollapse, UvSeamsSurviveEveryLevel) {
    const Primitive in = seamed_grid(20);
    const size_t targets[] = {400, 100, 20};
    for (const char* algorithm : kAlgorithms) {
        Result<std::vector<SimplifiedLevel>> r = simplify(in, algorithm, targets);
        ASSERT_TRUE(r.ok()) << r.error().message;
        for (const SimplifiedLevel& level : *r) {
            const Primitive& p = level.primitive;
            ASSERT_EQ(p.uv1.size(), p.positions.size());
            ASSERT_EQ(p.normals.size(), p.positions.size());
            std::map<std::array<float, 3>, std::set<bool>> charts_at;
            for (size_t f = 0; f < p.triangle_count(); ++f) {
                // A face stays in one chart, and its uv1 is still the chart's affine map of the
                // position (attributes interpolated along the edge on the flat grid).
                std::set<bool> face_chart;
                for (int k = 0; k < 3; ++k) {
                    const uint32_t i = p.indices[3 * f + k];
                    const glm::vec3 x = p.positions[i];
                    const bool right = p.uv1[i].x >= 0.5f;
                    face_chart.insert(right);
                    const glm::vec2 want = right ? glm::vec2(0.55f + 0.9f * (x.x - 0.5f), x.y)
                                                 : glm::vec2(0.9f * x.x, x.y);
                    EXPECT_NEAR(p.uv1[i].x, want.x, 1e-5) << algorithm;
                    EXPECT_NEAR(p.uv1[i].y, want.y, 1e-5) << algorithm;
                    EXPECT_NEAR(p.uv0[i].x, x.x, 1e-5) << algorithm;
                    EXPECT_NEAR(p.normals[i].z, 1.0f, 1e-6) << algorithm;
                    EXPECT_TRUE(right ? p.uv1[i].x <= 1.0f : p.uv1[i].x <= 0.45f + 1e-6f);
                    charts_at[{x.x, x.y, x.z}].insert(right);
                }
                EXPECT_EQ(face_chart.size(), 1u) << algorithm;
                EXPECT_GT(face_normal(p, f).z, 0.0) << algorithm;
            }
            // The seam is still the line x = 0.5: positions there carry both charts, all others
            // one.
            for (const auto& [x, charts] : charts_at) {
                if (x[0] == 0.5f) {
                    EXPECT_EQ(charts.size(), 2u) << algorithm << " y=" << x[1];
                } else {
                    EXPECT_EQ(charts.size(), 1u) << algorithm;
                    EXPECT_EQ(*charts.begin(), x[0] > 0.5f) << algorithm;
                }
            }
        }
    }
}

// Compare each output face's normal with the input face nearest to its centroid.
TEST(EdgeCollapse, NoFaceFlips) {
    const Primitive in = grid(24, [](float x, float y) {
        // note: slopes up to ~0.8, so a face that keeps facing up never meets an input face
        // facing away from it; a flipped face does.
        return 0.05f * std::sin(7.0f * x) * std::cos(5.0f * y) + 0.02f * std::sin(23.0f * x * y);
    });
    for (const char* algorithm : kAlgorithms) {
        for (size_t target : {300, 60}) {
            const Primitive out = simplify_one(in, algorithm, target);
            ASSERT_GT(out.triangle_count(), 0u);
            for (size_t f = 0; f < out.triangle_count(); ++f) {
                const glm::dvec3 c = (glm::dvec3(out.positions[out.indices[3 * f]]) +
                                      glm::dvec3(out.positions[out.indices[3 * f + 1]]) +
                                      glm::dvec3(out.positions[out.indices[3 * f + 2]])) /
                                     3.0;
                double best = 1e30;
                glm::dvec3 best_normal(0.0);
                for (size_t g = 0; g < in.triangle_count(); ++g) {
                    const glm::dvec3 d = (glm::dvec3(in.positions[in.indices[3 * g]]) +
                                          glm::dvec3(in.positions[in.indices[3 * g + 1]]) +
                                          glm::dvec3(in.positions[in.indices[3 * g + 2]])) /
                                             3.0 -
                                         c;
                    if (glm::dot(d, d) < best)
                        best = glm::dot(d, d), best_normal = face_normal(in, g);
                }
                const double cosine =
                    glm::dot(glm::normalize(face_normal(out, f)), glm::normalize(best_normal));
                if (std::string(algorithm) != "formula1") {
                    EXPECT_GT(cosine, 0.0) << algorithm << " target " << target << " face " << f;
                } else {
                    // note: Formula 1 is short-sighted (Lazányi 2003): it leaves slivers standing
                    // at about 90 degrees along the border (the engine lets a face reach 90
                    // degrees from its own input normal, not pass it, which Lazányi's cube
                    // diagonal needs); the nearest input face may lean slightly the other way. A
                    // turned-over face would be near -1.
                    EXPECT_GT(cosine, -0.25) << algorithm << " target " << target << " face " << f;
                }
            }
        }
    }
}

TEST(EdgeCollapse, ClosedManifoldInputStaysClosedAndManifold) {
    const Primitive in = sphere(3);  // 1280 triangles
    for (const char* algorithm : kAlgorithms) {
        const size_t targets[] = {600, 100, 20};
        Result<std::vector<SimplifiedLevel>> r = simplify(in, algorithm, targets);
        ASSERT_TRUE(r.ok()) << r.error().message;
        for (size_t l = 0; l < 3; ++l) {
            const Primitive& p = (*r)[l].primitive;
            EXPECT_LE(p.triangle_count(), targets[l]) << algorithm;
            const EdgeCensus c = census(p);
            EXPECT_TRUE(c.oriented) << algorithm;
            EXPECT_FALSE(c.degenerate) << algorithm;
            EXPECT_FALSE(c.duplicate) << algorithm;
            for (const auto& [edge, faces] : c.faces) EXPECT_EQ(faces, 2) << algorithm;
            // Euler characteristic of a sphere: V - E + F = 2.
            const long v = long(position_set(p).size()), e = long(c.faces.size()),
                       f = long(p.triangle_count());
            EXPECT_EQ(v - e + f, 2) << algorithm;
        }
    }
}

// From 8 192 faces on, the pass schedule (qem, curvature-qem) cuts the mesh in two regions and
// applies most of a pass's collapses region by region, on a helper thread where the caller allows
// one (threads = 2) and there is a second core: a closed sphere of 81 920 faces still comes out
// closed, manifold, facing out, and bit for bit the same with the helper and without (threads = 1).
TEST(EdgeCollapse, TwoRegionPassesKeepTheSphereClosedAndDoNotDependOnTheHelper) {
    const Primitive in = sphere(6);
    const size_t targets[] = {20000, 2000, 200};
    for (const char* algorithm : {"qem", "curvature-qem"}) {
        SimplifyOptions one_thread, helper;
        one_thread.threads = 1;
        helper.threads = 2;
        Result<std::vector<SimplifiedLevel>> a = simplify(in, algorithm, targets, helper);
        Result<std::vector<SimplifiedLevel>> b = simplify(in, algorithm, targets, one_thread);
        ASSERT_TRUE(a.ok()) << a.error().message;
        ASSERT_TRUE(b.ok()) << b.error().message;
        for (size_t l = 0; l < 3; ++l) {
            const Primitive& p = (*a)[l].primitive;
            const Primitive& q = (*b)[l].primitive;
            EXPECT_LE(p.triangle_count(), targets[l]) << algorithm;
            EXPECT_GE(p.triangle_count(), targets[l] - 2) << algorithm;
            EXPECT_EQ(p.indices, q.indices) << algorithm << " level " << l;
            ASSERT_EQ(p.positions.size(), q.positions.size()) << algorithm;
            EXPECT_EQ(std::memcmp(p.positions.data(), q.positions.data(), p.positions.size() * 12),
                      0)
                << algorithm << " level " << l;
            EXPECT_EQ((*a)[l].estimated_error, (*b)[l].estimated_error) << algorithm;
            const EdgeCensus c = census(p);
            EXPECT_TRUE(c.oriented) << algorithm;
            EXPECT_FALSE(c.degenerate) << algorithm;
            EXPECT_FALSE(c.duplicate) << algorithm;
            size_t not_two = 0;
            for (const auto& [edge, faces] : c.faces) not_two += faces != 2;
            EXPECT_EQ(not_two, 0u) << algorithm;
            const long v = long(position_set(p).size()), e = long(c.faces.size()),
                       f = long(p.triangle_count());
            EXPECT_EQ(v - e + f, 2) << algorithm;
            size_t inward = 0;
            for (size_t t = 0; t < p.triangle_count(); ++t) {
                const glm::dvec3 centre = glm::dvec3(p.positions[p.indices[3 * t]]) +
                                          glm::dvec3(p.positions[p.indices[3 * t + 1]]) +
                                          glm::dvec3(p.positions[p.indices[3 * t + 2]]);
                inward += glm::dot(face_normal(p, t), centre) <= 0.0;
            }
            EXPECT_EQ(inward, 0u) << algorithm << " level " << l;
        }
    }
}

// Piecewise-flat input (the spot, data/meshes, with each triangle split into 4 on its own
// plane): most candidates cost zero, and many of those fail the checks pass after pass. A pass
// must still make real progress: 41 passes to 35 % here, where a pass limit held at zero by the
// failing candidates made a handful of collapses per pass (170 passes here, 1 302 on the bunny
// split the same way, 20x its time).
TEST(EdgeCollapse, PiecewiseFlatInputTakesFewPasses) {
    Result<Mesh> spot = load_obj(HMDNODE_SOURCE_DIR "/data/meshes/spot.obj");
    ASSERT_TRUE(spot.ok()) << spot.error().message;
    Primitive coarse;
    coarse.positions = spot->primitives[0].positions;
    coarse.indices = spot->primitives[0].indices;
    const Primitive in = test::subdivided_flat(coarse, 1);
    ASSERT_EQ(in.triangle_count(), 23424u);
    const size_t targets[] = {8198};
    for (const char* algorithm : {"qem", "curvature-qem"}) {
        for (unsigned threads : {1u, 2u}) {
            SimplifyStats stats;
            SimplifyOptions options;
            options.threads = threads;
            options.stats = &stats;
            Result<std::vector<SimplifiedLevel>> r = simplify(in, algorithm, targets, options);
            ASSERT_TRUE(r.ok()) << r.error().message;
            const Primitive& out = (*r)[0].primitive;
            EXPECT_LE(out.triangle_count(), 8198u) << algorithm;
            EXPECT_GE(out.triangle_count(), 8196u) << algorithm;
            EXPECT_GT(stats.collapses, 7000u) << algorithm;
            EXPECT_LE(stats.passes, 80u) << algorithm << " threads " << threads;
            const EdgeCensus c = census(out);
            EXPECT_TRUE(c.oriented) << algorithm;
            EXPECT_FALSE(c.degenerate) << algorithm;
        }
    }
}

// The threads of this process, as /proc lists them (0 where there is no /proc).
size_t process_threads() {
    std::error_code ec;
    size_t n = 0;
    for (auto it = std::filesystem::directory_iterator("/proc/self/task", ec);
         !ec && it != std::filesystem::directory_iterator(); it.increment(ec)) {
        ++n;
    }
    return n;
}

// simplify() starts no thread its caller did not ask for: by default (threads = 1) the call runs
// on the calling thread alone, even on a mesh large enough to split; with threads = 2 it has one
// helper thread while it runs (on a machine with a second core), and none once it returned.
TEST(EdgeCollapse, NoThreadUnlessTheCallerAsksForOne) {
    // note: ThreadSanitizer's runtime starts a background thread of its own with the process's
    // first thread and keeps it; one thread started and joined here first makes it exist before
    // the count (a no-op elsewhere), so the lane counts only the threads simplify() starts.
    std::thread([] {}).join();
    const size_t before = process_threads();
    if (before == 0) GTEST_SKIP() << "no /proc/self/task";
    const Primitive in = sphere(5);  // 20 480 faces: large enough to split
    const size_t targets[] = {1000};
    for (const char* algorithm : {"qem", "melax"}) {
        for (unsigned threads : {1u, 2u}) {
            size_t most = 0;
            SimplifyOptions options;  // note: the default for 1
            if (threads == 2) options.threads = 2;
            options.progress = [&most](double) { most = std::max(most, process_threads()); };
            ASSERT_TRUE(simplify(in, algorithm, targets, options).ok()) << algorithm;
            const bool helper = threads == 2 && std::string(algorithm) != "melax" &&
                                std::thread::hardware_concurrency() > 1;
            EXPECT_EQ(most, before + (helper ? 1 : 0)) << algorithm << " threads " << threads;
            EXPECT_EQ(process_threads(), before) << algorithm << " threads " << threads;
        }
    }
}

TEST(EdgeCollapse, BordersStayOnTheBorderAndLockedBordersStayBitExact) {
    const Primitive in =
        grid(16, [](float x, float y) { return 0.1f * std::sin(6.0f * x + 4.0f * y); });
    auto on_square_border = [](glm::vec3 p) {
        return p.x == 0.0f || p.x == 1.0f || p.y == 0.0f || p.y == 1.0f;
    };
    std::set<std::array<float, 3>> input_border;
    for (const glm::vec3& p : in.positions) {
        if (on_square_border(p)) input_border.insert({p.x, p.y, p.z});
    }
    for (const char* algorithm : kAlgorithms) {
        // Free borders: the output's border vertices are input border vertices, on the square's
        // sides (a border vertex only slides along the border); QEM's boundary planes also keep
        // the square's four corners.
        {
            const Primitive out = simplify_one(in, algorithm, 40);
            const EdgeCensus c = census(out);
            std::set<std::array<float, 3>> border;
            for (const auto& [edge, faces] : c.faces) {
                ASSERT_LE(faces, 2) << algorithm;
                if (faces == 1) border.insert(edge.first), border.insert(edge.second);
            }
            EXPECT_GE(border.size(), 4u);
            for (const auto& x : border) {
                EXPECT_TRUE(on_square_border(glm::vec3(x[0], x[1], x[2]))) << algorithm;
            }
            if (std::string(algorithm) == "qem") {
                size_t corners = 0;
                for (const auto& x : border) {
                    corners += (x[0] == 0.0f || x[0] == 1.0f) && (x[1] == 0.0f || x[1] == 1.0f);
                }
                EXPECT_EQ(corners, 4u);
            }
        }
        // Locked borders: every input border vertex is still there, bit for bit, and nothing else
        // is on the border.
        SimplifyOptions locked;
        locked.lock_borders = true;
        const Primitive out = simplify_one(in, algorithm, 40, locked);
        std::set<std::array<float, 3>> output_border;
        for (uint32_t i : out.indices) {
            const glm::vec3 p = out.positions[i];
            if (on_square_border(p)) output_border.insert({p.x, p.y, p.z});
        }
        EXPECT_EQ(output_border, input_border) << algorithm;
        EXPECT_GT(out.triangle_count(), 0u);
        EXPECT_LT(out.triangle_count(), in.triangle_count());
    }
}

TEST(EdgeCollapse, AllLevelsFromOnePassAndAttributesKept) {
    const Primitive in = seamed_grid(12);
    const size_t targets[] = {200, 150, 100, 50};
    for (const char* algorithm : kAlgorithms) {
        Result<std::vector<SimplifiedLevel>> r = simplify(in, algorithm, targets);
        ASSERT_TRUE(r.ok()) << r.error().message;
        ASSERT_EQ(r->size(), 4u);
        for (size_t l = 0; l < 4; ++l) {
            const Primitive& p = (*r)[l].primitive;
            EXPECT_LE(p.triangle_count(), targets[l]) << algorithm;
            EXPECT_GE(p.triangle_count() + 2, targets[l])
                << algorithm;  // one collapse removes <= 2
            EXPECT_EQ(p.colors.size(), p.positions.size());
            EXPECT_EQ(p.uv0.size(), p.positions.size());
        }
    }
}

// A defect found on real meshes: the flip guard checks each face alone against its own normals, so
// Formula 1 folded neighbouring faces onto each other on closed meshes (each face turning less than
// 90 degrees, in opposite directions: 18 folded pairs on the spot at 10 % before the fold guard).
// No collapse may fold two faces around the kept position by more than 143 degrees where they were
// not before, whatever the cost.
TEST(EdgeCollapse, NoTwoAdjacentFacesFoldOntoEachOtherOnClosedMeshes) {
    Result<Mesh> spot = load_obj(HMDNODE_SOURCE_DIR "/data/meshes/spot.obj");
    ASSERT_TRUE(spot.ok()) << spot.error().message;
    Primitive bumpy = sphere(4);  // 5 120 triangles
    for (glm::vec3& v : bumpy.positions) {
        v *= 1.0f + 0.15f * std::sin(5.0f * v.x) * std::cos(4.0f * v.y) * std::sin(3.0f * v.z);
    }
    const std::pair<const char*, const Primitive*> meshes[] = {{"spot", &spot->primitives[0]},
                                                               {"bumpy sphere", &bumpy}};
    for (const auto& [name, in] : meshes) {
        ASSERT_EQ(folded_pairs(*in), 0u) << name;
        const size_t count = in->triangle_count();
        for (const char* algorithm : kAlgorithms) {
            const size_t targets[] = {count / 10, count / 100};
            Result<std::vector<SimplifiedLevel>> r = simplify(*in, algorithm, targets);
            ASSERT_TRUE(r.ok()) << r.error().message;
            for (size_t l = 0; l < 2; ++l) {
                const Primitive& out = (*r)[l].primitive;
                // note: at 1 % formula1 stops above the spot's target (58 faces), at 98, where
                // every collapse left would fold two faces; it still comes down to under 3 %.
                if (l == 0) {
                    EXPECT_LE(out.triangle_count(), targets[l]) << name << " " << algorithm;
                } else {
                    EXPECT_LT(out.triangle_count(), count * 3 / 100) << name << " " << algorithm;
                }
                EXPECT_EQ(folded_pairs(out), 0u)
                    << name << " " << algorithm << " at " << targets[l] << " faces";
            }
        }
    }
}

// A defect found on real meshes (texture drift): a merged vertex takes its attributes where it
// lies. On a height field z = h(x, y) with uv0 = (x, y), qem merges free positions at points off
// their edge; the attributes come from the barycentric coordinates of the point projected into the
// face around the two endpoints that contains it, so uv0 stays (x, y) of the vertex up to the
// projection along the face normal (|uv0 - (x, y)| <= distance to the face's plane times its slope:
// at most 8e-4 here). The parameter of the point projected on the edge drifted by 0.013 to 0.034
// (an edge is 0.031).
TEST(EdgeCollapse, MergedVertexTakesItsAttributesWhereItLies) {
    Primitive in =
        grid(32, [](float x, float y) { return 0.08f * std::sin(4.0f * x) * std::cos(3.0f * y); });
    for (const glm::vec3& v : in.positions) in.uv0.emplace_back(v.x, v.y);
    for (const char* algorithm : {"qem", "curvature-qem"}) {
        for (size_t target : {size_t(400), size_t(100)}) {
            const Primitive out = simplify_one(in, algorithm, target);
            ASSERT_EQ(out.uv0.size(), out.positions.size());
            double worst = 0.0;
            for (size_t i = 0; i < out.positions.size(); ++i) {
                const double d = glm::length(glm::dvec2(out.uv0[i]) -
                                             glm::dvec2(out.positions[i].x, out.positions[i].y));
                worst = std::max(worst, d);
            }
            EXPECT_LT(worst, 2e-3) << algorithm << " at " << target << " faces";
        }
    }
}

TEST(EdgeCollapse, RejectsBadArguments) {
    const Primitive in = flat_grid(4);
    const size_t ok[] = {10};
    EXPECT_FALSE(simplify(in, "no-such-algorithm", ok).ok());
    const size_t zero[] = {0};
    EXPECT_FALSE(simplify(in, "qem", zero).ok());
    const size_t increasing[] = {5, 10};
    EXPECT_FALSE(simplify(in, "qem", increasing).ok());
    const size_t too_many[] = {32};
    EXPECT_FALSE(simplify(in, "qem", too_many).ok());
    EXPECT_FALSE(simplify(Primitive{}, "qem", ok).ok());
    Primitive bad = in;
    bad.indices[4] = 999;
    Result<std::vector<SimplifiedLevel>> r = simplify(bad, "qem", ok);
    ASSERT_FALSE(r.ok());
    EXPECT_NE(r.error().message.find("index 4"), std::string::npos) << r.error().message;
    for (const char* name : kAlgorithms) {
        const AlgorithmInfo* info = find_simplification_algorithm(name);
        ASSERT_NE(info, nullptr) << name;
        EXPECT_TRUE(info->edge_collapse);
    }
}

}  // namespace
}  // namespace hmdnode
