// The demo scene generator behind `hmdnode scene demo` (docs/demo-scene.md): room geometry with a
// packed lightmap atlas, source meshes from OBJ, LOD chains by QEM with measured error,
// path-traced bake, .glb. An offline tool step: the runtime library does not contain it.
#include "tool/demo_scene.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <string>
#include <vector>

#include <glm/gtc/quaternion.hpp>

#include "hmdnode/bake/bake.hpp"
#include "hmdnode/core/gltf.hpp"
#include "hmdnode/core/obj.hpp"
#include "hmdnode/lod/mesh_distance.hpp"
#include "hmdnode/lod/simplify.hpp"
#include "hmdnode/lod/vertex_clustering.hpp"

namespace hmdnode {
namespace {

namespace fs = std::filesystem;

// Room: x and z in [-3, 3], floor at y = 0, ceiling at y = 3.
constexpr float kHalf = 3.0f, kHeight = 3.0f;
constexpr int kAtlasSize = 512;
constexpr int kChartPadding = 2;  // texels between charts and around the atlas
constexpr float kMaxTexelsPerM = 40.0f;
// Lighting: two shaded pendant lamps; the shades keep the ceiling out of the direct light so the
// 8-bit lightmap's range (set by its brightest texel) is spent on what the viewer looks at.
constexpr float kLampIntensityCd = 11.0f;
constexpr float kLampY = 2.5f;
// MSFT_screencoverage: level k is good enough while its error projects under kToleranceScreen of
// the screen height (1 px of 1000).
constexpr double kToleranceScreen = 1e-3;

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) {
    return std::chrono::duration<double>(Clock::now() - t0).count();
}

struct Chart {
    float width_m = 0, height_m = 0;
    int w = 0, h = 0, x = 0, y = 0;  // texels
};

// Shelf packing, tallest first, each chart into the first shelf with room; false if they do not
// fit.
bool pack_charts(std::vector<Chart>* charts, float texels_per_m) {
    std::vector<size_t> order(charts->size());
    for (size_t i = 0; i < order.size(); ++i) {
        Chart& c = (*charts)[i];
        c.w = std::max(1, int(std::ceil(c.width_m * texels_per_m - 1e-4f)));
        c.h = std::max(1, int(std::ceil(c.height_m * texels_per_m - 1e-4f)));
        order[i] = i;
    }
    std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) {
        const Chart &ca = (*charts)[a], &cb = (*charts)[b];
        return ca.h != cb.h ? ca.h > cb.h : ca.w > cb.w;
    });
    struct Shelf {
        int y, h, x;
    };
    std::vector<Shelf> shelves;
    int next_y = kChartPadding;
    for (size_t i : order) {
        Chart& c = (*charts)[i];
        Shelf* shelf = nullptr;
        for (Shelf& s : shelves)
            if (s.h >= c.h && s.x + c.w + kChartPadding <= kAtlasSize) {
                shelf = &s;
                break;
            }
        if (!shelf) {
            if (next_y + c.h + kChartPadding > kAtlasSize || c.w + 2 * kChartPadding > kAtlasSize)
                return false;
            shelves.push_back(Shelf{next_y, c.h, kChartPadding});
            next_y += c.h + kChartPadding;
            shelf = &shelves.back();
        }
        c.x = shelf->x;
        c.y = shelf->y;
        shelf->x += c.w + kChartPadding;
    }
    return true;
}

class Builder {
  public:
    Scene scene;
    std::vector<Chart> charts;

    int material(const std::string& name, glm::vec3 srgb_like_linear, bool lightmapped,
                 bool double_sided = false) {
        Material m;
        m.name = name;
        m.base_color_factor = glm::vec4(srgb_like_linear, 1.0f);
        m.double_sided = double_sided;
        if (lightmapped) {
            m.lightmap.texture = 0;
            m.lightmap.tex_coord = 1;
        }
        scene.materials.push_back(m);
        return int(scene.materials.size()) - 1;
    }

