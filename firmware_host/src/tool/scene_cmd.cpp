// hmdnode scene: generate the bundled demo scene; describe a scene file.
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include "hmdnode/core/gltf.hpp"
#include "tool/cli_errors.hpp"
#include "tool/commands.hpp"
#include "tool/demo_scene.hpp"
#include "tool/stress_scene.hpp"

namespace hmdnode::tool {
namespace {

const CliErrors demo_errors{"scene demo"};
const CliErrors stress_errors{"scene stress"};
const CliErrors info_errors{"scene info"};

const char* light_type_name(Light::Type t) {
    switch (t) {
        case Light::Type::Point:
            return "point";
        case Light::Type::Spot:
            return "spot";
        case Light::Type::Directional:
            return "directional";
    }
    return "?";
}

void print_scene_info(const std::filesystem::path& path, const Scene& scene) {
    const std::vector<SceneObject> objects = flatten_objects(scene);
    size_t tris0 = 0;
    for (const SceneObject& o : objects) tris0 += o.levels[0].triangles;
    std::printf("%s: %zu nodes, %zu meshes, %zu objects (%zu triangles at level 0)\n", path.c_str(),
                scene.nodes.size(), scene.meshes.size(), objects.size(), tris0);
    std::printf("objects:\n");
    for (const SceneObject& o : objects) {
        std::printf("  %-20s at (%6.2f, %5.2f, %6.2f) r %.2f m, %zu level%s\n", o.name.c_str(),
                    o.bounds_center.x, o.bounds_center.y, o.bounds_center.z, o.bounds_radius,
                    o.levels.size(), o.levels.size() == 1 ? "" : "s");
        if (o.levels.size() > 1)
            for (size_t k = 0; k < o.levels.size(); ++k)
                std::printf("      L%zu %8zu triangles  error %.4f m\n", k, o.levels[k].triangles,
                            o.levels[k].geometric_error_m);
        else
            std::printf("      %zu triangles\n", o.levels[0].triangles);
    }
    std::printf("materials:\n");
    for (const Material& m : scene.materials) {
        std::printf("  %-22s base (%.2f %.2f %.2f %.2f)", m.name.c_str(), m.base_color_factor.r,
                    m.base_color_factor.g, m.base_color_factor.b, m.base_color_factor.a);
        if (m.base_color_texture >= 0) std::printf(" texture %d", m.base_color_texture);
        if (m.lightmap.texture >= 0)
            std::printf(" lightmap %d (TEXCOORD_%d, intensity %.3f%s)", m.lightmap.texture,
                        m.lightmap.tex_coord, m.lightmap.intensity,
                        m.lightmap.encoding == LightmapEncoding::Rgbm ? ", RGBM" : "");
        if (m.double_sided) std::printf(" double-sided");
        std::printf("\n");
    }
    std::printf("textures:\n");
    for (size_t i = 0; i < scene.textures.size(); ++i)
        std::printf("  %zu %-20s %d x %d\n", i, scene.textures[i].name.c_str(),
                    scene.textures[i].width, scene.textures[i].height);
    std::printf("lights:\n");
    for (const Light& l : scene.lights) {
        std::printf("  %-12s %-11s %.2f %s colour (%.2f %.2f %.2f)", l.name.c_str(),
                    light_type_name(l.type), l.intensity,
                    l.type == Light::Type::Directional ? "lx" : "cd", l.color.r, l.color.g,
                    l.color.b);
        if (l.node >= 0 && size_t(l.node) < scene.nodes.size()) {
            const glm::dvec3& t = scene.nodes[l.node].translation;
            std::printf(" node %s (%.2f, %.2f, %.2f)", scene.nodes[l.node].name.c_str(), t.x, t.y,
                        t.z);
        }
        std::printf("\n");
    }
}

}  // namespace

void add_scene_command(CLI::App& app) {
    CLI::App* scene =
        app.add_subcommand("scene", "Scene tools: generate the demo scene, describe a scene");
    scene->require_subcommand(1);

    auto data_dir = std::make_shared<std::string>();
    auto out = std::make_shared<std::string>();
    CLI::App* demo = scene->add_subcommand(
        "demo",
        "Generate the bundled demo room (LOD chains, baked light) from the meshes in DIR/meshes");
    demo->add_option("--data", *data_dir,
                     "Data directory holding meshes/stanford-bunny.obj and meshes/spot.obj")
        ->required();
    demo->add_option("--out", *out, "Scene to write (.glb)")->required();
    demo->callback([=] {
        if (!demo_errors.check_outputs({{"--out", *out}})) return;
        std::string summary;
        Status st = build_demo_scene(*data_dir, *out, &summary);
        if (!st) return demo_errors.fail(st.error().message);
        std::fputs(summary.c_str(), stdout);
    });

    auto stress_data = std::make_shared<std::string>();
    auto stress_out = std::make_shared<std::string>();
    auto stress_opt = std::make_shared<StressSceneOptions>();
    CLI::App* stress = scene->add_subcommand(
        "stress",
        "Generate a heavy LOD scene: COPIES x 5 objects (bunny, spot, fandisk from DIR/meshes) "
        "with LOD chains and converged vertex light, tens of millions of triangles at full detail");
    stress->add_option("--data", *stress_data, "Data directory holding meshes/*.obj")->required();
    stress->add_option("--out", *stress_out, "Scene to write (.glb)")->required();
    stress
        ->add_option("--copies", stress_opt->copies,
                     "Groups of 3 bunnies, a spot and a fandisk (default 100: 500 objects)")
        ->check(CLI::Range(1, 100000));
    stress
        ->add_option("--vertex-samples", stress_opt->vertex_samples,
                     "Bake paths per vertex (default 256)")
        ->check(CLI::Range(1, 1 << 16));
    stress->add_option("--seed", stress_opt->seed, "Seed of the placement");
    stress->callback([=] {
        if (!stress_errors.check_outputs({{"--out", *stress_out}})) return;
        std::string summary;
        Result<Scene> s = make_stress_scene(*stress_data, *stress_opt, &summary);
        Status st = s.ok() ? save_glb(*s, *stress_out) : Status(s.error());
        if (!st) return stress_errors.fail(st.error().message);
        std::fputs(summary.c_str(), stdout);
        std::printf("wrote %s\n", stress_out->c_str());
    });

    auto file = std::make_shared<std::string>();
    CLI::App* info = scene->add_subcommand("info",
                                           "Describe a scene: objects with LOD levels, materials, "
                                           "textures, lights");
    info->add_option("file", *file, "Scene (.glb/.gltf)")->required();
    info->callback([=] {
        Result<Scene> s = load_gltf(*file);
        if (!s) return info_errors.fail(s.error().message);
        print_scene_info(*file, *s);
    });
}

}  // namespace hmdnode::tool
