// The heavy scene behind `hmdnode scene stress`: what an LOD allocator needs to be measured on (a
// scene heavy enough that full detail misses frames). Hundreds of objects whose full detail no
// software renderer draws at 90 Hz, so that frame time depends on the levels chosen.
//
// Geometry: per model one LOD chain (make_lod_levels: QEM levels with their measured Hausdorff
// error, as `hmdnode lod` makes them), its meshes shared by every copy (glTF instancing: a copy is
// a node with its own transform and MSFT_lod nodes pointing at the shared level meshes), so the
// file and the GPU hold each level once while the draws count every copy's triangles.
//
// Light: per-vertex irradiance (_LIGHT_0) from one path-traced bake (bake/) of each model's base
// level standing alone on a ground plane under a sun and a sky, with `vertex_samples` paths per
// vertex (256 by default), carried onto the coarser levels by filtering the base's light over
// each level vertex's footprint (lod/attribute_transfer.hpp): baking every level on its own gave
// each its own noise, and LOD against full detail then measured that noise (37 dB at any
// tolerance). Because the copies share meshes they share that light: self-shadowing and ground
// occlusion are baked, shadows between objects are not.
//
// Placement: the nearest grid cells (2.5 m apart) around the origin beyond 2 m, jittered and
// turned at random (Pcg32 from `seed`), sized 0.6-1.2 m.
//
// Cost: the chains O(T log T) per model (T source triangles), the bake O(V * vertex_samples *
// path length) rays for the V base vertices (~45,000), the transfer O(V), placement O(objects).
#include "tool/stress_scene.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <string>
#include <vector>

#include <glm/gtc/quaternion.hpp>

#include "hmdnode/bake/bake.hpp"
#include "hmdnode/bake/path_tracer.hpp"
#include "hmdnode/core/obj.hpp"
#include "hmdnode/lod/attribute_transfer.hpp"
#include "tool/demo_scene.hpp"

namespace hmdnode {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) {
    return std::chrono::duration<double>(Clock::now() - t0).count();
}

struct Model {
    const char* name;
    const char* file;
    glm::vec3 albedo;
    double height_m;  // typical height of a copy
    std::vector<size_t> targets;
};

// Bunny 69,451 triangles, spot 5,856, fandisk 12,946 (data/meshes/README.md).
const Model kModels[] = {
    {"bunny", "stanford-bunny.obj", {0.78f, 0.66f, 0.52f}, 0.9, {16000, 4000, 1000, 300}},
    {"spot", "spot.obj", {0.85f, 0.84f, 0.82f}, 1.0, {1500, 400, 120}},
    {"fandisk", "fandisk.obj", {0.45f, 0.55f, 0.70f}, 0.8, {3000, 800, 200}},
};
// Per copy: three bunnies, one spot, one fandisk.
const int kGroup[] = {0, 0, 0, 1, 2};

constexpr double kSpacing = 2.5, kClearing = 2.0;

Primitive quad_xz(float half, int material) {
    Primitive p;
    p.positions = {{-half, 0, half}, {half, 0, half}, {half, 0, -half}, {-half, 0, -half}};
    p.normals.assign(4, glm::vec3(0, 1, 0));
    p.indices = {0, 1, 2, 0, 2, 3};
    p.material = material;
    return p;
}

void add_sun_and_sky(Scene* s, BakeOptions* o) {
    Node sun;
    sun.name = "sun";
    sun.rotation =
        glm::angleAxis(-0.9, glm::dvec3(1, 0, 0)) * glm::angleAxis(0.5, glm::dvec3(0, 1, 0));
    s->nodes.push_back(sun);
    Light l;
    l.name = "sun";
    l.type = Light::Type::Directional;
    l.color = {1.0f, 0.95f, 0.85f};
    l.intensity = 1.6f;  // lux; with the sky, a lit top face shows about its albedo
    l.node = int(s->nodes.size()) - 1;
    s->lights.push_back(l);
    o->sky_radiance = glm::vec3(0.42f, 0.48f, 0.58f);
}