    int mesh(const std::string& name) {
        Mesh m;
        m.name = name;
        scene.meshes.push_back(m);
        return int(scene.meshes.size()) - 1;
    }

    int primitive(int mesh, int material) {
        Primitive p;
        p.material = material;
        scene.meshes[mesh].primitives.push_back(p);
        return int(scene.meshes[mesh].primitives.size()) - 1;
    }

    // A quad o, o+u, o+u+v, o+v, counter-clockwise seen from the side cross(u, v) points to; with
    // a lightmap chart of its own when `lightmapped`.
    void quad(int mesh, int prim, glm::vec3 o, glm::vec3 u, glm::vec3 v, bool lightmapped) {
        Primitive& p = scene.meshes[mesh].primitives[prim];
        uint32_t base = uint32_t(p.positions.size());
        glm::vec3 n = glm::normalize(glm::cross(u, v));
        for (glm::vec3 c : {o, o + u, o + u + v, o + v}) {
            p.positions.push_back(c);
            p.normals.push_back(n);
        }
        p.indices.insert(p.indices.end(), {base, base + 1, base + 2, base, base + 2, base + 3});
        if (lightmapped) {
            p.uv1.resize(p.positions.size(), glm::vec2(0.0f));
            charts.push_back(Chart{glm::length(u), glm::length(v)});
            uses_.push_back(ChartUse{mesh, prim, base, int(charts.size()) - 1});
        }
    }

    // A box standing on its local origin: x and z in [-hx, hx] x [-hz, hz], y in [0, height];
    // outward faces; no bottom face unless `bottom`.
    void box(int mesh, int prim, glm::vec3 size, bool lightmapped, bool bottom = false,
             bool top = true) {
        float hx = 0.5f * size.x, hz = 0.5f * size.z, h = size.y;
        quad(mesh, prim, {hx, 0, hz}, {0, 0, -2 * hz}, {0, h, 0}, lightmapped);   // +X
        quad(mesh, prim, {-hx, 0, -hz}, {0, 0, 2 * hz}, {0, h, 0}, lightmapped);  // -X
        quad(mesh, prim, {-hx, 0, hz}, {2 * hx, 0, 0}, {0, h, 0}, lightmapped);   // +Z
        quad(mesh, prim, {hx, 0, -hz}, {-2 * hx, 0, 0}, {0, h, 0}, lightmapped);  // -Z
        if (top) quad(mesh, prim, {-hx, h, hz}, {2 * hx, 0, 0}, {0, 0, -2 * hz}, lightmapped);
        if (bottom) quad(mesh, prim, {-hx, 0, -hz}, {2 * hx, 0, 0}, {0, 0, 2 * hz}, lightmapped);
    }

    int node(const std::string& name, int mesh, glm::dvec3 t, double yaw_deg = 0.0,
             double scale = 1.0, bool root = true) {
        Node n;
        n.name = name;
        n.mesh = mesh;
        n.translation = t;
        n.rotation = glm::angleAxis(glm::radians(yaw_deg), glm::dvec3(0, 1, 0));
        n.scale = glm::dvec3(scale);
        scene.nodes.push_back(n);
        int idx = int(scene.nodes.size()) - 1;
        if (root) scene.roots.push_back(idx);
        return idx;
    }

    // A single-level prop: a lightmapped box mesh with its own node.
    void box_prop(const std::string& name, int material, glm::vec3 size, glm::vec3 at,
                  bool top = true) {
        int m = mesh(name);
        box(m, primitive(m, material), size, true, /*bottom=*/false, top);
        scene.nodes[node(name, m, glm::dvec3(at))].geometric_error_m = 0.0;
    }

