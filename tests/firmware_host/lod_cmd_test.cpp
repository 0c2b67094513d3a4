// `hmdnode lod` as a user runs it: each input format and target kind, the report, and bad input
// (non-zero exit, a message naming the problem, no output file); `--progressive` and `hmdnode pm`
// (refine equals the chain's levels, truncated files rejected).
#include <gtest/gtest.h>

#include <sys/wait.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "firmware_host/command_run.hpp"
#include "hmdnode/core/gltf.hpp"
#include "hmdnode/core/obj.hpp"

namespace fs = std::filesystem;

namespace {

using hmdnode::test::CommandRun;
using hmdnode::test::run;

fs::path temp_dir(const std::string& name) {
    return hmdnode::test::fresh_temp_dir("hmdnode_lod_cmd_test_" + name);
}

void write(const fs::path& p, const std::string& bytes) {
    std::ofstream(p, std::ios::binary) << bytes;
}

const std::string kTool = HMDNODE_TOOL;

struct Sphere {
    std::vector<std::array<float, 3>> v;
    std::vector<std::array<uint32_t, 3>> f;
};

// Unit icosphere, 20 * 4^levels triangles.
Sphere icosphere(int levels) {
    const float t = (1.0f + std::sqrt(5.0f)) / 2.0f;
    Sphere s;
    s.v = {{-1, t, 0},  {1, t, 0},  {-1, -t, 0}, {1, -t, 0}, {0, -1, t},  {0, 1, t},
           {0, -1, -t}, {0, 1, -t}, {t, 0, -1},  {t, 0, 1},  {-t, 0, -1}, {-t, 0, 1}};
    auto norm = [](std::array<float, 3> a) {
        const float l = std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
        return std::array<float, 3>{a[0] / l, a[1] / l, a[2] / l};
    };
    for (auto& p : s.v) p = norm(p);
    s.f = {{0, 11, 5},  {0, 5, 1},  {0, 1, 7},  {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
           {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
           {3, 8, 9},   {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
    for (int l = 0; l < levels; ++l) {
        std::map<std::pair<uint32_t, uint32_t>, uint32_t> mid;
        auto midpoint = [&](uint32_t a, uint32_t b) {
            auto key = std::minmax(a, b);
            auto it = mid.find(key);
            if (it != mid.end()) return it->second;
            s.v.push_back(
                norm({s.v[a][0] + s.v[b][0], s.v[a][1] + s.v[b][1], s.v[a][2] + s.v[b][2]}));
            return mid[key] = uint32_t(s.v.size() - 1);
        };
        std::vector<std::array<uint32_t, 3>> next;
        for (auto [a, b, c] : s.f) {
            const uint32_t ab = midpoint(a, b), bc = midpoint(b, c), ca = midpoint(c, a);
            next.insert(next.end(), {{a, ab, ca}, {b, bc, ab}, {c, ca, bc}, {ab, bc, ca}});
        }
        s.f = std::move(next);
    }
    return s;
}

std::string obj_text(const Sphere& s) {
    std::ostringstream o;
    for (auto& p : s.v) o << "v " << p[0] << " " << p[1] << " " << p[2] << "\n";
    for (auto& f : s.f) o << "f " << f[0] + 1 << " " << f[1] + 1 << " " << f[2] + 1 << "\n";
    return o.str();
}

std::string ply_ascii(const Sphere& s) {
    std::ostringstream o;
    o << "ply\nformat ascii 1.0\ncomment test\nelement vertex " << s.v.size()
      << "\nproperty float x\nproperty float y\nproperty float z\nelement face " << s.f.size()
      << "\nproperty list uchar int vertex_indices\nend_header\n";
    for (auto& p : s.v) o << p[0] << " " << p[1] << " " << p[2] << "\n";
    for (auto& f : s.f) o << "3 " << f[0] << " " << f[1] << " " << f[2] << "\n";
    return o.str();
}

std::string ply_binary(const Sphere& s) {
    std::ostringstream o;
    o << "ply\nformat binary_little_endian 1.0\nelement vertex " << s.v.size()
      << "\nproperty double x\nproperty double y\nproperty double z\nproperty uchar red\n"
         "element face "
      << s.f.size() << "\nproperty list uchar uint vertex_indices\nend_header\n";
    std::string bytes = o.str();
    auto put = [&](const void* p, size_t n) { bytes.append(static_cast<const char*>(p), n); };
    for (auto& p : s.v) {
        for (float c : p) {
            const double d = c;
            put(&d, 8);
        }
        const uint8_t red = 200;
        put(&red, 1);
    }
    for (auto& f : s.f) {
        const uint8_t n = 3;
        put(&n, 1);
        put(f.data(), 12);
    }
    return bytes;
}

std::string off_text(const Sphere& s) {
    std::ostringstream o;
    o << "OFF\n# comment\n" << s.v.size() << " " << s.f.size() << " 0\n";
    for (auto& p : s.v) o << p[0] << " " << p[1] << " " << p[2] << "\n";
    for (auto& f : s.f) o << "3 " << f[0] << " " << f[1] << " " << f[2] << "\n";
    return o.str();
}

std::string lod(const fs::path& in, const fs::path& out, const std::string& extra) {
    return kTool + " lod --samples 20000 --in " + in.string() + " --out " + out.string() + " " +
           extra;
}

// Levels of the one object of `glb`: triangle counts.
std::vector<size_t> level_triangles(const fs::path& glb) {
    hmdnode::Result<hmdnode::Scene> s = hmdnode::load_gltf(glb);
    EXPECT_TRUE(s.ok()) << (s.ok() ? "" : s.error().message);
    if (!s.ok()) return {};
    std::vector<hmdnode::SceneObject> objects = hmdnode::flatten_objects(*s);
    EXPECT_EQ(objects.size(), 1u);
    std::vector<size_t> out;
    for (const hmdnode::LodLevel& l : objects.at(0).levels) out.push_back(l.triangles);
    return out;
}

TEST(LodCommand, ListsAlgorithms) {
    CommandRun r = run(kTool + " lod --list-algorithms");
    EXPECT_EQ(r.code, 0) << r.output;
    EXPECT_NE(r.output.find("qem"), std::string::npos) << r.output;
}

TEST(LodCommand, RatiosFromObjWithReport) {
    const fs::path d = temp_dir("ratios");
    write(d / "ball.obj", obj_text(icosphere(3)));
    CommandRun r = run(
        lod(d / "ball.obj", d / "out.glb", "--ratios 0.5,0.1 --report " + (d / "r.json").string()));
    ASSERT_EQ(r.code, 0) << r.output;
    EXPECT_NE(r.output.find("error m"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("ball_lod2"), std::string::npos) << r.output;
    const std::vector<size_t> tris = level_triangles(d / "out.glb");
    ASSERT_EQ(tris.size(), 3u);
    EXPECT_EQ(tris[0], 1280u);
    EXPECT_LE(tris[1], 640u);
    EXPECT_LE(tris[2], 128u);
    std::ifstream f(d / "r.json");
    const nlohmann::json j = nlohmann::json::parse(f);
    EXPECT_EQ(j["algorithm"], "qem");
    ASSERT_EQ(j["levels"].size(), 3u);
    for (const char* key :
         {"mesh", "mesh_name", "level", "triangles", "target", "error_m", "error_pct_diag",
          "mean_m", "mean_pct_diag", "simplify_ms", "measure_ms", "error_upper_m",
          "error_upper_pct_diag", "mean_stderr_m", "mean_stderr_pct_diag", "measure_cpu_ms"})
        EXPECT_TRUE(j["levels"][1].contains(key)) << key;
    // The sampling error: the Hausdorff bracket is ordered, the mean has a standard error.
    for (size_t k = 1; k < 3; ++k) {
        const nlohmann::json& l = j["levels"][k];
        EXPECT_GE(l["error_upper_m"].get<double>(), l["error_m"].get<double>());
        EXPECT_GT(l["mean_stderr_m"].get<double>(), 0.0);
        EXPECT_LT(l["mean_stderr_m"].get<double>(), l["mean_m"].get<double>());
    }
    for (const char* key : {"load", "load_cpu", "repair", "repair_cpu", "chains", "chains_cpu"})
        EXPECT_TRUE(j["timing_ms"].contains(key)) << key;
    EXPECT_EQ(j["levels"][2]["triangles"].get<size_t>(), tris[2]);
    EXPECT_GT(j["levels"][2]["error_m"].get<double>(), j["levels"][1]["error_m"].get<double>());
    EXPECT_EQ(j["levels"][0]["error_m"].get<double>(), 0.0);
    EXPECT_EQ(j["repair"]["degenerate_faces"], 0);
}

// The tool dropped _LIGHT_0 (the baked vertex light) from the levels it wrote, and repair dropped
// it from level 0: a .glb in with light linear in position gives a .glb out whose every level has
// it, within sqrt(2) times half the level's longest edge of the closed form (lod_chain_test).
TEST(LodCommand, EveryLevelKeepsTheBakedVertexLight) {
    const fs::path d = temp_dir("light");
    const Sphere ball = icosphere(3);
    auto light_at = [](const glm::vec3& p) {
        return glm::vec3(2.0f + p.x, 3.0f - 0.5f * p.y, 1.0f + p.x + p.z);
    };
    hmdnode::Scene in;
    hmdnode::Primitive prim;
    for (const auto& v : ball.v) {
        prim.positions.emplace_back(v[0], v[1], v[2]);
        prim.normals.push_back(prim.positions.back());
        prim.light.push_back(light_at(prim.positions.back()));
    }
    for (const auto& f : ball.f) prim.indices.insert(prim.indices.end(), f.begin(), f.end());
    in.meshes.push_back({"ball", {prim}});
    hmdnode::Node node;
    node.mesh = 0;
    in.nodes.push_back(node);
    in.roots.push_back(0);
    ASSERT_TRUE(hmdnode::save_glb(in, d / "in.glb").ok());
    CommandRun r = run(lod(d / "in.glb", d / "out.glb", "--no-progress"));
    ASSERT_EQ(r.code, 0) << r.output;
    hmdnode::Result<hmdnode::Scene> out = hmdnode::load_gltf(d / "out.glb");
    ASSERT_TRUE(out.ok()) << out.error().message;
    ASSERT_EQ(out->meshes.size(), 4u);  // level 0 and the default ratios' three
    for (const hmdnode::Mesh& m : out->meshes) {
        SCOPED_TRACE(m.name);
        const hmdnode::Primitive& p = m.primitives.at(0);
        ASSERT_EQ(p.light.size(), p.positions.size());
        float longest = 0.0f, worst = 0.0f;
        for (size_t t = 0; t < p.indices.size(); t += 3)
            for (size_t e = 0; e < 3; ++e)
                longest = std::max(longest, glm::distance(p.positions[p.indices[t + e]],
                                                          p.positions[p.indices[t + (e + 1) % 3]]));
        for (size_t v = 0; v < p.positions.size(); ++v) {
            const glm::vec3 diff = glm::abs(p.light[v] - light_at(p.positions[v]));
            worst = std::max({worst, diff.x, diff.y, diff.z});
        }
        EXPECT_LE(worst, std::sqrt(2.0f) * 0.5f * longest) << p.triangle_count() << " triangles";
    }
}

// `hmdnode lod --algorithm grid` failed on the demo room ("mesh 16 primitive 0: no vertices"):
// the grid collapsed a small object to nothing for a target of a triangle or two. It now chains
// the room; every primitive written has triangles, and every level has the light (_LIGHT_0) and
// texture coordinates its level 0 has.
TEST(LodCommand, GridChainsTheDemoRoomWithoutLosingObjectsOrLight) {
    const fs::path d = temp_dir("grid_demo");
    CommandRun r = run(lod(HMDNODE_DEMO_SCENE, d / "out.glb", "--no-progress --algorithm grid"));
    ASSERT_EQ(r.code, 0) << r.output;
    hmdnode::Result<hmdnode::Scene> out = hmdnode::load_gltf(d / "out.glb");
    ASSERT_TRUE(out.ok()) << out.error().message;
    size_t chained = 0;
    for (const hmdnode::Node& n : out->nodes) {
        if (n.mesh < 0 || n.lod_ids.empty()) continue;
        ++chained;
        const hmdnode::Mesh& base = out->meshes.at(size_t(n.mesh));
        for (int id : n.lod_ids) {
            const hmdnode::Mesh& level = out->meshes.at(size_t(out->nodes.at(size_t(id)).mesh));
            SCOPED_TRACE(level.name);
            ASSERT_EQ(level.primitives.size(), base.primitives.size());
            for (size_t k = 0; k < base.primitives.size(); ++k) {
                const hmdnode::Primitive &b = base.primitives[k], &l = level.primitives[k];
                EXPECT_GT(l.triangle_count(), 0u) << "primitive " << k;
                EXPECT_EQ(l.light.empty(), b.light.empty()) << "primitive " << k;
                EXPECT_EQ(l.uv0.empty(), b.uv0.empty()) << "primitive " << k;
                EXPECT_EQ(l.uv1.empty(), b.uv1.empty()) << "primitive " << k;
                EXPECT_EQ(l.normals.empty(), b.normals.empty()) << "primitive " << k;
            }
        }
    }
    EXPECT_GE(chained, 5u);
}

// --threads 2 lets qem use a helper thread on meshes of 8 192 faces or more: the .glb is the
// same byte for byte as with --threads 1; --threads 0 is a usage error and writes nothing.
TEST(LodCommand, ThreadsDoNotChangeTheOutput) {
    const fs::path d = temp_dir("threads");
    write(d / "ball.obj", obj_text(icosphere(5)));  // 20 480 triangles
    auto bytes = [](const fs::path& p) {
        std::ifstream f(p, std::ios::binary);
        return std::string(std::istreambuf_iterator<char>(f), {});
    };
    CommandRun one = run(lod(d / "ball.obj", d / "one.glb", "--ratios 0.5,0.1 --threads 1"));
    ASSERT_EQ(one.code, 0) << one.output;
    CommandRun two = run(lod(d / "ball.obj", d / "two.glb", "--ratios 0.5,0.1 --threads 2"));
    ASSERT_EQ(two.code, 0) << two.output;
    EXPECT_FALSE(bytes(d / "one.glb").empty());
    EXPECT_EQ(bytes(d / "one.glb"), bytes(d / "two.glb"));
    CommandRun zero = run(lod(d / "ball.obj", d / "zero.glb", "--ratios 0.5 --threads 0"));
    EXPECT_EQ(zero.code, 2) << zero.output;
    EXPECT_FALSE(fs::exists(d / "zero.glb"));
}

TEST(LodCommand, TrianglesFromAsciiPly) {
    const fs::path d = temp_dir("triangles");
    write(d / "ball.ply", ply_ascii(icosphere(3)));
    CommandRun r = run(lod(d / "ball.ply", d / "out.glb", "--triangles 400,100"));
    ASSERT_EQ(r.code, 0) << r.output;
    const std::vector<size_t> tris = level_triangles(d / "out.glb");
    ASSERT_EQ(tris.size(), 3u);
    EXPECT_LE(tris[1], 400u);
    EXPECT_GT(tris[1], 300u);
    EXPECT_LE(tris[2], 100u);
}

TEST(LodCommand, ErrorFromBinaryPly) {
    const fs::path d = temp_dir("error");
    write(d / "ball.ply", ply_binary(icosphere(3)));
    CommandRun r =
        run(lod(d / "ball.ply", d / "out.glb", "--error 0.05 --report " + (d / "r.json").string()));
    ASSERT_EQ(r.code, 0) << r.output;
    std::ifstream f(d / "r.json");
    const nlohmann::json j = nlohmann::json::parse(f);
    ASSERT_EQ(j["levels"].size(), 2u);
    EXPECT_LE(j["levels"][1]["error_m"].get<double>(), 0.05);
    EXPECT_LT(j["levels"][1]["triangles"].get<size_t>(), 640u);
    EXPECT_EQ(j["targets"]["max_error_m"].get<double>(), 0.05);
}

TEST(LodCommand, StepFromOff) {
    const fs::path d = temp_dir("step");
    write(d / "ball.off", off_text(icosphere(2)));
    CommandRun r = run(lod(d / "ball.off", d / "out.glb", "--step 100"));
    ASSERT_EQ(r.code, 0) << r.output;
    const std::vector<size_t> tris = level_triangles(d / "out.glb");
    ASSERT_EQ(tris.size(), 4u);  // 320, 220, 120, 20
    EXPECT_LE(tris[1], 220u);
    EXPECT_LE(tris[3], 20u);
}

TEST(LodCommand, RepairsWithAWarning) {
    const fs::path d = temp_dir("repair");
    const Sphere s = icosphere(2);
    std::string obj = obj_text(s);
    // degenerate, duplicate (the first face again), unreferenced
    obj += "f 1 1 2\nf " + std::to_string(s.f[0][0] + 1) + " " + std::to_string(s.f[0][1] + 1) +
           " " + std::to_string(s.f[0][2] + 1) + "\nv 9 9 9\n";
    write(d / "ball.obj", obj);
    CommandRun r = run(lod(d / "ball.obj", d / "out.glb", "--ratios 0.5"));
    ASSERT_EQ(r.code, 0) << r.output;
    EXPECT_NE(r.output.find("warning"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("degenerate"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("duplicate"), std::string::npos) << r.output;
    EXPECT_EQ(level_triangles(d / "out.glb").at(0), 320u);
}

void expect_fails(const fs::path& in, const std::string& extra,
                  std::initializer_list<std::string> parts) {
    const fs::path out = in.parent_path() / "out.glb";
    const fs::path report = in.parent_path() / "r.json";
    CommandRun r = run(lod(in, out, extra + " --report " + report.string()));
    EXPECT_NE(r.code, 0) << r.output;
    for (const std::string& part : parts)
        EXPECT_NE(r.output.find(part), std::string::npos) << part << " in: " << r.output;
    EXPECT_FALSE(fs::exists(out)) << r.output;
    EXPECT_FALSE(fs::exists(report)) << r.output;
}

TEST(LodCommand, RejectsBadInputWithoutWriting) {
    const fs::path d = temp_dir("bad");
    write(d / "nan.obj", "v 0 0 0\nv 1 0 0\nv nan 1 0\nf 1 2 3\n");
    expect_fails(d / "nan.obj", "--ratios 0.5", {"nan.obj:3"});
    write(d / "nan.ply",
          "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
          "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
          "0 0 0\n1 0 0\n0 inf 0\n3 0 1 2\n");
    expect_fails(d / "nan.ply", "--ratios 0.5", {"primitive 0", "vertex 2", "non-finite"});
    write(d / "empty.obj", "");
    expect_fails(d / "empty.obj", "--ratios 0.5", {"empty.obj"});
    write(d / "range.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n");
    expect_fails(d / "range.off", "--ratios 0.5", {"range.off", "out of range"});
    std::string ply = ply_binary(icosphere(1));
    ply.resize(ply.size() - 5);
    write(d / "cut.ply", ply);
    expect_fails(d / "cut.ply", "--ratios 0.5", {"cut.ply", "truncated"});
    write(d / "flat.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n");
    expect_fails(d / "flat.obj", "--ratios 0.5", {"degenerate"});
    write(d / "ball.obj", obj_text(icosphere(1)));
    expect_fails(d / "ball.obj", "--ratios 0.1,0.5", {"decreasing"});
    expect_fails(d / "ball.obj", "--ratios 0.5 --algorithm nope", {"nope"});
    expect_fails(d / "ball.obj", "--error x", {"--error"});
    write(d / "notes.txt", "hello\n");
    expect_fails(d / "notes.txt", "--ratios 0.5", {"notes.txt"});
    expect_fails(d / "missing.obj", "--ratios 0.5", {"missing.obj"});
}

// Inputs the mesh-file fuzz harness found (tests/fuzz/mesh_file_fuzz.cpp): indices and counts that
// do not fit an integer, and an element of no properties with a huge count.
TEST(LodCommand, RejectsUnrepresentableNumbersAndEmptyElements) {
    const fs::path d = temp_dir("fuzzed");
    write(d / "big.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 4.4e55\n");
    expect_fails(d / "big.off", "--ratios 0.5", {"big.off", "out of range"});
    write(d / "nan.off", "OFF\nnan 1 0\n0 0 0\n");
    expect_fails(d / "nan.off", "--ratios 0.5", {"nan.off", "bad counts"});
    write(d / "corners.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n1e300 0 1 2\n");
    expect_fails(d / "corners.off", "--ratios 0.5", {"corners.off", "corner count"});
    write(d / "big.ply",
          "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
          "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
          "element nothing 999999999999999\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 1e30\n");
    expect_fails(d / "big.ply", "--ratios 0.5", {"big.ply", "out of range"});
}

TEST(LodCommand, StepNeedsAnEdgeCollapseAlgorithm) {
    CommandRun list = run(kTool + " lod --list-algorithms");
    std::string other;
    std::istringstream lines(list.output);
    for (std::string line; std::getline(lines, line);) {
        std::istringstream w(line);
        std::string name, collapse;
        w >> name >> collapse;
        if (collapse == "no") other = name;
    }
    if (other.empty()) GTEST_SKIP() << "no algorithm that is not an edge collapse is registered";
    const fs::path d = temp_dir("stepbad");
    write(d / "ball.obj", obj_text(icosphere(1)));
    expect_fails(d / "ball.obj", "--step 10 --algorithm " + other, {"edge-collapse"});
}

// ---- progressive meshes: `lod --progressive`, `pm info`, `pm refine` ----

using PositionSet = std::set<std::array<float, 3>>;

struct MeshSummary {
    size_t triangles = 0;
    PositionSet positions;
};

MeshSummary summary_of(const hmdnode::Mesh& m) {
    MeshSummary s;
    for (const hmdnode::Primitive& p : m.primitives) {
        s.triangles += p.triangle_count();
        for (const glm::vec3& v : p.positions) s.positions.insert({v.x, v.y, v.z});
    }
    return s;
}

// The mesh called `name` in a .glb.
MeshSummary glb_mesh(const fs::path& glb, const std::string& name) {
    hmdnode::Result<hmdnode::Scene> s = hmdnode::load_gltf(glb);
    EXPECT_TRUE(s.ok()) << (s.ok() ? "" : s.error().message);
    if (!s.ok()) return {};
    for (const hmdnode::Mesh& m : s->meshes)
        if (m.name == name) return summary_of(m);
    ADD_FAILURE() << "no mesh " << name << " in " << glb;
    return {};
}

// Triangles and positions of an OBJ that `pm refine` wrote.
MeshSummary obj_mesh(const fs::path& obj) {
    MeshSummary s;
    std::ifstream f(obj);
    for (std::string line; std::getline(f, line);) {
        std::istringstream w(line);
        std::string key;
        w >> key;
        if (key == "v") {
            std::array<float, 3> v{};
            w >> v[0] >> v[1] >> v[2];
            s.positions.insert(v);
        } else if (key == "f") {
            ++s.triangles;
        }
    }
    return s;
}

std::string pm_refine(const fs::path& in, size_t triangles, const fs::path& out) {
    return kTool + " pm refine --in " + in.string() + " --triangles " + std::to_string(triangles) +
           " --out " + out.string();
}

// `--progressive` then `pm refine` at each level's count gives that level of the chain (same
// triangles, same positions), as .glb and as .obj; for melax (greedy order) also at counts that
// are not levels, equal to what `lod --triangles N` makes on its own.
void check_progressive(const std::string& algorithm) {
    const fs::path d = temp_dir("progressive_" + algorithm);
    write(d / "ball.obj", obj_text(icosphere(3)));
    CommandRun r =
        run(lod(d / "ball.obj", d / "out.glb",
                "--algorithm " + algorithm + " --triangles 600,300,100 --progressive " +
                    (d / "ball.hmpm").string() + " --report " + (d / "r.json").string()));
    ASSERT_EQ(r.code, 0) << r.output;
    ASSERT_TRUE(fs::exists(d / "ball.hmpm")) << r.output;
    std::ifstream rf(d / "r.json");
    const nlohmann::json j = nlohmann::json::parse(rf);
    ASSERT_EQ(j["progressive"].size(), 1u);
    EXPECT_EQ(j["progressive"][0]["full_triangles"].get<size_t>(), 1280u);
    const size_t base = j["progressive"][0]["base_triangles"].get<size_t>();
    EXPECT_LE(base, 100u);
    EXPECT_EQ(base, j["levels"][3]["triangles"].get<size_t>());

    CommandRun info = run(kTool + " pm info " + (d / "ball.hmpm").string());
    ASSERT_EQ(info.code, 0) << info.output;
    EXPECT_NE(info.output.find("full triangles   1280"), std::string::npos) << info.output;
    EXPECT_NE(info.output.find("base triangles   " + std::to_string(base)), std::string::npos)
        << info.output;
    EXPECT_NE(info.output.find("vertex splits"), std::string::npos) << info.output;
    EXPECT_NE(info.output.find("normal"), std::string::npos) << info.output;

    const std::vector<size_t> targets = {600, 300, 100};
    for (size_t k = 0; k < targets.size(); ++k) {
        const MeshSummary level = glb_mesh(d / "out.glb", "ball_lod" + std::to_string(k + 1));
        ASSERT_GT(level.triangles, 0u);
        const fs::path glb = d / ("r" + std::to_string(targets[k]) + ".glb");
        CommandRun rr = run(pm_refine(d / "ball.hmpm", targets[k], glb));
        ASSERT_EQ(rr.code, 0) << rr.output;
        EXPECT_NE(rr.output.find("written " + std::to_string(level.triangles) + " triangles"),
                  std::string::npos)
            << rr.output;
        const MeshSummary from_glb = glb_mesh(glb, glb.stem().string());
        EXPECT_EQ(from_glb.triangles, level.triangles) << targets[k];
        EXPECT_EQ(from_glb.positions, level.positions) << targets[k];
        const fs::path obj = d / ("r" + std::to_string(targets[k]) + ".obj");
        ASSERT_EQ(run(pm_refine(d / "ball.hmpm", targets[k], obj)).code, 0);
        const MeshSummary from_obj = obj_mesh(obj);
        EXPECT_EQ(from_obj.triangles, level.triangles) << targets[k];
        EXPECT_EQ(from_obj.positions, level.positions) << targets[k];
    }
    for (size_t n : {size_t(450), size_t(150)}) {
        const fs::path glb = d / ("n" + std::to_string(n) + ".glb");
        ASSERT_EQ(run(pm_refine(d / "ball.hmpm", n, glb)).code, 0);
        const MeshSummary refined = glb_mesh(glb, glb.stem().string());
        EXPECT_LE(refined.triangles, n);
        EXPECT_GE(refined.triangles, n - 2);  // a collapse removes at most two triangles here
        if (algorithm != "melax") continue;
        const fs::path one = d / ("one" + std::to_string(n) + ".glb");
        ASSERT_EQ(
            run(lod(d / "ball.obj", one, "--algorithm melax --triangles " + std::to_string(n)))
                .code,
            0);
        const MeshSummary level = glb_mesh(one, "ball_lod1");
        EXPECT_EQ(refined.triangles, level.triangles) << n;
        EXPECT_EQ(refined.positions, level.positions) << n;
    }
    // Below the base: the base; above the full count: the full mesh.
    ASSERT_EQ(run(pm_refine(d / "ball.hmpm", 1, d / "low.glb")).code, 0);
    EXPECT_EQ(glb_mesh(d / "low.glb", "low").triangles, base);
    ASSERT_EQ(run(pm_refine(d / "ball.hmpm", 100000, d / "high.glb")).code, 0);
    EXPECT_EQ(glb_mesh(d / "high.glb", "high").triangles, 1280u);
}

TEST(LodCommand, ProgressiveRefinesToTheChainLevels) {
    check_progressive("qem");
}

TEST(LodCommand, ProgressiveRefinesToAnyCountForAGreedyAlgorithm) {
    check_progressive("melax");
}

// The OBJ that `pm refine` writes carries the same texture coordinates as its .glb: OBJ's v runs
// up the image, glTF's down, and hmdnode's own OBJ reader turns it back.
TEST(LodCommand, ProgressiveObjKeepsTheTextureCoordinates) {
    const fs::path d = temp_dir("progressive_uv");
    std::ostringstream o;
    const int n = 6;  // a flat n x n grid with u = x / n, v = y / n
    for (int y = 0; y <= n; ++y)
        for (int x = 0; x <= n; ++x) o << "v " << x << ' ' << y << " 0\n";
    for (int y = 0; y <= n; ++y)
        for (int x = 0; x <= n; ++x) o << "vt " << double(x) / n << ' ' << double(y) / n << '\n';
    auto id = [](int x, int y) { return y * (n + 1) + x + 1; };
    for (int y = 0; y < n; ++y) {
        for (int x = 0; x < n; ++x) {
            const int a = id(x, y), b = id(x + 1, y), c = id(x + 1, y + 1), e = id(x, y + 1);
            o << "f " << a << '/' << a << ' ' << b << '/' << b << ' ' << c << '/' << c << '\n';
            o << "f " << a << '/' << a << ' ' << c << '/' << c << ' ' << e << '/' << e << '\n';
        }
    }
    write(d / "grid.obj", o.str());
    CommandRun r = run(lod(d / "grid.obj", d / "out.glb",
                           "--triangles 20 --progressive " + (d / "grid.hmpm").string()));
    ASSERT_EQ(r.code, 0) << r.output;
    ASSERT_EQ(run(pm_refine(d / "grid.hmpm", 40, d / "r.glb")).code, 0);
    ASSERT_EQ(run(pm_refine(d / "grid.hmpm", 40, d / "r.obj")).code, 0);
    hmdnode::Result<hmdnode::Scene> glb = hmdnode::load_gltf(d / "r.glb");
    hmdnode::Result<hmdnode::Mesh> obj = hmdnode::load_obj(d / "r.obj");
    ASSERT_TRUE(glb.ok()) << glb.error().message;
    ASSERT_TRUE(obj.ok()) << obj.error().message;
    // position -> uv0 of every corner, from each file
    auto uvs = [](const hmdnode::Primitive& p) {
        std::map<std::array<float, 3>, std::array<float, 2>> m;
        for (size_t i = 0; i < p.positions.size(); ++i) {
            const glm::vec3 v = p.positions[i];
            m[{v.x, v.y, v.z}] = {p.uv0[i].x, p.uv0[i].y};
        }
        return m;
    };
    const auto from_glb = uvs(glb->meshes.at(0).primitives.at(0));
    const auto from_obj = uvs(obj->primitives.at(0));
    ASSERT_EQ(from_glb.size(), from_obj.size());
    for (const auto& [pos, uv] : from_glb) {
        ASSERT_TRUE(from_obj.count(pos)) << pos[0] << ' ' << pos[1];
        EXPECT_NEAR(from_obj.at(pos)[0], uv[0], 1e-6f);
        EXPECT_NEAR(from_obj.at(pos)[1], uv[1], 1e-6f);
        // and both are the input's: u = x / n, v (glTF, down the image) = 1 - y / n
        EXPECT_NEAR(uv[0], pos[0] / n, 1e-6f);
        EXPECT_NEAR(uv[1], 1.0f - pos[1] / n, 1e-6f);
    }
}

TEST(LodCommand, ProgressiveRejectsBadFilesWithoutWriting) {
    const fs::path d = temp_dir("progressive_bad");
    write(d / "ball.obj", obj_text(icosphere(2)));
    ASSERT_EQ(run(lod(d / "ball.obj", d / "out.glb",
                      "--ratios 0.2 --progressive " + (d / "ball.hmpm").string()))
                  .code,
              0);
    std::ifstream f(d / "ball.hmpm", std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    ASSERT_GT(bytes.size(), 100u);
    // Cut in the header, in the base mesh, in the splits and by one byte; then a bad magic.
    std::vector<std::string> bad;
    for (size_t cut : {size_t(10), size_t(60), bytes.size() / 2, bytes.size() - 1})
        bad.push_back(bytes.substr(0, cut));
    bad.push_back("XMPM" + bytes.substr(4));
    for (size_t i = 0; i < bad.size(); ++i) {
        const fs::path in = d / ("bad" + std::to_string(i) + ".hmpm");
        write(in, bad[i]);
        for (const char* ext : {".glb", ".obj"}) {
            const fs::path out = d / (std::string("refined") + ext);
            CommandRun r = run(pm_refine(in, 100, out));
            EXPECT_NE(r.code, 0) << i << r.output;
            EXPECT_NE(r.output.find("byte "), std::string::npos) << i << r.output;
            EXPECT_NE(r.output.find(in.filename().string()), std::string::npos) << r.output;
            EXPECT_FALSE(fs::exists(out)) << i << r.output;
        }
        CommandRun info = run(kTool + " pm info " + in.string());
        EXPECT_NE(info.code, 0) << info.output;
        EXPECT_NE(info.output.find("byte "), std::string::npos) << info.output;
    }
    CommandRun ext = run(pm_refine(d / "ball.hmpm", 100, d / "refined.ply"));
    EXPECT_NE(ext.code, 0) << ext.output;
    EXPECT_FALSE(fs::exists(d / "refined.ply"));
}

TEST(LodCommand, ProgressiveNeedsAnEdgeCollapseAlgorithm) {
    const fs::path d = temp_dir("progressive_algo");
    write(d / "ball.obj", obj_text(icosphere(1)));
    expect_fails(d / "ball.obj",
                 "--ratios 0.5 --algorithm grid --progressive " + (d / "ball.hmpm").string(),
                 {"--progressive", "edge-collapse"});
    EXPECT_FALSE(fs::exists(d / "ball.hmpm"));
}

// A .glb of two sphere meshes, "small" (320 triangles) and "large" (1280), one node each.
void write_two_meshes(const fs::path& glb) {
    hmdnode::Scene scene;
    for (int m = 0; m < 2; ++m) {
        const Sphere s = icosphere(2 + m);
        hmdnode::Primitive p;
        for (auto& v : s.v) p.positions.emplace_back(v[0], v[1], v[2]);
        for (auto& f : s.f) p.indices.insert(p.indices.end(), {f[0], f[1], f[2]});
        hmdnode::Mesh mesh;
        mesh.name = m == 0 ? "small" : "large";
        mesh.primitives.push_back(std::move(p));
        scene.meshes.push_back(std::move(mesh));
        hmdnode::Node node;
        node.name = scene.meshes.back().name;
        node.mesh = m;
        node.translation = glm::dvec3(3.0 * m, 0.0, 0.0);
        scene.nodes.push_back(std::move(node));
        scene.roots.push_back(m);
    }
    ASSERT_TRUE(hmdnode::save_glb(scene, glb).ok());
}

TEST(LodCommand, ProgressiveWritesOneFilePerMesh) {
    const fs::path d = temp_dir("progressive_scene");
    write_two_meshes(d / "two.glb");
    CommandRun r = run(lod(d / "two.glb", d / "out.glb",
                           "--ratios 0.25 --progressive " + (d / "two.hmpm").string()));
    ASSERT_EQ(r.code, 0) << r.output;
    EXPECT_FALSE(fs::exists(d / "two.hmpm"));
    for (const auto& [name, full] : {std::pair<std::string, size_t>{"small", 320},
                                     std::pair<std::string, size_t>{"large", 1280}}) {
        const fs::path f = d / ("two." + name + ".hmpm");
        ASSERT_TRUE(fs::exists(f)) << r.output;
        CommandRun info = run(kTool + " pm info " + f.string());
        EXPECT_EQ(info.code, 0) << info.output;
        EXPECT_NE(info.output.find("full triangles   " + std::to_string(full)), std::string::npos)
            << info.output;
        EXPECT_NE(info.output.find("base triangles   " + std::to_string(full / 4)),
                  std::string::npos)
            << info.output;
    }
}

// The files in `dir`, hidden ones (temporaries) included.
std::set<std::string> files_in(const fs::path& dir) {
    std::set<std::string> out;
    for (const fs::directory_entry& e : fs::directory_iterator(dir))
        out.insert(e.path().filename().string());
    return out;
}

// An output that cannot be written fails the command before the work, and none of its outputs is
// left behind: not the .glb, not a progressive mesh, not a temporary file.
TEST(LodCommand, AnOutputThatCannotBeWrittenLeavesNoOutput) {
    const fs::path d = temp_dir("unwritable");
    write(d / "ball.obj", obj_text(icosphere(2)));
    fs::create_directory(d / "taken.json");
    const std::string out = (d / "out.glb").string();
    const std::vector<std::pair<std::string, std::string>> cases = {
        {"--report " + (d / "missing" / "r.json").string(), "does not exist"},
        {"--report " + (d / "taken.json").string(), "is a directory"},
        {"--report " + out, "same file"},
        {"--report " + (d / "r.json").string() + " --progressive " +
             (d / "missing" / "ball.hmpm").string(),
         "does not exist"},
        {"--progressive " + (d / "taken.json").string(), "is a directory"},
    };
    for (const auto& [extra, message] : cases) {
        CommandRun r = run(lod(d / "ball.obj", out, "--ratios 0.5 " + extra));
        EXPECT_EQ(r.code, 1) << extra << ": " << r.output;
        EXPECT_NE(r.output.find(message), std::string::npos) << extra << ": " << r.output;
        EXPECT_NE(r.output.find("nothing written"), std::string::npos) << r.output;
        EXPECT_EQ(files_in(d), (std::set<std::string>{"ball.obj", "taken.json"})) << extra;
    }
}

// The progressive meshes' names are known only after the work (one per mesh): one that cannot be
// written fails the command before any output is written.
TEST(LodCommand, AProgressiveFileThatCannotBeWrittenLeavesNoOutput) {
    const fs::path d = temp_dir("unwritable_pm");
    write_two_meshes(d / "two.glb");
    fs::create_directory(d / "two.large.hmpm");
    CommandRun r = run(lod(d / "two.glb", d / "out.glb",
                           "--ratios 0.25 --progressive " + (d / "two.hmpm").string() +
                               " --report " + (d / "r.json").string()));
    EXPECT_EQ(r.code, 1) << r.output;
    EXPECT_NE(r.output.find("two.large.hmpm"), std::string::npos) << r.output;
    EXPECT_EQ(files_in(d), (std::set<std::string>{"two.glb", "two.large.hmpm"})) << r.output;
}

}  // namespace
