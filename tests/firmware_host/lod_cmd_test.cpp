// `hmdnode lod` as a user runs it: each input format and target kind, the report, and bad input
// (non-zero exit, a message naming the problem, no output file).
#include <gtest/gtest.h>

#include <sys/wait.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "hmdnode/core/gltf.hpp"

namespace fs = std::filesystem;

namespace {

struct CommandRun {
    int code = -1;
    std::string output;  // stdout and stderr
};

CommandRun run(const std::string& cmd) {
    CommandRun r;
    FILE* p = popen((cmd + " 2>&1").c_str(), "r");
    if (!p) return r;
    std::array<char, 4096> buf;
    size_t n;
    while ((n = fread(buf.data(), 1, buf.size(), p)) > 0) r.output.append(buf.data(), n);
    int st = pclose(p);
    r.code = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
    return r;
}

fs::path temp_dir(const std::string& name) {
    fs::path d = fs::temp_directory_path() / ("hmdnode_lod_cmd_test_" + name);
    fs::remove_all(d);
    fs::create_directories(d);
    return d;
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
          "mean_m", "mean_pct_diag", "simplify_ms", "measure_ms"})
        EXPECT_TRUE(j["levels"][1].contains(key)) << key;
    EXPECT_EQ(j["levels"][2]["triangles"].get<size_t>(), tris[2]);
    EXPECT_GT(j["levels"][2]["error_m"].get<double>(), j["levels"][1]["error_m"].get<double>());
    EXPECT_EQ(j["levels"][0]["error_m"].get<double>(), 0.0);
    EXPECT_EQ(j["repair"]["degenerate_faces"], 0);
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
    EXPECT_LE(j["levels"][1]["error_m"].get<double>(), 0.05 * 1.05);
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

}  // namespace