    // Packs the charts at the highest density (whole texels per metre) that fits; writes uv1.
    // Returns the density, 0 when nothing fits.
    float pack() {
        for (float density = kMaxTexelsPerM; density >= 4.0f; density -= 1.0f) {
            if (!pack_charts(&charts, density)) continue;
            for (const ChartUse& use : uses_) {
                const Chart& c = charts[use.chart];
                Primitive& p = scene.meshes[use.mesh].primitives[use.prim];
                const float s = 1.0f / kAtlasSize;
                p.uv1[use.first_vertex + 0] = glm::vec2(c.x, c.y) * s;
                p.uv1[use.first_vertex + 1] = glm::vec2(c.x + c.w, c.y) * s;
                p.uv1[use.first_vertex + 2] = glm::vec2(c.x + c.w, c.y + c.h) * s;
                p.uv1[use.first_vertex + 3] = glm::vec2(c.x, c.y + c.h) * s;
            }
            return density;
        }
        return 0.0f;
    }

  private:
    struct ChartUse {
        int mesh, prim;
        uint32_t first_vertex;
        int chart;
    };
    std::vector<ChartUse> uses_;
};

// UV sphere: `slices` around, `stacks` from pole to pole, poles as single vertices; analytic
// normals.
Primitive uv_sphere(float radius, int slices, int stacks) {
    Primitive p;
    const float pi = std::numbers::pi_v<float>;
    p.positions.emplace_back(0.0f, radius, 0.0f);
    p.normals.emplace_back(0.0f, 1.0f, 0.0f);
    for (int i = 1; i < stacks; ++i) {
        float theta = pi * float(i) / float(stacks);
        for (int j = 0; j < slices; ++j) {
            float phi = 2.0f * pi * float(j) / float(slices);
            glm::vec3 n(std::sin(theta) * std::cos(phi), std::cos(theta),
                        -std::sin(theta) * std::sin(phi));
            p.positions.push_back(radius * n);
            p.normals.push_back(n);
        }
    }
    p.positions.emplace_back(0.0f, -radius, 0.0f);
    p.normals.emplace_back(0.0f, -1.0f, 0.0f);
    const uint32_t south = uint32_t(p.positions.size() - 1);
    auto ring = [&](int i, int j) { return uint32_t(1 + (i - 1) * slices + (j % slices)); };
    // Seen from outside, counter-clockwise: phi grows towards -z (right-handed around +y).
    for (int j = 0; j < slices; ++j)
        p.indices.insert(p.indices.end(), {0u, ring(1, j), ring(1, j + 1)});
    for (int i = 1; i + 1 < stacks; ++i)
        for (int j = 0; j < slices; ++j) {
            uint32_t a = ring(i, j), b = ring(i, j + 1), c = ring(i + 1, j), d = ring(i + 1, j + 1);
            p.indices.insert(p.indices.end(), {a, c, d, a, d, b});
        }
    for (int j = 0; j < slices; ++j)
        p.indices.insert(p.indices.end(), {south, ring(stacks - 1, j + 1), ring(stacks - 1, j)});
    return p;
}

}  // namespace

glm::vec3 stand_on_origin(Primitive* p) {
    glm::vec3 lo(1e30f), hi(-1e30f);
    for (const glm::vec3& v : p->positions) {
        lo = glm::min(lo, v);
        hi = glm::max(hi, v);
    }
    glm::vec3 offset(0.5f * (lo.x + hi.x), lo.y, 0.5f * (lo.z + hi.z));
    for (glm::vec3& v : p->positions) v -= offset;
    return hi - lo;
}

LodLevels make_lod_levels(const Primitive& base, const std::vector<size_t>& targets) {
    LodLevels out;
    glm::vec3 lo(1e30f), hi(-1e30f);
    for (const glm::vec3& v : base.positions) {
        lo = glm::min(lo, v);
        hi = glm::max(hi, v);
    }
    out.diameter_m = glm::length(hi - lo);
    out.levels.push_back(base);
    out.errors.push_back(0.0);
    // Levels by the LOD generator's QEM (lod/simplify.hpp, all targets in one pass), each with
    // its measured symmetric Hausdorff distance to level 0 (lod/mesh_distance.hpp) as its error;
    // uniform-grid clustering with its displacement bound only if QEM fails.
    Result<std::vector<SimplifiedLevel>> made = simplify(base, "qem", targets);
    MeshDistanceOptions distance;
    distance.samples = 100'000;  // keeps the build-time generation within a few seconds
    for (size_t k = 0; k < targets.size(); ++k) {
        if (made.ok()) {
            out.levels.push_back(std::move((*made)[k].primitive));
            out.errors.push_back(
                measure_mesh_distance(base, out.levels.back(), distance).hausdorff);
        } else {
            ClusteredLevel lvl = cluster_to_triangle_count(base, targets[k]);
            out.levels.push_back(std::move(lvl.primitive));
            out.errors.push_back(lvl.max_displacement_m);
        }
    }
    return out;
}

