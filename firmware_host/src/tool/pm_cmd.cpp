// `hmdnode pm`: reads the progressive meshes (.hmpm, lod/progressive_mesh.hpp, Hoppe 1996) that
// `hmdnode lod --progressive` writes. `pm info FILE` prints the counts and attributes;
// `pm refine --in FILE --triangles N --out OUT.glb|.obj` writes the mesh refined to N triangles
// (the first level of the collapse sequence at or below N, bit for bit what simplify() returns).
// A bad or truncated file: exit 1, the reader's error with the byte offset, nothing written.
// Formats: docs/simplification.md; the tool: docs/lod-generation.md.
#include <algorithm>
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <sstream>
#include <string>

#include <CLI/CLI.hpp>

#include "hmdnode/core/atomic_file.hpp"
#include "hmdnode/core/gltf.hpp"
#include "hmdnode/lod/mesh_file.hpp"
#include "hmdnode/lod/progressive_mesh.hpp"
#include "tool/cli_errors.hpp"
#include "tool/commands.hpp"

namespace hmdnode::tool {
namespace {

struct PmArgs {
    std::string info_file;
    std::string in, out;
    size_t triangles = 0;
};

const CliErrors info_errors{"pm info"};
const CliErrors refine_errors{"pm refine"};

std::string attribute_list(const ProgressiveMesh& pm) {
    std::string s = "position";
    if (pm.has_normals) s += ", normal";
    if (pm.has_uv0) s += ", uv0";
    if (pm.has_uv1) s += ", uv1";
    if (pm.has_colors) s += ", color";
    return s;
}

void run_info(const PmArgs& args) {
    Result<ProgressiveMesh> pm = read_progressive_mesh(args.info_file);
    if (!pm.ok()) return info_errors.fail(pm.error().message);
    std::printf("%s\n", args.info_file.c_str());
    std::printf("  base triangles   %zu\n", pm->base_triangles());
    std::printf("  full triangles   %zu\n", pm->full_triangles());
    std::printf("  vertex splits    %zu\n", pm->splits.size());
    std::printf("  base positions   %zu of %u\n", pm->base_positions.size(), pm->position_count);
    std::printf("  base vertices    %zu of %u (position + attributes)\n", pm->base_wedges.size(),
                pm->wedge_count);
    std::printf("  attributes       %s\n", attribute_list(*pm).c_str());
    std::printf("  material         %d\n", pm->material);
}

// Wavefront OBJ of one primitive: v, then vt / vn when it has them, faces v/vt/vn (1-based).
std::string obj_text(const Primitive& p, const std::string& source) {
    std::ostringstream o;
    o.precision(9);
    o << "# hmdnode pm refine of " << source << ": " << p.triangle_count() << " triangles\n";
    for (const glm::vec3& v : p.positions) o << "v " << v.x << ' ' << v.y << ' ' << v.z << '\n';
    const bool uv = !p.uv0.empty(), nrm = !p.normals.empty();
    // note: glTF's v runs down the image, OBJ's up (load_obj flips it back).
    for (const glm::vec2& t : p.uv0) o << "vt " << t.x << ' ' << 1.0f - t.y << '\n';
    for (const glm::vec3& n : p.normals) o << "vn " << n.x << ' ' << n.y << ' ' << n.z << '\n';
    for (size_t i = 0; i + 2 < p.indices.size(); i += 3) {
        o << 'f';
        for (int k = 0; k < 3; ++k) {
            const uint32_t v = p.indices[i + size_t(k)] + 1;
            o << ' ' << v;
            if (uv || nrm) o << '/';
            if (uv) o << v;
            if (nrm) o << '/' << v;
        }
        o << '\n';
    }
    return o.str();
}

void run_refine(const PmArgs& args) {
    if (args.in.empty() || args.out.empty())
        return refine_errors.usage("--in and --out are required");
    std::string ext = std::filesystem::path(args.out).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(),
                   [](unsigned char c) { return char(std::tolower(c)); });
    if (ext != ".glb" && ext != ".obj")
        return refine_errors.usage("--out \"" + args.out + "\" must end in .glb or .obj");
    if (!refine_errors.check_outputs({{"--out", args.out}})) return;
    Result<ProgressiveMesh> pm = read_progressive_mesh(args.in);
    if (!pm.ok()) return refine_errors.fail(pm.error().message + "; nothing written");
    Primitive prim = refine(*pm, args.triangles);
    prim.material = -1;  // the .hmpm holds no materials
    const std::string name = std::filesystem::path(args.out).stem().string();
    Status written = Status::success();
    if (ext == ".obj") {
        written = write_file_atomically(args.out, obj_text(prim, args.in));
    } else {
        Mesh mesh;
        mesh.name = name;
        mesh.primitives.push_back(prim);
        written = save_glb(single_mesh_scene(std::move(mesh)), args.out);
    }
    if (!written.ok()) return refine_errors.fail(written.error().message + "; nothing written");
    if (args.triangles < pm->base_triangles())
        refine_errors.note(std::to_string(args.triangles) +
                           " is below the base mesh; wrote the base");
    std::printf("base %zu, full %zu, written %zu triangles (%zu vertices) to %s\n",
                pm->base_triangles(), pm->full_triangles(), prim.triangle_count(),
                prim.positions.size(), args.out.c_str());
}

void add_pm_command(CLI::App& app) {
    auto args = std::make_shared<PmArgs>();
    CLI::App* pm = app.add_subcommand(
        "pm", "Progressive meshes (.hmpm from `hmdnode lod --progressive`): info, refine");
    pm->require_subcommand(1);
    CLI::App* info = pm->add_subcommand("info", "Base and full counts, splits, attributes");
    info->add_option("file", args->info_file, "The .hmpm file")->required();
    info->callback([args] { run_info(*args); });
    CLI::App* ref =
        pm->add_subcommand("refine", "Write the mesh refined to a triangle count (.glb or .obj)");
    ref->add_option("--in", args->in, "The .hmpm file")->required();
    ref->add_option("--triangles", args->triangles,
                    "Triangle count: the finest level at or below it (clamped to base..full)")
        ->required();
    ref->add_option("--out", args->out, "Output .glb or .obj (written only on success)")
        ->required();
    ref->callback([args] { run_refine(*args); });
}

const CommandRegistration reg{41, add_pm_command};

}  // namespace
}  // namespace hmdnode::tool