// Per model one LOD chain, and the scale that makes a copy its typical height (the chains stay
// in mesh units: the copies' nodes scale them to metres).
struct ModelChains {
    std::vector<LodLevels> chains;
    std::vector<double> model_scale;
};

Result<ModelChains> make_model_chains(const fs::path& data_dir) {
    ModelChains out;
    for (const Model& m : kModels) {
        Result<Mesh> mesh = load_obj(data_dir / "meshes" / m.file);
        if (!mesh) return mesh.error();
        if (mesh->primitives.empty())
            return make_error((data_dir / "meshes" / m.file).string() + ": no triangles");
        Primitive p = mesh->primitives[0];
        p.uv0.clear();
        p.uv1.clear();
        const glm::vec3 size = stand_on_origin(&p);
        if (!(size.y > 0.0f))
            return make_error((data_dir / "meshes" / m.file).string() + ": flat mesh");
        out.model_scale.push_back(m.height_m / size.y);
        out.chains.push_back(make_lod_levels(p, m.targets));
    }
    return out;
}

// The studio the bake lights: each model's base level alone on a ground plane, 8 m apart (far
// enough that the sun's shadows do not reach a neighbour), at its copies' typical size; one
// material per model, then the ground's (the last). Gives every level its model's material.
Scene make_studio(ModelChains* models) {
    Scene studio;
    for (const Model& m : kModels) {
        Material mat;
        mat.name = std::string(m.name) + "_vertex_lit";
        mat.base_color_factor = glm::vec4(m.albedo, 1.0f);
        studio.materials.push_back(mat);
    }
    Material ground_mat;
    ground_mat.name = "ground";
    ground_mat.base_color_factor = glm::vec4(0.35f, 0.36f, 0.33f, 1.0f);
    studio.materials.push_back(ground_mat);
    const int ground_material = int(studio.materials.size()) - 1;
    int slot = 0;
    // Only each model's base level is baked; the coarser levels get its light by transfer.
    for (size_t mi = 0; mi < models->chains.size(); ++mi) {
        for (Primitive& level : models->chains[mi].levels) level.material = int(mi);
        Mesh mesh;
        mesh.name = std::string(kModels[mi].name) + "_studio";
        mesh.primitives.push_back(models->chains[mi].levels.front());
        Node n;
        n.name = mesh.name;
        studio.meshes.push_back(std::move(mesh));
        n.mesh = int(studio.meshes.size()) - 1;
        n.translation = glm::dvec3(8.0 * slot++, 0.0, 0.0);
        n.scale = glm::dvec3(models->model_scale[mi]);
        studio.nodes.push_back(n);
        studio.roots.push_back(int(studio.nodes.size()) - 1);
    }
    Mesh g;
    g.name = "ground";
    g.primitives.push_back(quad_xz(500.0f, ground_material));
    studio.meshes.push_back(std::move(g));
    Node n;
    n.name = "ground";
    n.mesh = int(studio.meshes.size()) - 1;
    studio.nodes.push_back(n);
    studio.roots.push_back(int(studio.nodes.size()) - 1);
    return studio;
}

// Path-traces the studio's vertex light (3 bounces, one-sided, under the sun and the sky).
Result<BakeReport> bake_studio(Scene* studio, int vertex_samples) {
    BakeOptions bake;
    bake.vertex = true;
    bake.samples = vertex_samples;
    bake.vertex_samples = vertex_samples;
    bake.bounces = 3;
    bake.two_sided = false;
    bake.seed = 1;
    add_sun_and_sky(studio, &bake);
    Result<BakeReport> baked = bake_scene(*studio, bake);
    if (!baked) return make_error("stress scene: " + baked.error().message);
    return baked;
}