std::vector<double> lod_screen_coverage(const LodLevels& chain) {
    // Coverage (fraction of the screen height) below which level k+1's error projects under the
    // tolerance: diameter / error_{k+1} * tolerance; the last level is kept down to 0.
    std::vector<double> coverage;
    const std::vector<double>& errors = chain.errors;
    for (size_t k = 0; k + 1 < errors.size(); ++k)
        coverage.push_back(std::min(
            1.0, errors[k + 1] > 0.0 ? chain.diameter_m * kToleranceScreen / errors[k + 1] : 1.0));
    coverage.push_back(0.0);
    return coverage;
}

namespace {

struct LevelReport {
    size_t triangles = 0;
    double error_mesh_m = 0.0, error_world_m = 0.0;
};
struct ObjectReport {
    std::string name;
    std::vector<LevelReport> levels;
};

// Adds `base` as level 0 of an object on a new root node, then one non-root node per coarser
// level (simplified from the original, same transform), with errors and screen coverages.
ObjectReport add_lod_object(Builder& b, const std::string& name, Primitive base, int material,
                            const std::vector<size_t>& targets, glm::dvec3 at, double yaw_deg,
                            double scale) {
    ObjectReport report{name, {}};
    base.material = material;
    int m0 = b.mesh(name);
    b.scene.meshes[m0].primitives.push_back(base);
    int n0 = b.node(name, m0, at, yaw_deg, scale);
    b.scene.nodes[n0].geometric_error_m = 0.0;
    report.levels.push_back(LevelReport{base.triangle_count(), 0.0, 0.0});

    LodLevels chain = make_lod_levels(base, targets);
    for (size_t k = 0; k < targets.size(); ++k) {
        const double error_m = chain.errors[k + 1];
        const std::string lname = name + "_lod" + std::to_string(k + 1);
        int mk = b.mesh(lname);
        chain.levels[k + 1].material = material;
        b.scene.meshes[mk].primitives.push_back(std::move(chain.levels[k + 1]));
        int nk = b.node(lname, mk, at, yaw_deg, scale, /*root=*/false);
        b.scene.nodes[nk].geometric_error_m = error_m;
        b.scene.nodes[n0].lod_ids.push_back(nk);
        report.levels.push_back(
            LevelReport{b.scene.meshes[mk].triangle_count(), error_m, error_m * scale});
    }
    b.scene.nodes[n0].screen_coverage = lod_screen_coverage(chain);
    return report;
}

// Where the showpieces stand, and their stands' heights.
const glm::vec3 kBunnyAt(0.0f, 0.0f, -2.0f), kCowAt(1.8f, 0.0f, -1.2f),
    kSphereAt(-1.4f, 0.0f, 1.8f);
constexpr float kPlinthH = 1.0f, kTableH = 0.45f, kPedestalH = 0.8f;

// Room: inward faces, one material and one chart each.
void add_room(Builder& b) {
    const float h = kHalf, y = kHeight;
    int room = b.mesh("room");
    struct Face {
        const char* name;
        glm::vec3 color, o, u, v;
    } faces[] = {
        {"floor_oak", {0.42f, 0.27f, 0.15f}, {-h, 0, h}, {2 * h, 0, 0}, {0, 0, -2 * h}},
        {"ceiling_plaster", {0.80f, 0.79f, 0.76f}, {-h, y, -h}, {2 * h, 0, 0}, {0, 0, 2 * h}},
        {"wall_front_blue", {0.38f, 0.48f, 0.62f}, {-h, 0, -h}, {2 * h, 0, 0}, {0, y, 0}},
        {"wall_back_sand", {0.70f, 0.62f, 0.48f}, {h, 0, h}, {-2 * h, 0, 0}, {0, y, 0}},
        {"wall_left_sage", {0.47f, 0.56f, 0.44f}, {-h, 0, h}, {0, 0, -2 * h}, {0, y, 0}},
        {"wall_right_terracotta", {0.66f, 0.38f, 0.28f}, {h, 0, -h}, {0, 0, 2 * h}, {0, y, 0}},
    };
    for (const Face& f : faces) {
        int prim = b.primitive(room, b.material(f.name, f.color, true));
        b.quad(room, prim, f.o, f.u, f.v, true);
    }
    b.scene.nodes[b.node("room", room, glm::dvec3(0.0))].geometric_error_m = 0.0;
}

// The lamps' materials, made with the furniture's so that the materials keep their order.
struct LampMaterials {
    int shade = -1, cord = -1;
};

// Stands and furniture (single level, lightmapped).
LampMaterials add_furniture(Builder& b) {
    const int stone = b.material("plinth_stone", {0.62f, 0.60f, 0.57f}, true);
    const int wood = b.material("table_walnut", {0.33f, 0.21f, 0.13f}, true);
    const int concrete = b.material("pillar_concrete", {0.55f, 0.55f, 0.53f}, true);
    const int fabric = b.material("bench_fabric", {0.22f, 0.30f, 0.45f}, true);
    const int crate_wood = b.material("crate_pine", {0.63f, 0.48f, 0.30f}, true);
    LampMaterials lamp;
    lamp.shade = b.material("lamp_shade", {0.85f, 0.82f, 0.72f}, true, /*double_sided=*/true);
    lamp.cord = b.material("lamp_cord", {0.05f, 0.05f, 0.05f}, false);
    b.box_prop("bunny_plinth", stone, {0.6f, kPlinthH, 0.6f}, kBunnyAt);
    b.box_prop("cow_table", wood, {0.8f, kTableH, 0.8f}, kCowAt);
    b.box_prop("sphere_pedestal", stone, {0.4f, kPedestalH, 0.4f}, kSphereAt);
    b.box_prop("pillar_front_left", concrete, {0.4f, kHeight, 0.4f}, {-2.3f, 0.0f, -2.3f}, false);
    b.box_prop("pillar_back_right", concrete, {0.4f, kHeight, 0.4f}, {2.3f, 0.0f, 2.2f}, false);
    b.box_prop("bench_left", fabric, {0.5f, 0.45f, 1.4f}, {-2.6f, 0.0f, 0.2f});
    b.box_prop("crate_back", crate_wood, {0.6f, 0.6f, 0.6f}, {0.9f, 0.0f, 2.4f});
    b.box_prop("crate_right", crate_wood, {0.5f, 0.5f, 0.5f}, {2.6f, 0.0f, 0.6f});
    return lamp;
}

// Pendant lamps: an open-bottomed shade around each light, hung on a cord.
void add_lamps(Builder& b, const LampMaterials& mat) {
    const glm::vec3 lamp_at[2] = {{-1.2f, kLampY, -0.8f}, {1.0f, kLampY, 1.2f}};
    const glm::vec3 lamp_color[2] = {{1.0f, 0.90f, 0.76f}, {1.0f, 0.95f, 0.88f}};
    const float shade_bottom = 0.05f, shade_h = 0.25f;
    for (int i = 0; i < 2; ++i) {
        const std::string tag = std::to_string(i + 1);
        int shade = b.mesh("lamp_shade_" + tag);
        b.box(shade, b.primitive(shade, mat.shade), {0.4f, shade_h, 0.4f}, true);
        int sn = b.node("lamp_shade_" + tag, shade,
                        glm::dvec3(lamp_at[i] - glm::vec3(0, shade_bottom, 0)));
        b.scene.nodes[sn].geometric_error_m = 0.0;
        int cord = b.mesh("lamp_cord_" + tag);
        const float cord_bottom = lamp_at[i].y - shade_bottom + shade_h;
        b.box(cord, b.primitive(cord, mat.cord), {0.02f, kHeight - cord_bottom, 0.02f}, false);
        int cn =
            b.node("lamp_cord_" + tag, cord, glm::dvec3(lamp_at[i].x, cord_bottom, lamp_at[i].z));
        b.scene.nodes[cn].geometric_error_m = 0.0;

        int ln = b.node("lamp_" + tag, -1, glm::dvec3(lamp_at[i]));
        Light l;
        l.name = "lamp_" + tag;
        l.type = Light::Type::Point;
        l.color = lamp_color[i];
        l.intensity = kLampIntensityCd;
        l.node = ln;
        b.scene.lights.push_back(l);
    }
}

// Showpieces with LOD chains, vertex-lit: the bunny on its plinth, spot on the table, a sphere on
// the pedestal.
std::vector<ObjectReport> add_showpieces(Builder& b, const Mesh& bunny, const Mesh& spot) {
    std::vector<ObjectReport> lod_reports;
    {
        Primitive p = bunny.primitives[0];
        glm::vec3 size = stand_on_origin(&p);
        const double scale = 0.45 / size.y;  // 0.45 m tall
        int mat = b.material("bunny_clay", {0.78f, 0.66f, 0.52f}, false);
        // note: the scan faces -x; a 60 degree turn shows its face to a viewer at the origin.
        lod_reports.push_back(
            add_lod_object(b, "bunny", std::move(p), mat, {16000, 4000, 1000, 300},
                           glm::dvec3(kBunnyAt) + glm::dvec3(0, kPlinthH, 0), 60.0, scale));
    }
    {
        Primitive p = spot.primitives[0];
        p.uv0.clear();  // no texture ships with the mesh
        glm::vec3 size = stand_on_origin(&p);
        const double scale = 0.55 / size.y;  // 0.55 m tall
        int mat = b.material("spot_white", {0.85f, 0.84f, 0.82f}, false);
        // note: spot faces -z; 120 degrees turns it towards the viewer.
        lod_reports.push_back(add_lod_object(b, "spot", std::move(p), mat, {1500, 400},
                                             glm::dvec3(kCowAt) + glm::dvec3(0, kTableH, 0), 120.0,
                                             scale));
    }
    {
        const float radius = 0.25f;
        Primitive p = uv_sphere(radius, 64, 32);  // 3968 triangles
        int mat = b.material("sphere_glaze", {0.20f, 0.45f, 0.70f}, false);
        lod_reports.push_back(add_lod_object(
            b, "sphere", std::move(p), mat, {1000, 250},
            glm::dvec3(kSphereAt) + glm::dvec3(0, kPedestalH + radius, 0), 0.0, 1.0));
    }
    return lod_reports;
}

// Seconds each step took.
struct StepTimes {
    double load = 0, lod = 0, bake = 0, total = 0;
};

// The summary `hmdnode scene demo` prints: objects, levels with triangles and errors, the
// lightmap, the bake, the times.
std::string demo_summary(const Builder& b, const std::vector<ObjectReport>& lod_reports,
                         const BakeReport& baked, float texels_per_m, const StepTimes& t) {
    std::string s;
    char line[256];
    auto add = [&](const char* fmt, auto... args) {
        std::snprintf(line, sizeof line, fmt, args...);
        s += line;
    };
    const std::vector<SceneObject> objects = flatten_objects(b.scene);
    size_t tris0 = 0;
    for (const SceneObject& o : objects) tris0 += o.levels[0].triangles;
    add("demo room 6 x 3 x 6 m: %zu objects, %zu triangles at level 0, %zu materials, %zu "
        "lights\n",
        objects.size(), tris0, b.scene.materials.size(), b.scene.lights.size());
    for (const ObjectReport& r : lod_reports) {
        add("  %-7s", r.name.c_str());
        for (size_t k = 0; k < r.levels.size(); ++k)
            add("%s L%zu %zu tris, err %.4f m (%.4f mesh)", k ? " |" : "", k, r.levels[k].triangles,
                r.levels[k].error_world_m, r.levels[k].error_mesh_m);
        s += "\n";
    }
    for (const BakedMap& m : baked.maps)
        add("lightmap %dx%d at %.0f texels/m, %zu charts: %zu texels covered (%.0f %%), %zu "
            "invalid, %zu dilated, intensity %.3f\n",
            m.width, m.height, texels_per_m, b.charts.size(), m.covered,
            100.0 * double(m.covered) / double(m.width * m.height), m.invalid, m.dilated,
            m.intensity);
    add("baked vertices %zu; %zu triangles traced, %.1f M rays (%.1f M rays/s)\n", baked.vertices,
        baked.triangles, double(baked.rays) / 1e6, baked.rays_per_second / 1e6);
    add("time: load %.2f s, lod %.2f s, bake %.2f s, total %.2f s\n", t.load, t.lod, t.bake,
        t.total);
    return s;
}

}  // namespace

