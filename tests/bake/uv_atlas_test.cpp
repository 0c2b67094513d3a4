#include "hmdnode/bake/uv_atlas.hpp"

#include <chrono>
#include <cstdio>
#include <filesystem>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <map>
#include <numbers>
#include <numeric>
#include <random>

#include <gtest/gtest.h>
#include <glm/gtc/matrix_transform.hpp>

#include "hmdnode/core/obj.hpp"

namespace hmdnode {
namespace {

constexpr double kPi = std::numbers::pi;

// Unit cube [-0.5, 0.5]^3 with 8 shared vertices (so the segmentation, not the indexing, has to
// find the 6 faces), outward winding.
Primitive cube(double half = 0.5) {
    Primitive p;
    for (int i = 0; i < 8; ++i)
        p.positions.push_back(glm::vec3(float((i & 1) ? half : -half),
                                        float((i & 2) ? half : -half),
                                        float((i & 4) ? half : -half)));
    const uint32_t q[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                              {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
    for (const auto& f : q) {
        for (uint32_t i : {f[0], f[1], f[2], f[0], f[2], f[3]}) p.indices.push_back(i);
    }
    return p;
}

// Latitude-longitude sphere of radius r, shared vertices (poles single), with normals and uv0.
Primitive sphere(float r, int rings, int segments, double max_polar = kPi) {
    Primitive p;
    p.positions.push_back({0.0f, 0.0f, r});
    p.normals.push_back({0.0f, 0.0f, 1.0f});
    p.uv0.push_back({0.0f, 0.0f});
    for (int i = 1; i <= rings; ++i) {
        const double th = max_polar * i / rings;
        for (int j = 0; j < segments; ++j) {
            const double ph = 2.0 * kPi * j / segments;
            glm::vec3 n(float(std::sin(th) * std::cos(ph)), float(std::sin(th) * std::sin(ph)),
                        float(std::cos(th)));
            if (i == rings && max_polar >= kPi) break;
            p.positions.push_back(n * r);
            p.normals.push_back(n);
            p.uv0.push_back({float(j) / segments, float(i) / rings});
        }
    }
    const bool closed = max_polar >= kPi;
    const int full_rings = closed ? rings - 1 : rings;
    auto at = [&](int i, int j) { return uint32_t(1 + (i - 1) * segments + (j % segments)); };
    for (int j = 0; j < segments; ++j) {
        for (uint32_t v : {0u, at(1, j), at(1, j + 1)}) p.indices.push_back(v);
    }
    for (int i = 1; i < full_rings; ++i)
        for (int j = 0; j < segments; ++j) {
            for (uint32_t v : {at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j), at(i + 1, j + 1),
                               at(i, j + 1)})
                p.indices.push_back(v);
        }
    if (closed) {
        p.positions.push_back({0.0f, 0.0f, -r});
        p.normals.push_back({0.0f, 0.0f, -1.0f});
        p.uv0.push_back({0.0f, 1.0f});
        const uint32_t s = uint32_t(p.positions.size() - 1);
        for (int j = 0; j < segments; ++j) {
            for (uint32_t v : {at(full_rings, j), s, at(full_rings, j + 1)}) p.indices.push_back(v);
        }
    }
    return p;
}

// An n x n grid over [0, size]^2 in the plane z = 0 (facing +z), vertices jittered inside.
Primitive grid(int n, float size, float jitter = 0.0f, unsigned seed = 1) {
    Primitive p;
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(-jitter, jitter);
    for (int y = 0; y <= n; ++y)
        for (int x = 0; x <= n; ++x) {
            glm::vec3 v(size * x / n, size * y / n, 0.0f);
            if (x > 0 && x < n && y > 0 && y < n)
                v += glm::vec3(u(rng), u(rng), 0.0f) * size / float(n);
            p.positions.push_back(v);
        }
    for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
            uint32_t a = uint32_t(y * (n + 1) + x), b = a + 1, c = a + uint32_t(n + 1), d = c + 1;
            for (uint32_t v : {a, b, d, a, d, c}) p.indices.push_back(v);
        }
    return p;
}

int add_mesh(Scene& s, const std::string& name, Primitive prim, glm::dvec3 t, double scale = 1.0) {
    Mesh m;
    m.name = name;
    m.primitives.push_back(std::move(prim));
    s.meshes.push_back(std::move(m));
    Node n;
    n.name = name;
    n.translation = t;
    n.scale = glm::dvec3(scale);
    n.mesh = int(s.meshes.size()) - 1;
    s.nodes.push_back(n);
    s.roots.push_back(int(s.nodes.size()) - 1);
    return n.mesh;
}

ChartMesh to_chart(const Primitive& p) {
    ChartMesh c;
    for (auto v : p.positions) c.positions.push_back(glm::dvec3(v));
    c.indices = p.indices;
    return c;
}

double tri_area3(const Primitive& p, size_t f) {
    glm::dvec3 a(p.positions[p.indices[3 * f]]), b(p.positions[p.indices[3 * f + 1]]),
        c(p.positions[p.indices[3 * f + 2]]);
    return 0.5 * glm::length(glm::cross(b - a, c - a));
}
// Signed area in texels (x right, y down as stored).
double tri_area_uv(const Primitive& p, size_t f, double W, double H) {
    glm::dvec2 a(p.uv1[p.indices[3 * f]]), b(p.uv1[p.indices[3 * f + 1]]),
        c(p.uv1[p.indices[3 * f + 2]]);
    a *= glm::dvec2(W, H), b *= glm::dvec2(W, H), c *= glm::dvec2(W, H);
    return 0.5 * ((b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x));
}

// Conservative triangle/texel overlap (separating axes: the box's two and the triangle's three).
// The texel is shrunk by 1e-3 so that float rounding of uv1 (stored as float uv, not texels) on a
// texel edge does not count as touching the neighbour.
bool overlaps(const glm::dvec2 t[3], double x, double y) {
    const double e = 1e-3, x0 = x + e, y0 = y + e, s = 1.0 - 2.0 * e;
    const glm::dvec2 box[4] = {{x0, y0}, {x0 + s, y0}, {x0, y0 + s}, {x0 + s, y0 + s}};
    glm::dvec2 lo = glm::min(t[0], glm::min(t[1], t[2])), hi = glm::max(t[0], glm::max(t[1], t[2]));
    if (hi.x <= x0 || lo.x >= x0 + s || hi.y <= y0 || lo.y >= y0 + s) return false;
    for (int e = 0; e < 3; ++e) {
        const glm::dvec2 d = t[(e + 1) % 3] - t[e];
        const glm::dvec2 n(-d.y, d.x);
        const double third = glm::dot(n, t[(e + 2) % 3] - t[e]);
        if (third == 0.0) continue;
        bool all_out = true;
        for (const auto& c : box)
            if (glm::dot(n, c - t[e]) * third > 0.0) all_out = false;
        if (all_out) return false;
    }
    return true;
}

// Checks every chart of every lightmapped primitive: integer origins, no overlap, padding,
// orientation; returns the number of charts found.
size_t check_atlas(const Scene& s, const AtlasReport& r, int padding) {
    std::map<int, size_t> atlas_of_texture;
    for (size_t a = 0; a < r.textures.size(); ++a) atlas_of_texture[r.textures[a]] = a;
    std::vector<std::vector<int>> owner(r.textures.size());
    for (size_t a = 0; a < r.textures.size(); ++a)
        owner[a].assign(size_t(r.widths[a]) * size_t(r.heights[a]), -1);
    int next_chart = 0;
    for (const Mesh& m : s.meshes)
        for (const Primitive& p : m.primitives) {
            if (p.uv1.empty()) continue;
            const int tex = s.materials[size_t(p.material)].lightmap.texture;
            if (!atlas_of_texture.count(tex)) continue;
            const size_t a = atlas_of_texture[tex];
            const int W = r.widths[a], H = r.heights[a];
            // Charts = components of triangles joined through vertices with identical uv1.
            std::map<std::pair<float, float>, size_t> key;
            std::vector<size_t> parent(p.positions.size());
            std::iota(parent.begin(), parent.end(), size_t(0));
            auto find = [&](size_t x) {
                while (parent[x] != x) x = parent[x] = parent[parent[x]];
                return x;
            };
            for (size_t v = 0; v < p.uv1.size(); ++v) {
                auto [it, ins] = key.emplace(std::make_pair(p.uv1[v].x, p.uv1[v].y), v);
                if (!ins) parent[find(v)] = find(it->second);
            }
            for (size_t f = 0; f < p.triangle_count(); ++f) {
                parent[find(p.indices[3 * f + 1])] = find(p.indices[3 * f]);
                parent[find(p.indices[3 * f + 2])] = find(p.indices[3 * f]);
            }
            std::map<size_t, int> chart_id;
            std::map<int, glm::dvec2> chart_min;
            for (size_t f = 0; f < p.triangle_count(); ++f) {
                const size_t root = find(p.indices[3 * f]);
                if (!chart_id.count(root)) chart_id[root] = next_chart++;
                const int c = chart_id[root];
                glm::dvec2 t[3];
                for (int k = 0; k < 3; ++k)
                    t[k] = glm::dvec2(p.uv1[p.indices[3 * f + k]]) * glm::dvec2(W, H);
                auto it = chart_min.find(c);
                glm::dvec2 lo = glm::min(t[0], glm::min(t[1], t[2]));
                chart_min[c] = it == chart_min.end() ? lo : glm::min(it->second, lo);
                if (tri_area3(p, f) > 1e-9) {
                    EXPECT_GT(tri_area_uv(p, f, W, H), 0.0) << "flipped triangle " << f;
                }
                glm::dvec2 hi = glm::max(t[0], glm::max(t[1], t[2]));
                for (int y = int(std::floor(lo.y)); y <= int(std::floor(hi.y)); ++y)
                    for (int x = int(std::floor(lo.x)); x <= int(std::floor(hi.x)); ++x) {
                        if (!overlaps(t, double(x), double(y))) continue;
                        const bool inside = x >= padding / 2 && y >= padding / 2 &&
                                            x < W - padding / 2 && y < H - padding / 2;
                        EXPECT_TRUE(inside) << "chart texel " << x << "," << y << " in the border";
                        if (!inside) continue;
                        int& o = owner[a][size_t(y) * size_t(W) + size_t(x)];
                        EXPECT_TRUE(o == -1 || o == c) << "texel " << x << "," << y << " shared";
                        o = c;
                    }
            }
            for (auto& [c, lo] : chart_min) {
                EXPECT_NEAR(lo.x, std::round(lo.x), 1e-3);
                EXPECT_NEAR(lo.y, std::round(lo.y), 1e-3);
            }
        }
    // Injectivity inside charts too: no triangle's uv centroid lies strictly inside another
    // triangle of the same primitive (a fold or overlap of LSCM would put some there).
    for (const Mesh& m : s.meshes)
        for (const Primitive& p : m.primitives) {
            if (p.uv1.empty()) continue;
            const int tex = s.materials[size_t(p.material)].lightmap.texture;
            if (!atlas_of_texture.count(tex)) continue;
            const size_t a = atlas_of_texture[tex];
            const glm::dvec2 size(r.widths[a], r.heights[a]);
            const double cell = 2.0;
            std::map<std::pair<int, int>, std::vector<size_t>> grid;
            auto corner = [&](size_t f, int k) {
                return glm::dvec2(p.uv1[p.indices[3 * f + k]]) * size;
            };
            for (size_t f = 0; f < p.triangle_count(); ++f) {
                glm::dvec2 lo = glm::min(corner(f, 0), glm::min(corner(f, 1), corner(f, 2)));
                glm::dvec2 hi = glm::max(corner(f, 0), glm::max(corner(f, 1), corner(f, 2)));
                for (int y = int(lo.y / cell); y <= int(hi.y / cell); ++y)
                    for (int x = int(lo.x / cell); x <= int(hi.x / cell); ++x)
                        grid[{x, y}].push_back(f);
            }
            size_t inside_other = 0;
            for (size_t f = 0; f < p.triangle_count(); ++f) {
                const glm::dvec2 c = (corner(f, 0) + corner(f, 1) + corner(f, 2)) / 3.0;
                for (size_t g : grid[{int(c.x / cell), int(c.y / cell)}]) {
                    if (g == f) continue;
                    const glm::dvec2 A = corner(g, 0), B = corner(g, 1), C = corner(g, 2);
                    const double d = (B.x - A.x) * (C.y - A.y) - (B.y - A.y) * (C.x - A.x);
                    if (std::abs(d) < 1e-12) continue;
                    const double u = ((c.x - A.x) * (C.y - A.y) - (c.y - A.y) * (C.x - A.x)) / d;
                    const double v = ((B.x - A.x) * (c.y - A.y) - (B.y - A.y) * (c.x - A.x)) / d;
                    if (u > 1e-6 && v > 1e-6 && 1.0 - u - v > 1e-6) ++inside_other;
                }
            }
            EXPECT_EQ(inside_other, 0u) << "overlapping triangles in mesh " << m.name;
        }
    // Padding: no texel of another chart within `padding` texels (Chebyshev).
    for (size_t a = 0; a < owner.size(); ++a) {
        const int W = r.widths[a], H = r.heights[a];
        for (int y = 0; y < H; ++y)
            for (int x = 0; x < W; ++x) {
                const int c = owner[a][size_t(y) * size_t(W) + size_t(x)];
                if (c < 0) continue;
                for (int dy = -padding; dy <= padding; ++dy)
                    for (int dx = -padding; dx <= padding; ++dx) {
                        const int xx = x + dx, yy = y + dy;
                        if (xx < 0 || yy < 0 || xx >= W || yy >= H) continue;
                        const int o = owner[a][size_t(yy) * size_t(W) + size_t(xx)];
                        if (o >= 0 && o != c) {
                            ADD_FAILURE() << "charts " << c << " and " << o << " closer than "
                                          << padding << " texels at " << x << "," << y;
                            return size_t(next_chart);
                        }
                    }
            }
    }
    return size_t(next_chart);
}

TEST(UvCharts, CubeWithSharedVerticesSplitsIntoSixFaces) {
    Primitive c = cube();
    int count = 0;
    std::vector<int> id = segment_charts(c.positions, c.indices, 60.0, 0, &count);
    EXPECT_EQ(count, 6);
    for (size_t f = 0; f < 12; f += 2) EXPECT_EQ(id[f], id[f + 1]);  // both halves of a face
}

TEST(Lscm, PlanarChartIsAnIsometry) {
    Primitive g = grid(12, 2.0f, 0.3f);
    // Tilt it out of any axis plane.
    const glm::dmat3 rot = glm::dmat3(glm::rotate(glm::dmat4(1.0), 0.7, glm::dvec3(1, 2, 3)));
    ChartMesh c = to_chart(g);
    for (auto& p : c.positions) p = rot * p + glm::dvec3(3, -1, 2);
    auto uv = lscm_parameterise(c);
    ASSERT_TRUE(uv.ok()) << uv.error().message;
    ParamQuality q = measure_parameterisation(c, *uv);
    EXPECT_NEAR(q.area_ratio, 1.0, 1e-9);
    EXPECT_NEAR(q.mean_conformal, 1.0, 1e-6);
    EXPECT_NEAR(q.max_stretch, 1.0, 1e-6);
    EXPECT_NEAR(q.min_stretch, 1.0, 1e-6);
    EXPECT_EQ(q.flipped, 0u);
    // Distances are preserved: compare a long diagonal.
    const size_t a = 0, b = c.positions.size() - 1;
    EXPECT_NEAR(glm::length((*uv)[a] - (*uv)[b]), glm::length(c.positions[a] - c.positions[b]),
                1e-6);
}

TEST(Lscm, HemisphereCapHasLowConformalDistortion) {
    Primitive cap = sphere(1.0f, 16, 48, kPi / 2.0);
    ChartMesh c = to_chart(cap);
    auto uv = lscm_parameterise(c);
    ASSERT_TRUE(uv.ok()) << uv.error().message;
    ParamQuality q = measure_parameterisation(c, *uv);
    EXPECT_EQ(q.flipped, 0u);
    EXPECT_LT(q.mean_conformal, 1.05) << "LSCM angle distortion";
    // The orthogonal projection of the same cap is far from conformal near its rim.
    ParamQuality qp = measure_parameterisation(c, planar_parameterise(c));
    EXPECT_GT(qp.mean_conformal, 1.3);
    EXPECT_NEAR(q.area_ratio, 1.0, 1e-9);  // rescaled to the 3D area
    EXPECT_EQ(q.overlapping, 0u);
}

TEST(Lscm, QualityCountsOverlapsAndFlips) {
    // Two disjoint 3D triangles whose uvs overlap, then one mirrored.
    ChartMesh c;
    c.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {5, 0, 0}, {6, 0, 0}, {5, 1, 0}};
    c.indices = {0, 1, 2, 3, 4, 5};
    std::vector<glm::dvec2> uv = {{0, 0}, {1, 0}, {0, 1}, {0.1, 0.1}, {1.1, 0.1}, {0.1, 1.1}};
    ParamQuality q = measure_parameterisation(c, uv);
    EXPECT_EQ(q.overlapping, 2u);
    EXPECT_EQ(q.flipped, 0u);
    uv = {{0, 0}, {1, 0}, {0, 1}, {5, 0}, {5, 1}, {6, 0}};
    q = measure_parameterisation(c, uv);
    EXPECT_EQ(q.overlapping, 0u);
    EXPECT_EQ(q.flipped, 1u);
}

struct AtlasScene {
    Scene s;
    AtlasScene() {
        add_mesh(s, "box", cube(0.5), {0, 0, 0});
        add_mesh(s, "ball", sphere(0.6f, 12, 24), {2, 0, 0});
        add_mesh(s, "floor", grid(4, 2.0f, 0.2f), {0, -1, 0}, 2.0);  // node scale 2: 4 m
        for (auto& m : s.meshes) {
            Material mat;
            mat.name = m.name;
            s.materials.push_back(mat);
            m.primitives[0].material = int(s.materials.size()) - 1;
        }
    }
};

TEST(UvAtlas, UniformDensityNoOverlapPaddingNoFlips) {
    AtlasScene as;
    AtlasOptions o;
    o.texels_per_metre = 40.0;
    o.padding_texels = 3;
    auto r = build_uv_atlas(as.s, o);
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_EQ(r->primitives, 3u);
    EXPECT_GE(r->charts, 6u + 1u + 4u);
    ASSERT_EQ(r->atlases, 1u);
    const double W = r->widths[0], H = r->heights[0];
    EXPECT_LE(W, 1024);
    EXPECT_GT(r->utilisation, 0.3);
    EXPECT_LE(r->utilisation, 1.0);
    const double scale[3] = {1.0, 1.0, 2.0};
    std::mt19937 rng(7);
    for (size_t m = 0; m < 3; ++m) {
        const Primitive& p = as.s.meshes[m].primitives[0];
        ASSERT_EQ(p.uv1.size(), p.positions.size());
        EXPECT_EQ(as.s.materials[size_t(p.material)].lightmap.texture, r->textures[0]);
        EXPECT_EQ(as.s.materials[size_t(p.material)].lightmap.tex_coord, 1);
        if (m == 1) {
            EXPECT_EQ(p.normals.size(), p.positions.size());
            EXPECT_EQ(p.uv0.size(), p.positions.size());
        }
        // Whole-mesh density is exact; per triangle it is exact on flat charts and within the
        // LSCM area distortion on the ball.
        double a3 = 0.0, a2 = 0.0;
        for (size_t f = 0; f < p.triangle_count(); ++f) {
            a3 += tri_area3(p, f) * scale[m] * scale[m];
            a2 += tri_area_uv(p, f, W, H);
        }
        EXPECT_NEAR(std::sqrt(a2 / a3), o.texels_per_metre, 0.01 * o.texels_per_metre)
            << as.s.meshes[m].name;
        std::uniform_int_distribution<size_t> pick(0, p.triangle_count() - 1);
        for (int k = 0; k < 20; ++k) {
            const size_t f = pick(rng);
            const double d = std::sqrt(tri_area_uv(p, f, W, H) / tri_area3(p, f)) / scale[m];
            EXPECT_NEAR(d, o.texels_per_metre, (m == 1 ? 0.2 : 0.001) * o.texels_per_metre)
                << as.s.meshes[m].name << " triangle " << f;
        }
    }
    EXPECT_GE(check_atlas(as.s, *r, o.padding_texels), r->charts);
}

TEST(UvAtlas, SeveralAtlasesWhenOneIsFull) {
    AtlasScene as;
    AtlasOptions o;
    o.texels_per_metre = 40.0;
    o.max_atlas_size = 128;  // the floor alone (160 texels) would not fit: use a smaller one
    as.s.meshes[2].primitives[0] = grid(4, 1.0f);
    auto r = build_uv_atlas(as.s, o);
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_GE(r->atlases, 2u);
    for (size_t a = 0; a < r->atlases; ++a) {
        EXPECT_LE(r->widths[a], 128);
        EXPECT_LE(r->heights[a], 128);
    }
    check_atlas(as.s, *r, o.padding_texels);
    // Every primitive (including those split across atlases) points at one of the atlases.
    size_t prims = 0;
    for (const auto& m : as.s.meshes)
        for (const auto& p : m.primitives) {
            ++prims;
            EXPECT_EQ(p.uv1.size(), p.positions.size());
            const int tex = as.s.materials[size_t(p.material)].lightmap.texture;
            EXPECT_NE(std::find(r->textures.begin(), r->textures.end(), tex), r->textures.end());
        }
    EXPECT_GE(prims, 3u);
}

// A whole closed sphere offered as one chart (cone 180 degrees): LSCM cannot flatten a closed
// surface without folding, so the chart is cut until every part maps without flips.
TEST(UvAtlas, FoldedLscmChartsAreSplit) {
    Scene s;
    add_mesh(s, "ball", sphere(0.5f, 16, 32), {0, 0, 0});
    AtlasOptions o;
    o.texels_per_metre = 64.0;
    o.chart_angle_deg = 180.0;
    auto r = build_uv_atlas(s, o);
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_GT(r->split_charts, 0u);
    EXPECT_GE(r->charts, 2u);
    check_atlas(s, *r, o.padding_texels);
    std::printf("closed sphere as one chart: %zu charts after %zu splits, mean conformal %.3f\n",
                r->charts, r->split_charts, r->mean_conformal_distortion);
}

TEST(UvAtlas, InstancesGetTheirOwnTexels) {
    Scene s;
    add_mesh(s, "crate", cube(), {0, 0, 0});
    Node second = s.nodes[0];
    second.translation = {3, 0, 0};
    second.scale = glm::dvec3(2.0);
    s.nodes.push_back(second);
    s.roots.push_back(1);
    std::vector<int> asked;
    AtlasOptions o;
    o.lightmapped = [&](int mesh, int) {
        asked.push_back(mesh);
        return true;
    };
    auto r = build_uv_atlas(s, o);
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_EQ(r->unshared_instances, 1u);
    ASSERT_EQ(s.meshes.size(), 2u);
    EXPECT_EQ(s.nodes[0].mesh, 0);
    EXPECT_EQ(s.nodes[1].mesh, 1);
    EXPECT_EQ(s.meshes[1].name, "crate_instance1");
    for (int m : asked) EXPECT_EQ(m, 0);  // the copy is asked as the mesh it copies
    EXPECT_EQ(check_atlas(s, *r, o.padding_texels), 12u);  // 6 faces per instance, no overlap
    // The second instance is twice as large in the world: 4x the texels.
    double a0 = 0.0, a1 = 0.0;
    for (size_t f = 0; f < 12; ++f) {
        a0 += tri_area_uv(s.meshes[0].primitives[0], f, r->widths[0], r->heights[0]);
        a1 += tri_area_uv(s.meshes[1].primitives[0], f, r->widths[0], r->heights[0]);
    }
    EXPECT_NEAR(a1 / a0, 4.0, 1e-3);
}

TEST(UvAtlas, ChartTooLargeIsAClearError) {
    Scene s;
    add_mesh(s, "big_wall", grid(2, 100.0f), {0, 0, 0});
    AtlasOptions o;
    o.texels_per_metre = 64.0;
    o.max_atlas_size = 1024;
    auto r = build_uv_atlas(s, o);
    ASSERT_FALSE(r.ok());
    EXPECT_NE(r.error().message.find("big_wall"), std::string::npos) << r.error().message;
    EXPECT_NE(r.error().message.find("texels per metre"), std::string::npos) << r.error().message;
    EXPECT_TRUE(s.meshes[0].primitives[0].uv1.empty());
    EXPECT_TRUE(s.textures.empty());
}

// Several charts too large: the suggestion comes from the largest (a 100 m wall, not the 30 m
// one first in the scene), so that a rerun at the suggested density fits.
TEST(UvAtlas, ChartTooLargeSuggestsTheDensityOfTheLargestChart) {
    auto walls = [] {
        Scene s;
        add_mesh(s, "wall_30m", grid(2, 30.0f), {0, 0, 0});
        add_mesh(s, "wall_100m", grid(2, 100.0f), {0, 0, 200});
        return s;
    };
    Scene s = walls();
    AtlasOptions o;
    o.texels_per_metre = 64.0;
    o.max_atlas_size = 1024;
    auto r = build_uv_atlas(s, o);
    ASSERT_FALSE(r.ok());
    const std::string& msg = r.error().message;
    EXPECT_NE(msg.find("2 charts do not fit"), std::string::npos) << msg;
    EXPECT_NE(msg.find("wall_100m"), std::string::npos) << msg;
    // at most (1024 - padding - 1) / 100 m texels per metre
    const size_t at = msg.find("use at most ");
    ASSERT_NE(at, std::string::npos) << msg;
    const double suggested = std::atof(msg.c_str() + at + 12);
    EXPECT_GT(suggested, 10.0);
    EXPECT_LE(suggested, 1021.0 / 100.0);
    Scene again = walls();
    o.texels_per_metre = suggested;
    auto fits = build_uv_atlas(again, o);
    EXPECT_TRUE(fits.ok()) << fits.error().message;
}

TEST(UvAtlas, KeepsExistingUv1AndClonesSharedMaterials) {
    Scene s;
    Material shared;
    shared.name = "shared";
    s.materials.push_back(shared);
    add_mesh(s, "lit", cube(), {0, 0, 0});
    add_mesh(s, "vertex_coloured", cube(), {2, 0, 0});
    Primitive with_uv1 = grid(1, 1.0f);
    with_uv1.uv1 = {{0.1f, 0.1f}, {0.2f, 0.1f}, {0.1f, 0.2f}, {0.2f, 0.2f}};
    add_mesh(s, "authored", with_uv1, {0, 2, 0});
    for (auto& m : s.meshes) m.primitives[0].material = 0;
    AtlasOptions o;
    o.lightmapped = [](int mesh, int) { return mesh != 1; };
    auto r = build_uv_atlas(s, o);
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_EQ(r->primitives, 1u);
    EXPECT_EQ(r->kept_primitives, 1u);
    EXPECT_EQ(r->kept_without_lightmap.size(), 1u);
    EXPECT_EQ(s.meshes[2].primitives[0].uv1[1], glm::vec2(0.2f, 0.1f));
    EXPECT_TRUE(s.meshes[1].primitives[0].uv1.empty());
    EXPECT_EQ(s.materials[0].lightmap.texture, -1);  // still used without a lightmap
    const int lit = s.meshes[0].primitives[0].material;
    EXPECT_NE(lit, 0);
    EXPECT_EQ(s.materials[size_t(lit)].lightmap.texture, r->textures[0]);
    EXPECT_EQ(s.textures[size_t(r->textures[0])].rgba8.size(),
              size_t(r->widths[0]) * size_t(r->heights[0]) * 4);
}

TEST(UvAtlas, RejectsNonFinitePositions) {
    Scene s;
    Primitive c = cube();
    c.positions[3].y = std::nanf("");
    add_mesh(s, "broken", c, {0, 0, 0});
    auto r = build_uv_atlas(s, AtlasOptions{});
    ASSERT_FALSE(r.ok());
    EXPECT_NE(r.error().message.find("vertex 3"), std::string::npos) << r.error().message;
}

// The bundled meshes (data/meshes: bunny, spot, fandisk), each scaled to a 1 m bounding-box
// diagonal, at 256 texels per metre: the figures docs/baking.md quotes, plus the same invariants as
// above.
TEST(UvAtlas, SharedMeshes) {
    const std::filesystem::path dir = std::filesystem::path(HMDNODE_SOURCE_DIR) / "data" / "meshes";
    if (!std::filesystem::exists(dir / "spot.obj")) FAIL() << "no meshes in " << dir;
    for (const char* name : {"spot", "fandisk", "stanford-bunny"}) {
        auto mesh = load_obj(dir / (std::string(name) + ".obj"));
        ASSERT_TRUE(mesh.ok()) << mesh.error().message;
        glm::vec3 lo(1e30f), hi(-1e30f);
        for (auto& v : mesh->primitives[0].positions) lo = glm::min(lo, v), hi = glm::max(hi, v);
        const double scale = 1.0 / glm::length(hi - lo);
        Scene s;
        const size_t tris = mesh->primitives[0].triangle_count();
        add_mesh(s, name, mesh->primitives[0], {0, 0, 0}, scale);
        AtlasOptions o;
        o.texels_per_metre = 256.0;
        const auto t0 = std::chrono::steady_clock::now();
        auto r = build_uv_atlas(s, o);
        const double ms =
            std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0)
                .count();
        ASSERT_TRUE(r.ok()) << r.error().message;
        std::printf(
            "%-15s %6zu triangles: %4zu charts (%zu planar, %zu LSCM, %zu re-split), %zu "
            "atlas %d x %d, utilisation %.1f %%, vertices %zu -> %zu, mean conformal "
            "distortion %.3f, %.0f ms\n",
            name, tris, r->charts, r->planar_charts, r->lscm_charts, r->split_charts, r->atlases,
            r->widths[0], r->heights[0], 100.0 * r->utilisation, r->vertices_before,
            r->vertices_after, r->mean_conformal_distortion, ms);
        EXPECT_LT(r->mean_conformal_distortion, 1.2) << name;
        EXPECT_GT(r->utilisation, 0.3) << name;
        check_atlas(s, *r, o.padding_texels);
        const Primitive& p = s.meshes[0].primitives[0];
        double a3 = 0.0, a2 = 0.0;
        for (const auto& m : s.meshes)
            for (const auto& q : m.primitives) {
                const auto tex = s.materials[size_t(q.material)].lightmap.texture;
                size_t atlas = 0;
                while (r->textures[atlas] != tex) ++atlas;
                for (size_t f = 0; f < q.triangle_count(); ++f) {
                    a3 += tri_area3(q, f) * scale * scale;
                    a2 += tri_area_uv(q, f, r->widths[atlas], r->heights[atlas]);
                }
            }
        EXPECT_NEAR(std::sqrt(a2 / a3), o.texels_per_metre, 0.01 * o.texels_per_metre) << name;
        (void)p;
    }
}

}  // namespace
}  // namespace hmdnode