// The scene's meshes from the baked studio: per model its levels (the base as baked, the coarser
// ones with the base's light transferred), level_mesh[model][k] their indices; then a ground plane
// lit as the studio's far ground is (sun and open sky), on node 0, the first root.
Result<Scene> scene_of_baked_levels(const Scene& studio, const ModelChains& models,
                                    std::vector<std::vector<int>>* level_mesh) {
    const std::vector<LodLevels>& chains = models.chains;
    Scene s;
    s.materials = studio.materials;
    level_mesh->assign(chains.size(), {});
    size_t studio_mesh = 0;
    for (size_t mi = 0; mi < chains.size(); ++mi) {
        const Mesh& baked_base = studio.meshes[studio_mesh++];
        for (size_t k = 0; k < chains[mi].levels.size(); ++k) {
            Mesh mesh = baked_base;
            mesh.name = std::string(kModels[mi].name) + (k ? "_lod" + std::to_string(k) : "");
            if (k > 0) {
                // The coarser levels show the base's light filtered over their footprints.
                Primitive level = chains[mi].levels[k];
                Result<std::vector<glm::vec3>> light =
                    transfer_vertex_light(baked_base.primitives[0], level);
                if (!light) return make_error("stress scene: " + light.error().message);
                level.light = std::move(light).value();
                mesh.primitives[0] = std::move(level);
            }
            s.meshes.push_back(std::move(mesh));
            (*level_mesh)[mi].push_back(int(s.meshes.size()) - 1);
        }
    }
    const int ground_material = int(studio.materials.size()) - 1;
    Mesh g = studio.meshes[studio_mesh];
    g.primitives[0].positions = quad_xz(200.0f, ground_material).positions;
    s.meshes.push_back(std::move(g));
    Node n;
    n.name = "ground";
    n.mesh = int(s.meshes.size()) - 1;
    s.nodes.push_back(n);
    s.roots.push_back(0);
    return s;
}

struct Cell {
    double x, z, r, a;
};

// Grid cells beyond the clearing, nearest the origin first (ties by angle, so the order is
// total), at least `objects` of them.
std::vector<Cell> placement_cells(int objects) {
    std::vector<Cell> cells;
    const int reach = int(std::ceil(std::sqrt(double(objects)) / 2.0)) + 3;
    for (int i = -reach; i <= reach; ++i)
        for (int j = -reach; j <= reach; ++j) {
            const double x = i * kSpacing, z = j * kSpacing, r = std::hypot(x, z);
            if (r >= kClearing) cells.push_back(Cell{x, z, r, std::atan2(z, x)});
        }
    std::sort(cells.begin(), cells.end(),
              [](const Cell& a, const Cell& b) { return a.r != b.r ? a.r < b.r : a.a < b.a; });
    return cells;
}

// Triangles of the placed objects at full detail and at the coarsest levels.
struct Placed {
    size_t full_triangles = 0, coarse_triangles = 0;
};

// One root node per object in cell order (models by kGroup), jittered, turned and sized by the
// seed's Pcg32, with an MSFT_lod node per coarser level pointing at the shared level meshes.
Placed place_objects(Scene* s, const ModelChains& models,
                     const std::vector<std::vector<int>>& level_mesh,
                     const std::vector<Cell>& cells, int objects, uint64_t seed) {
    Pcg32 rng(seed, 0x5712e55);
    Placed placed;
    for (int o = 0; o < objects; ++o) {
        const size_t mi = size_t(kGroup[o % int(std::size(kGroup))]);
        const Cell& c = cells[size_t(o)];
        const double jx = (rng.uniform() - 0.5) * 0.8, jz = (rng.uniform() - 0.5) * 0.8;
        const double yaw = rng.uniform() * 2.0 * std::numbers::pi;
        const double size = 0.65 + 0.55 * rng.uniform();  // of the model's typical height
        const double scale = models.model_scale[mi] * size;
        const std::string name = std::string(kModels[mi].name) + "_" + std::to_string(o);
        auto add_node = [&](const std::string& nname, int mesh, double error) {
            Node n;
            n.name = nname;
            n.mesh = mesh;
            n.translation = glm::dvec3(c.x + jx, 0.0, c.z + jz);
            n.rotation = glm::angleAxis(yaw, glm::dvec3(0, 1, 0));
            n.scale = glm::dvec3(scale);
            n.geometric_error_m = error;
            s->nodes.push_back(n);
            return int(s->nodes.size()) - 1;
        };
        const LodLevels& chain = models.chains[mi];
        const int n0 = add_node(name, level_mesh[mi][0], 0.0);
        s->roots.push_back(n0);
        for (size_t k = 1; k < chain.levels.size(); ++k) {
            // note: add_node grows s->nodes, so the level's index is taken before n0 is indexed
            const int nk =
                add_node(name + "_lod" + std::to_string(k), level_mesh[mi][k], chain.errors[k]);
            s->nodes[size_t(n0)].lod_ids.push_back(nk);
        }
        s->nodes[size_t(n0)].screen_coverage = lod_screen_coverage(chain);
        placed.full_triangles += chain.levels.front().triangle_count();
        placed.coarse_triangles += chain.levels.back().triangle_count();
    }
    return placed;
}