Result<Scene> make_demo_scene(const fs::path& data_dir, std::string* out_summary) {
    const Clock::time_point t_start = Clock::now();
    StepTimes times;
    Result<Mesh> bunny = load_obj(data_dir / "meshes" / "stanford-bunny.obj");
    if (!bunny) return bunny.error();
    Result<Mesh> spot = load_obj(data_dir / "meshes" / "spot.obj");
    if (!spot) return spot.error();
    times.load = seconds_since(t_start);

    Builder b;
    Texture atlas;
    atlas.name = "lightmap_atlas";
    atlas.width = atlas.height = kAtlasSize;
    b.scene.textures.push_back(atlas);
    add_room(b);
    const LampMaterials lamp_materials = add_furniture(b);
    add_lamps(b, lamp_materials);
    const float texels_per_m = b.pack();
    if (texels_per_m <= 0.0f)
        return make_error("demo scene: the lightmap charts do not fit a 512 x 512 atlas");

    const Clock::time_point t_lod0 = Clock::now();
    const std::vector<ObjectReport> lod_reports = add_showpieces(b, *bunny, *spot);
    times.lod = seconds_since(t_lod0);

    // Bake: global illumination by the Embree path tracer at demo_bake_options()
    // (demo_scene.hpp, docs/baking.md "Demo scene"). Deterministic for any thread count.
    const Clock::time_point t_bake0 = Clock::now();
    const BakeOptions bake_opt = demo_bake_options();
    Result<BakeReport> baked = bake_scene(b.scene, bake_opt);
    if (!baked) return make_error("demo scene: " + baked.error().message);
    times.bake = seconds_since(t_bake0);

    if (out_summary) {
        times.total = seconds_since(t_start);
        *out_summary = demo_summary(b, lod_reports, *baked, texels_per_m, times);
    }
    return std::move(b.scene);
}

Status build_demo_scene(const fs::path& data_dir, const fs::path& out_glb,
                        std::string* out_summary) {
    const Clock::time_point t0 = Clock::now();
    Result<Scene> scene = make_demo_scene(data_dir, out_summary);
    if (!scene) return scene.error();
    const Clock::time_point t_write = Clock::now();
    Status st = save_glb(*scene, out_glb);
    if (!st) return st;
    if (out_summary) {
        std::error_code ec;
        auto bytes = fs::file_size(out_glb, ec);
        char line[256];
        std::snprintf(line, sizeof line, "wrote %s (%.1f MB) in %.2f s; generation %.2f s in all\n",
                      out_glb.string().c_str(), ec ? 0.0 : double(bytes) / 1e6,
                      seconds_since(t_write), seconds_since(t0));
        *out_summary += line;
    }
    return Status::success();
}

}  // namespace hmdnode