// Seconds each step took.
struct StepTimes {
    double lod = 0, bake = 0, total = 0;
};

// The summary `hmdnode scene stress` prints: objects and their reach, triangles, the levels of
// each model, the bake, the times.
std::string stress_summary(const StressSceneOptions& opt, const ModelChains& models, int objects,
                           double reach_m, const Placed& placed, const BakeReport& baked,
                           const StepTimes& t) {
    std::string out;
    char line[320];
    auto add = [&](const char* fmt, auto... args) {
        std::snprintf(line, sizeof line, fmt, args...);
        out += line;
    };
    add("stress scene: %d objects (%d copies of 3 bunnies, a spot, a fandisk) on a %.1f m grid "
        "out to %.1f m\n",
        objects, opt.copies, kSpacing, reach_m);
    add("triangles: %zu at full detail, %zu at the coarsest levels\n", placed.full_triangles,
        placed.coarse_triangles);
    for (size_t mi = 0; mi < models.chains.size(); ++mi) {
        const LodLevels& chain = models.chains[mi];
        add("  %-8s", kModels[mi].name);
        for (size_t k = 0; k < chain.levels.size(); ++k)
            add("%s L%zu %zu tris, err %.4f m", k ? " |" : "", k, chain.levels[k].triangle_count(),
                chain.errors[k] * models.model_scale[mi]);
        out += "\n";
    }
    add("bake: %d paths per vertex, %zu vertices, %.1f M rays (%.1f M rays/s)\n",
        opt.vertex_samples, baked.vertices, double(baked.rays) / 1e6, baked.rays_per_second / 1e6);
    add("time: lod %.2f s, bake %.2f s, total %.2f s\n", t.lod, t.bake, t.total);
    return out;
}

}  // namespace

Result<Scene> make_stress_scene(const fs::path& data_dir, const StressSceneOptions& opt,
                                std::string* out_summary) {
    if (opt.copies < 1) return make_error("stress scene: --copies must be at least 1");
    const Clock::time_point t0 = Clock::now();
    Result<ModelChains> models = make_model_chains(data_dir);
    if (!models) return models.error();
    StepTimes times;
    times.lod = seconds_since(t0);

    const Clock::time_point t_bake0 = Clock::now();
    Scene studio = make_studio(&*models);
    Result<BakeReport> baked = bake_studio(&studio, opt.vertex_samples);
    if (!baked) return baked.error();
    times.bake = seconds_since(t_bake0);

    std::vector<std::vector<int>> level_mesh;
    Result<Scene> s = scene_of_baked_levels(studio, *models, &level_mesh);
    if (!s) return s.error();
    const int objects = opt.copies * int(std::size(kGroup));
    const std::vector<Cell> cells = placement_cells(objects);
    if (cells.size() < size_t(objects)) return make_error("stress scene: placement grid too small");
    const Placed placed = place_objects(&*s, *models, level_mesh, cells, objects, opt.seed);

    if (out_summary) {
        times.total = seconds_since(t0);
        *out_summary = stress_summary(opt, *models, objects, cells[size_t(objects) - 1].r, placed,
                                      *baked, times);
    }
    return s;
}

}  // namespace hmdnode
