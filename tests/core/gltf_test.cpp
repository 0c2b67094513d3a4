// glTF I/O: round trip of the scene model through .glb, the JSON path with data URIs, and the
// precise errors load_gltf gives for broken files.
#include "hmdnode/core/gltf.hpp"

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <numbers>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <glm/gtc/matrix_transform.hpp>
#include <nlohmann/json.hpp>

namespace hmdnode {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

class TempDir {
  public:
    TempDir() {
        static std::atomic<int> counter{0};
        path_ = fs::temp_directory_path() / ("hmdnode_gltf_test_" + std::to_string(::getpid()) +
                                             "_" + std::to_string(counter++));
        fs::remove_all(path_);
        fs::create_directories(path_);
    }
    ~TempDir() {
        std::error_code ec;
        fs::remove_all(path_, ec);
    }
    const fs::path& path() const { return path_; }
    fs::path operator/(const std::string& name) const { return path_ / name; }

  private:
    fs::path path_;
};

void write_bytes(const fs::path& path, const std::string& bytes) {
    std::ofstream out(path, std::ios::binary);
    out.write(bytes.data(), std::streamsize(bytes.size()));
}

std::string read_bytes(const fs::path& path) {
    std::ifstream in(path, std::ios::binary);
    std::ostringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

std::string base64(const std::string& bytes) {
    static const char* abc = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string out;
    size_t i = 0;
    for (; i + 2 < bytes.size(); i += 3) {
        const uint32_t v = uint32_t(uint8_t(bytes[i])) << 16 |
                           uint32_t(uint8_t(bytes[i + 1])) << 8 | uint8_t(bytes[i + 2]);
        for (int s = 18; s >= 0; s -= 6) out += abc[(v >> s) & 63];
    }
    if (i < bytes.size()) {
        uint32_t v = uint32_t(uint8_t(bytes[i])) << 16;
        if (i + 1 < bytes.size()) v |= uint32_t(uint8_t(bytes[i + 1])) << 8;
        out += abc[(v >> 18) & 63];
        out += abc[(v >> 12) & 63];
        out += i + 1 < bytes.size() ? abc[(v >> 6) & 63] : '=';
        out += '=';
    }
    return out;
}

template <class T>
std::string raw(const std::vector<T>& v) {
    return std::string(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
}

// A one-mesh .gltf: POSITION (accessor 0) and, if given, UNSIGNED_SHORT indices (accessor 1) in
// one data-URI buffer.
Json mesh_doc(const std::vector<float>& positions, const std::vector<uint16_t>& indices,
              int mode = 4) {
    std::string buf = raw(positions);
    const size_t index_offset = buf.size();
    buf += raw(indices);
    Json doc = {
        {"asset", {{"version", "2.0"}}},
        {"buffers",
         {{{"byteLength", buf.size()},
           {"uri", "data:application/octet-stream;base64," + base64(buf)}}}},
        {"bufferViews", {{{"buffer", 0}, {"byteOffset", 0}, {"byteLength", index_offset}}}},
        {"accessors",
         {{{"bufferView", 0},
           {"componentType", 5126},
           {"count", positions.size() / 3},
           {"type", "VEC3"}}}},
        {"meshes",
         {{{"name", "m"}, {"primitives", {{{"attributes", {{"POSITION", 0}}}, {"mode", mode}}}}}}},
        {"nodes", {{{"mesh", 0}}}},
        {"scenes", {{{"nodes", {0}}}}},
        {"scene", 0},
    };
    if (!indices.empty()) {
        doc["bufferViews"].push_back(
            {{"buffer", 0}, {"byteOffset", index_offset}, {"byteLength", indices.size() * 2}});
        doc["accessors"].push_back({{"bufferView", 1},
                                    {"componentType", 5123},
                                    {"count", indices.size()},
                                    {"type", "SCALAR"}});
        doc["meshes"][0]["primitives"][0]["indices"] = 1;
    }
    return doc;
}

const std::vector<float> kQuad = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};

Texture make_texture(const std::string& name, int w, int h, uint8_t seed) {
    Texture t;
    t.name = name;
    t.width = w;
    t.height = h;
    for (int i = 0; i < w * h * 4; ++i) t.rgba8.push_back(uint8_t(seed + i * 37));
    return t;
}

// The scene of the round trip: a lightmapped building with a three-level LOD chain under a
// rotated and scaled root, and a point light.
Scene make_scene() {
    Scene s;
    s.textures.push_back(make_texture("lightmap", 4, 4, 3));
    s.textures.push_back(make_texture("albedo", 2, 2, 200));

    Material lit;
    lit.name = "lightmapped";
    lit.base_color_factor = {0.8f, 0.7f, 0.6f, 1.0f};
    lit.base_color_texture = 1;
    lit.lightmap = {0, 1, 2.5f};
    lit.double_sided = true;
    lit.emissive_factor = {0.25f, 0.5f, 0.125f};
    Material plain;
    plain.name = "plain";
    plain.emissive_factor = {17.0f, 12.3f, 0.1f};  // above glTF's [0, 1]: emissive strength
    s.materials = {lit, plain};

    Mesh quad;
    quad.name = "quad";
    Primitive p;
    p.positions = {{-1, -1, 0}, {1, -1, 0}, {1, 1, 0.25f}, {-1, 1, 0}};
    p.normals = {{0, 0, 1}, {0, 0, 1}, {0, 0.6f, 0.8f}, {0, 0, 1}};
    p.uv0 = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    p.uv1 = {{0.125f, 0.125f}, {0.875f, 0.125f}, {0.875f, 0.875f}, {0.125f, 0.875f}};
    p.colors = {{0.5f, 0.25f, 0.1f, 1}, {0, 0, 0, 1}, {0.75f, 1, 1, 0.5f}, {0.2f, 0.3f, 0.4f, 1}};
    p.light = {{1.5f, 2.25f, 0.1f}, {0, 0, 0}, {83.75f, 1e-4f, 1}, {0.2f, 0.3f, 0.4f}};
    p.indices = {0, 1, 2, 0, 2, 3};
    p.material = 0;
    quad.primitives.push_back(p);

    Mesh tri;
    tri.name = "quad_lod1";
    Primitive t;
    t.positions = {{-1, -1, 0}, {1, -1, 0}, {0, 1, 0}};
    t.normals = {{0, 0, 1}, {0, 0, 1}, {0, 0, 1}};
    t.indices = {0, 1, 2};
    t.material = 1;
    tri.primitives.push_back(t);
    Mesh tri2 = tri;
    tri2.name = "quad_lod2";
    tri2.primitives[0].positions[2] = {0, 0.5f, 0};
    s.meshes = {quad, tri, tri2};

    Node root;
    root.name = "root";
    root.translation = {1, 2, 3};
    root.rotation = glm::angleAxis(0.5, glm::normalize(glm::dvec3(1, 1, 0)));
    root.scale = {2, 2, 2};
    root.children = {1, 4};
    Node building;
    building.name = "building";
    building.translation = {0, 0, -5};
    building.rotation = glm::angleAxis(1.0, glm::dvec3(0, 1, 0));
    building.scale = {1, 0.5, 1};
    building.mesh = 0;
    building.lod_ids = {2, 3};
    building.screen_coverage = {0.5, 0.2, 0.05};
    building.geometric_error_m = 0.0;
    Node lod1;
    lod1.name = "building_lod1";
    lod1.mesh = 1;
    lod1.geometric_error_m = 0.01;
    Node lod2;
    lod2.name = "building_lod2";
    lod2.mesh = 2;
    lod2.geometric_error_m = 0.04;
    Node lamp;
    lamp.name = "lamp";
    lamp.translation = {0, 3, 0};
    s.nodes = {root, building, lod1, lod2, lamp};
    s.roots = {0};

    Light light;
    light.name = "bulb";
    light.type = Light::Type::Point;
    light.color = {1.0f, 0.9f, 0.8f};
    light.intensity = 40.0f;
    light.range = 10.0f;
    light.node = 4;
    s.lights = {light};
    return s;
}

void expect_near(const glm::dvec3& a, const glm::dvec3& b, double eps) {
    EXPECT_NEAR(a.x, b.x, eps);
    EXPECT_NEAR(a.y, b.y, eps);
    EXPECT_NEAR(a.z, b.z, eps);
}

// The error of loading `text` written as `name`: it must start with the file's path.
std::string load_error(const TempDir& dir, const std::string& name, const std::string& text) {
    const fs::path path = dir / name;
    write_bytes(path, text);
    Result<Scene> r = load_gltf(path);
    EXPECT_FALSE(r.ok()) << name << " loaded";
    if (getenv("GLTF_TEST_PRINT") && !r.ok()) printf("%s\n", r.error().message.c_str());
    if (r.ok()) return {};
    const std::string& msg = r.error().message;
    EXPECT_EQ(msg.rfind(path.string(), 0), 0u) << msg;
    return msg;
}

TEST(Gltf, RoundTripsTheSceneModelThroughGlb) {
    TempDir dir;
    const Scene in = make_scene();
    const fs::path path = dir / "scene.glb";
    Status saved = save_glb(in, path);
    ASSERT_TRUE(saved.ok()) << saved.error().message;
    EXPECT_EQ(read_bytes(path).substr(0, 4), "glTF");

    Result<Scene> loaded = load_gltf(path);
    ASSERT_TRUE(loaded.ok()) << loaded.error().message;
    const Scene& out = *loaded;

    ASSERT_EQ(out.textures.size(), in.textures.size());
    for (size_t i = 0; i < in.textures.size(); ++i) {
        EXPECT_EQ(out.textures[i].name, in.textures[i].name);
        EXPECT_EQ(out.textures[i].width, in.textures[i].width);
        EXPECT_EQ(out.textures[i].height, in.textures[i].height);
        EXPECT_EQ(out.textures[i].rgba8, in.textures[i].rgba8);
    }
    ASSERT_EQ(out.materials.size(), 2u);
    const Material& lit = out.materials[0];
    EXPECT_EQ(lit.name, "lightmapped");
    EXPECT_EQ(lit.base_color_factor, in.materials[0].base_color_factor);
    EXPECT_EQ(lit.base_color_texture, 1);
    EXPECT_EQ(lit.lightmap.texture, 0);
    EXPECT_EQ(lit.lightmap.tex_coord, 1);
    EXPECT_FLOAT_EQ(lit.lightmap.intensity, 2.5f);
    EXPECT_TRUE(lit.double_sided);
    EXPECT_EQ(out.materials[1].lightmap.texture, -1);
    EXPECT_EQ(out.materials[1].base_color_texture, -1);
    EXPECT_FALSE(out.materials[1].double_sided);

    ASSERT_EQ(out.meshes.size(), in.meshes.size());
    for (size_t m = 0; m < in.meshes.size(); ++m) {
        EXPECT_EQ(out.meshes[m].name, in.meshes[m].name);
        ASSERT_EQ(out.meshes[m].primitives.size(), 1u);
        const Primitive& a = in.meshes[m].primitives[0];
        const Primitive& b = out.meshes[m].primitives[0];
        EXPECT_EQ(b.positions, a.positions);
        EXPECT_EQ(b.normals, a.normals);
        EXPECT_EQ(b.uv0, a.uv0);
        EXPECT_EQ(b.uv1, a.uv1);
        EXPECT_EQ(b.colors, a.colors);
        EXPECT_EQ(b.light, a.light);  // float: values above 1 survive exactly
        EXPECT_EQ(b.indices, a.indices);
        EXPECT_EQ(b.material, a.material);
    }
    EXPECT_EQ(out.meshes[0].primitives[0].light[2].x, 83.75f);
    for (size_t i = 0; i < in.materials.size(); ++i)  // power-of-two strength: exact
        EXPECT_EQ(out.materials[i].emissive_factor, in.materials[i].emissive_factor);

    ASSERT_EQ(out.nodes.size(), in.nodes.size());
    for (size_t i = 0; i < in.nodes.size(); ++i) {
        const Node& a = in.nodes[i];
        const Node& b = out.nodes[i];
        EXPECT_EQ(b.name, a.name);
        expect_near(b.translation, a.translation, 1e-12);
        EXPECT_NEAR(std::abs(glm::dot(b.rotation, a.rotation)), 1.0, 1e-12) << a.name;
        expect_near(b.scale, a.scale, 1e-12);
        EXPECT_EQ(b.mesh, a.mesh);
        EXPECT_EQ(b.children, a.children);
        EXPECT_EQ(b.lod_ids, a.lod_ids);
        EXPECT_EQ(b.screen_coverage, a.screen_coverage);
        EXPECT_EQ(b.geometric_error_m, a.geometric_error_m);
    }
    EXPECT_EQ(out.roots, in.roots);

    ASSERT_EQ(out.lights.size(), 1u);
    EXPECT_EQ(out.lights[0].name, "bulb");
    EXPECT_EQ(out.lights[0].type, Light::Type::Point);
    EXPECT_EQ(out.lights[0].color, in.lights[0].color);
    EXPECT_FLOAT_EQ(out.lights[0].intensity, 40.0f);
    EXPECT_FLOAT_EQ(out.lights[0].range, 10.0f);
    EXPECT_EQ(out.lights[0].node, 4);
}

TEST(Gltf, WritesTheExtensionsItUsesAndPositionBounds) {
    TempDir dir;
    const fs::path path = dir / "scene.glb";
    ASSERT_TRUE(save_glb(make_scene(), path).ok());
    const std::string glb = read_bytes(path);
    uint32_t json_length = 0;
    std::memcpy(&json_length, glb.data() + 12, 4);
    const Json doc = Json::parse(glb.substr(20, json_length));
    std::vector<std::string> used = doc["extensionsUsed"];
    std::sort(used.begin(), used.end());
    EXPECT_EQ(used,
              (std::vector<std::string>{"KHR_lights_punctual", "KHR_materials_emissive_strength",
                                        "MOZ_lightmap", "MSFT_lod"}));
    // Emission above 1: factor in [0, 1] times a power-of-two strength.
    EXPECT_EQ(
        doc["materials"][1]["extensions"]["KHR_materials_emissive_strength"]["emissiveStrength"],
        32.0);
    EXPECT_EQ(doc["materials"][1]["emissiveFactor"][0], 17.0 / 32.0);
    EXPECT_FALSE(doc["materials"][0].contains("extensions") &&
                 doc["materials"][0]["extensions"].contains("KHR_materials_emissive_strength"));
    // Baked light: _LIGHT_0, float VEC3.
    const int light = doc["meshes"][0]["primitives"][0]["attributes"]["_LIGHT_0"];
    EXPECT_EQ(doc["accessors"][light]["type"], "VEC3");
    EXPECT_EQ(doc["accessors"][light]["componentType"], 5126);
    const int pos = doc["meshes"][0]["primitives"][0]["attributes"]["POSITION"];
    EXPECT_EQ(doc["accessors"][pos]["min"], Json({-1.0, -1.0, 0.0}));
    EXPECT_EQ(doc["accessors"][pos]["max"], Json({1.0, 1.0, 0.25}));
    EXPECT_EQ(doc["nodes"][2]["extras"]["geometric_error"], 0.01);
    EXPECT_EQ(doc["nodes"][1]["extras"]["geometric_error"], 0.0);
    EXPECT_FALSE(doc["nodes"][0].contains("extras"));  // geometric_error_m < 0: absent
    EXPECT_EQ(doc["images"][0]["mimeType"], "image/png");
}

// MOZ_lightmap.extras.encoding: "RGBM" is written for RGBM lightmaps and read back; files
// without it (all older ones) read as linear; another value is an error naming the material.
TEST(Gltf, LightmapEncodingRoundTripsAndOldFilesReadAsLinear) {
    TempDir dir;
    Scene in = make_scene();
    ASSERT_EQ(in.materials[0].lightmap.encoding, LightmapEncoding::Linear);
    const fs::path linear = dir / "linear.glb", rgbm = dir / "rgbm.glb";
    ASSERT_TRUE(save_glb(in, linear).ok());
    in.materials[0].lightmap.encoding = LightmapEncoding::Rgbm;
    ASSERT_TRUE(save_glb(in, rgbm).ok());
    auto json_of = [](const std::string& glb) {
        uint32_t json_length = 0;
        std::memcpy(&json_length, glb.data() + 12, 4);
        return Json::parse(glb.substr(20, json_length));
    };
    const Json a = json_of(read_bytes(linear)), b = json_of(read_bytes(rgbm));
    EXPECT_FALSE(a["materials"][0]["extensions"]["MOZ_lightmap"].contains("extras"));
    EXPECT_EQ(b["materials"][0]["extensions"]["MOZ_lightmap"]["extras"]["encoding"], "RGBM");
    Result<Scene> la = load_gltf(linear), lb = load_gltf(rgbm);
    ASSERT_TRUE(la.ok() && lb.ok());
    EXPECT_EQ(la->materials[0].lightmap.encoding, LightmapEncoding::Linear);
    EXPECT_EQ(lb->materials[0].lightmap.encoding, LightmapEncoding::Rgbm);

    Json doc = Json::parse(
        read_bytes(fs::path(HMDNODE_SOURCE_DIR) / "tests/data/gltf/triangle_data_uri.gltf"));
    doc["materials"][0]["extensions"]["MOZ_lightmap"] = {{"index", 0},
                                                         {"extras", {{"encoding", "LogLuv"}}}};
    const std::string msg = load_error(dir, "encoding.gltf", doc.dump());
    EXPECT_NE(msg.find("MOZ_lightmap: extras.encoding is not \"linear\" or \"RGBM\""),
              std::string::npos)
        << msg;
    EXPECT_NE(msg.find("material 0"), std::string::npos) << msg;
}

TEST(Gltf, LoadedSceneFlattensIntoTheLodChain) {
    TempDir dir;
    const fs::path path = dir / "scene.glb";
    ASSERT_TRUE(save_glb(make_scene(), path).ok());
    Result<Scene> loaded = load_gltf(path);
    ASSERT_TRUE(loaded.ok()) << loaded.error().message;

    const std::vector<SceneObject> objects = flatten_objects(*loaded);
    ASSERT_EQ(objects.size(), 1u);  // the LOD alternates are levels, not objects
    const SceneObject& o = objects[0];
    EXPECT_EQ(o.name, "building");
    EXPECT_EQ(o.node, 1);
    ASSERT_EQ(o.levels.size(), 3u);
    EXPECT_EQ(o.levels[0].mesh, 0);
    EXPECT_EQ(o.levels[1].mesh, 1);
    EXPECT_EQ(o.levels[2].mesh, 2);
    EXPECT_EQ(o.levels[0].triangles, 2u);
    EXPECT_EQ(o.levels[1].triangles, 1u);
    // world scale = root's 2 x the building's largest axis 1
    EXPECT_NEAR(o.levels[0].geometric_error_m, 0.0, 1e-12);
    EXPECT_NEAR(o.levels[1].geometric_error_m, 0.02, 1e-12);
    EXPECT_NEAR(o.levels[2].geometric_error_m, 0.08, 1e-12);
    const Scene in = make_scene();
    const glm::dmat4 world = in.nodes[0].local_matrix() * in.nodes[1].local_matrix();
    for (int c = 0; c < 4; ++c)
        for (int r = 0; r < 4; ++r) EXPECT_NEAR(o.world[c][r], world[c][r], 1e-12);
}

TEST(Gltf, ReadsJsonWithDataUris) {
    const fs::path path = fs::path(HMDNODE_SOURCE_DIR) / "tests/data/gltf/triangle_data_uri.gltf";
    Result<Scene> r = load_gltf(path);
    ASSERT_TRUE(r.ok()) << r.error().message;
    const Scene& s = *r;
    ASSERT_EQ(s.meshes.size(), 1u);
    const Primitive& p = s.meshes[0].primitives[0];
    // interleaved: float POSITION + normalized UNSIGNED_BYTE COLOR_0, byteStride 16
    EXPECT_EQ(p.positions, (std::vector<glm::vec3>{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}));
    ASSERT_EQ(p.colors.size(), 3u);
    EXPECT_EQ(p.colors[0], glm::vec4(1, 0, 0, 1));
    EXPECT_FLOAT_EQ(p.colors[1].y, 128.0f / 255.0f);
    EXPECT_FLOAT_EQ(p.colors[2].w, 51.0f / 255.0f);
    EXPECT_EQ(p.indices, (std::vector<uint32_t>{0, 1, 2}));
    // no NORMAL in the file: computed
    ASSERT_EQ(p.normals.size(), 3u);
    for (const glm::vec3& n : p.normals) EXPECT_EQ(n, glm::vec3(0, 0, 1));
    EXPECT_TRUE(p.uv0.empty());
    EXPECT_EQ(p.material, 0);
    // the RGB PNG arrives as RGBA8
    ASSERT_EQ(s.textures.size(), 1u);
    EXPECT_EQ(s.textures[0].name, "checker");
    EXPECT_EQ(s.textures[0].width, 2);
    EXPECT_EQ(s.textures[0].height, 2);
    EXPECT_EQ(s.textures[0].rgba8, (std::vector<uint8_t>{255, 0, 0, 255, 0, 255, 0, 255, 0, 0, 255,
                                                         255, 10, 20, 30, 255}));
    EXPECT_EQ(s.materials[0].base_color_texture, 0);
    EXPECT_FLOAT_EQ(s.materials[0].base_color_factor.x, 0.5f);
    // the matrix decomposes into TRS; no "scenes": every parentless node is a root
    ASSERT_EQ(s.nodes.size(), 2u);
    expect_near(s.nodes[0].translation, {1, 2, 3}, 1e-12);
    expect_near(s.nodes[0].scale, {2, 2, 2}, 1e-12);
    EXPECT_NEAR(std::abs(s.nodes[0].rotation.w), 1.0, 1e-12);
    EXPECT_EQ(s.roots, (std::vector<int>{0, 1}));
    EXPECT_EQ(s.nodes[0].geometric_error_m, -1.0);
}

TEST(Gltf, DecomposesANodeMatrixIntoTrs) {
    TempDir dir;
    const glm::dquat q = glm::angleAxis(0.7, glm::normalize(glm::dvec3(0.3, -1, 0.5)));
    const glm::dmat4 m = glm::translate(glm::dmat4(1), glm::dvec3(-4, 5, 6)) * glm::mat4_cast(q) *
                         glm::scale(glm::dmat4(1), glm::dvec3(0.5, 3, 1.5));
    std::vector<double> flat;
    for (int c = 0; c < 4; ++c)
        for (int r = 0; r < 4; ++r) flat.push_back(m[c][r]);
    const Json doc = {{"asset", {{"version", "2.0"}}}, {"nodes", {{{"matrix", flat}}}}};
    write_bytes(dir / "matrix.gltf", doc.dump());
    Result<Scene> r = load_gltf(dir / "matrix.gltf");
    ASSERT_TRUE(r.ok()) << r.error().message;
    const Node& n = r->nodes[0];
    expect_near(n.translation, {-4, 5, 6}, 1e-12);
    expect_near(n.scale, {0.5, 3, 1.5}, 1e-12);
    EXPECT_NEAR(std::abs(glm::dot(n.rotation, q)), 1.0, 1e-12);
}

TEST(Gltf, KeepsTranslationAndScaleOfASingularMatrix) {
    TempDir dir;
    const std::vector<double> flat = {0, 0, 0, 0, 0, 2, 0, 0, 0, 0, 3, 0, 7, 8, 9, 1};  // x scale 0
    const Json doc = {{"asset", {{"version", "2.0"}}}, {"nodes", {{{"matrix", flat}}}}};
    write_bytes(dir / "singular.gltf", doc.dump());
    Result<Scene> r = load_gltf(dir / "singular.gltf");
    ASSERT_TRUE(r.ok()) << r.error().message;
    expect_near(r->nodes[0].translation, {7, 8, 9}, 1e-12);
    expect_near(r->nodes[0].scale, {0, 2, 3}, 1e-12);
}

TEST(Gltf, AppliesSparseAccessors) {
    TempDir dir;
    Json doc = mesh_doc(kQuad, {}, 5);
    const std::string buf =
        raw(kQuad) + raw(std::vector<uint16_t>{2, 0}) + raw(std::vector<float>{5, 6, 7});
    doc["buffers"][0] = {{"byteLength", buf.size()},
                         {"uri", "data:application/octet-stream;base64," + base64(buf)}};
    doc["bufferViews"].push_back({{"buffer", 0}, {"byteOffset", 48}, {"byteLength", 2}});
    doc["bufferViews"].push_back({{"buffer", 0}, {"byteOffset", 52}, {"byteLength", 12}});
    doc["accessors"][0]["sparse"] = {{"count", 1},
                                     {"indices", {{"bufferView", 1}, {"componentType", 5123}}},
                                     {"values", {{"bufferView", 2}}}};
    write_bytes(dir / "sparse.gltf", doc.dump());
    Result<Scene> r = load_gltf(dir / "sparse.gltf");
    ASSERT_TRUE(r.ok()) << r.error().message;
    const std::vector<glm::vec3>& p = r->meshes[0].primitives[0].positions;
    EXPECT_EQ(p, (std::vector<glm::vec3>{{0, 0, 0}, {1, 0, 0}, {5, 6, 7}, {0, 1, 0}}));

    doc["accessors"][0]["sparse"]["count"] = 9;  // more substitutions than the view holds
    write_bytes(dir / "sparse_bad.gltf", doc.dump());
    Result<Scene> bad = load_gltf(dir / "sparse_bad.gltf");
    ASSERT_FALSE(bad.ok());
    EXPECT_NE(bad.error().message.find("sparse"), std::string::npos) << bad.error().message;
}

TEST(Gltf, ExpandsStripsAndFansIntoTriangleLists) {
    TempDir dir;
    write_bytes(dir / "strip.gltf", mesh_doc(kQuad, {}, 5).dump());
    Result<Scene> strip = load_gltf(dir / "strip.gltf");
    ASSERT_TRUE(strip.ok()) << strip.error().message;
    EXPECT_EQ(strip->meshes[0].primitives[0].indices, (std::vector<uint32_t>{0, 1, 2, 1, 3, 2}));

    write_bytes(dir / "fan.gltf", mesh_doc(kQuad, {3, 0, 1, 2}, 6).dump());
    Result<Scene> fan = load_gltf(dir / "fan.gltf");
    ASSERT_TRUE(fan.ok()) << fan.error().message;
    EXPECT_EQ(fan->meshes[0].primitives[0].indices, (std::vector<uint32_t>{0, 1, 3, 1, 2, 3}));
}

TEST(Gltf, NonIndexedPrimitivesGetSequentialIndicesAndAreaWeightedNormals) {
    TempDir dir;
    // two triangles sharing vertex 0: a big one facing +Z (area 2), a small one facing +X (area
    // 0.5)
    const std::vector<float> pos = {0, 0, 0, 2, 0, 0, 0, 2, 0,  //
                                    0, 0, 0, 0, 1, 0, 0, 0, 1};
    write_bytes(dir / "normals.gltf", mesh_doc(pos, {0, 1, 2, 0, 4, 5}).dump());
    Result<Scene> r = load_gltf(dir / "normals.gltf");
    ASSERT_TRUE(r.ok()) << r.error().message;
    const Primitive& p = r->meshes[0].primitives[0];
    const glm::vec3 expected = glm::normalize(glm::vec3(0.5f * 2, 0, 2 * 2));  // cross products
    EXPECT_NEAR(p.normals[0].x, expected.x, 1e-6);
    EXPECT_NEAR(p.normals[0].z, expected.z, 1e-6);
    EXPECT_EQ(p.normals[1], glm::vec3(0, 0, 1));
    EXPECT_EQ(p.normals[4], glm::vec3(1, 0, 0));
    EXPECT_EQ(p.normals[3], glm::vec3(0, 1, 0));  // unused vertex: no area, +Y

    Json doc = mesh_doc(std::vector<float>(kQuad.begin(), kQuad.begin() + 9), {});
    write_bytes(dir / "plain.gltf", doc.dump());
    Result<Scene> plain = load_gltf(dir / "plain.gltf");
    ASSERT_TRUE(plain.ok()) << plain.error().message;
    EXPECT_EQ(plain->meshes[0].primitives[0].indices, (std::vector<uint32_t>{0, 1, 2}));
}

TEST(Gltf, ReportsMissingEmptyTruncatedAndForeignFiles) {
    TempDir dir;
    {
        Result<Scene> r = load_gltf(dir / "nope.glb");
        ASSERT_FALSE(r.ok());
        EXPECT_NE(r.error().message.find("nope.glb: file not found"), std::string::npos)
            << r.error().message;
    }
    EXPECT_NE(load_error(dir, "empty.glb", "").find("empty file"), std::string::npos);

    ASSERT_TRUE(save_glb(make_scene(), dir / "good.glb").ok());
    const std::string good = read_bytes(dir / "good.glb");
    const std::string half = good.substr(0, good.size() / 2);
    const std::string msg = load_error(dir, "half.glb", half);
    EXPECT_NE(msg.find("truncated"), std::string::npos) << msg;
    EXPECT_NE(msg.find(std::to_string(good.size())), std::string::npos) << msg;
    EXPECT_NE(msg.find(std::to_string(half.size())), std::string::npos) << msg;
    EXPECT_NE(load_error(dir, "tiny.glb", "glTF\x02").find("truncated"), std::string::npos);

    std::mt19937 rng(7);
    std::string noise(512, '\0');
    for (char& c : noise) c = char(rng());
    noise[0] = '\x9c';
    EXPECT_NE(load_error(dir, "noise.glb", noise).find("not glTF"), std::string::npos);

    const std::string hello = load_error(dir, "hello.gltf", R"({"hello":1})");
    EXPECT_NE(hello.find("not a glTF asset"), std::string::npos) << hello;
    EXPECT_NE(hello.find("hello"), std::string::npos) << hello;
    EXPECT_NE(load_error(dir, "noversion.gltf", R"({"asset":{}})").find("asset.version"),
              std::string::npos);
    EXPECT_NE(load_error(dir, "v1.gltf", R"({"asset":{"version":"1.0"}})")
                  .find("unsupported glTF version \"1.0\""),
              std::string::npos);
    EXPECT_NE(load_error(dir, "broken.gltf", R"({"asset": {"version": )").find("invalid JSON"),
              std::string::npos);
    Json draco = {{"asset", {{"version", "2.0"}}},
                  {"extensionsRequired", {"KHR_draco_mesh_compression"}}};
    EXPECT_NE(load_error(dir, "draco.gltf", draco.dump()).find("KHR_draco_mesh_compression"),
              std::string::npos);
}

TEST(Gltf, ReportsMissingExternalBuffersAndImages) {
    TempDir dir;
    Json doc = mesh_doc(kQuad, {0, 1, 2});
    doc["buffers"][0]["uri"] = "missing.bin";
    std::string msg = load_error(dir, "nobin.gltf", doc.dump());
    EXPECT_NE(msg.find("buffer 0"), std::string::npos) << msg;
    EXPECT_NE(msg.find("\"missing.bin\" not found"), std::string::npos) << msg;

    doc = mesh_doc(kQuad, {0, 1, 2});
    doc["images"] = {{{"uri", "textures/missing.png"}}};
    doc["textures"] = {{{"source", 0}}};
    msg = load_error(dir, "noimage.gltf", doc.dump());
    EXPECT_NE(msg.find("image 0"), std::string::npos) << msg;
    EXPECT_NE(msg.find("\"textures/missing.png\" not found"), std::string::npos) << msg;

    // an external buffer that exists loads
    write_bytes(dir / "quad.bin", raw(kQuad) + raw(std::vector<uint16_t>{0, 1, 2}));
    doc = mesh_doc(kQuad, {0, 1, 2});
    doc["buffers"][0]["uri"] = "quad.bin";
    write_bytes(dir / "external.gltf", doc.dump());
    Result<Scene> r = load_gltf(dir / "external.gltf");
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_EQ(r->meshes[0].primitives[0].positions.size(), 4u);

    // an image that is not an image
    write_bytes(dir / "fake.png", "not a png at all");
    doc["images"] = {{{"uri", "fake.png"}}};
    doc["textures"] = {{{"source", 0}}};
    msg = load_error(dir, "badimage.gltf", doc.dump());
    EXPECT_NE(msg.find("cannot decode image"), std::string::npos) << msg;
}

TEST(Gltf, ReportsBadGeometry) {
    TempDir dir;
    std::string msg = load_error(dir, "index.gltf", mesh_doc(kQuad, {0, 1, 7}).dump());
    EXPECT_NE(msg.find("index 7 (at position 2) is out of range: the primitive has 4 vertices"),
              std::string::npos)
        << msg;
    EXPECT_NE(msg.find("mesh 0"), std::string::npos) << msg;

    Json doc = mesh_doc(kQuad, {0, 1, 2});
    doc["accessors"][0]["count"] = 40;
    msg = load_error(dir, "range.gltf", doc.dump());
    EXPECT_NE(msg.find("accessor out of range"), std::string::npos) << msg;
    EXPECT_NE(msg.find("POSITION"), std::string::npos) << msg;

    doc = mesh_doc(kQuad, {0, 1, 2});
    doc["bufferViews"][0]["byteLength"] = 4000;
    msg = load_error(dir, "view.gltf", doc.dump());
    EXPECT_NE(msg.find("out of range of buffer 0"), std::string::npos) << msg;

    msg = load_error(dir, "lines.gltf", mesh_doc(kQuad, {0, 1, 1, 2}, 1).dump());
    EXPECT_NE(msg.find("mesh 0 \"m\" primitive 0: mode LINES"), std::string::npos) << msg;
    msg = load_error(dir, "points.gltf", mesh_doc(kQuad, {}, 0).dump());
    EXPECT_NE(msg.find("mode POINTS"), std::string::npos) << msg;

    std::vector<float> nan_quad = kQuad;
    nan_quad[4] = std::numeric_limits<float>::quiet_NaN();
    msg = load_error(dir, "nan.gltf", mesh_doc(nan_quad, {0, 1, 2}).dump());
    EXPECT_NE(msg.find("POSITION 1 is not finite"), std::string::npos) << msg;

    msg = load_error(dir, "odd.gltf", mesh_doc(kQuad, {0, 1, 2, 3}).dump());
    EXPECT_NE(msg.find("not a multiple of 3"), std::string::npos) << msg;
}

TEST(Gltf, ReportsBadNodeGraphs) {
    TempDir dir;
    Json doc = {{"asset", {{"version", "2.0"}}},
                {"nodes", {Json::object(), {{"children", {2}}}, {{"children", {1}}}}}};
    std::string msg = load_error(dir, "cycle.gltf", doc.dump());
    EXPECT_NE(msg.find("cycle"), std::string::npos) << msg;

    doc["nodes"] = {{{"children", {1}}}, {{"children", {1}}}};
    msg = load_error(dir, "self.gltf", doc.dump());
    EXPECT_NE(msg.find("cycle"), std::string::npos) << msg;

    doc["nodes"] = {{{"children", {2}}}, {{"children", {2}}}, Json::object()};
    msg = load_error(dir, "twoparents.gltf", doc.dump());
    EXPECT_NE(msg.find("child of both node 0 and node 1"), std::string::npos) << msg;

    doc["nodes"] = {{{"extensions", {{"MSFT_lod", {{"ids", {0}}}}}}}};
    msg = load_error(dir, "lodself.gltf", doc.dump());
    EXPECT_NE(msg.find("MSFT_lod id 0 is the node itself"), std::string::npos) << msg;

    doc["nodes"] = {{{"extensions", {{"MSFT_lod", {{"ids", {5}}}}}}}};
    msg = load_error(dir, "lodrange.gltf", doc.dump());
    EXPECT_NE(msg.find("MSFT_lod id 5 is out of range"), std::string::npos) << msg;

    doc["nodes"] = {{{"children", {1}}}, Json::object()};
    doc["scenes"] = {{{"nodes", {0, 1}}}};
    msg = load_error(dir, "notroot.gltf", doc.dump());
    EXPECT_NE(msg.find("scene 0: node 1 is not a root"), std::string::npos) << msg;
    doc.erase("scenes");

    doc["nodes"] = {{{"children", {3}}}};
    msg = load_error(dir, "child.gltf", doc.dump());
    EXPECT_NE(msg.find("child 3 does not exist"), std::string::npos) << msg;
}

TEST(Gltf, SurvivesTruncatedAndCorruptedGlb) {
    TempDir dir;
    ASSERT_TRUE(save_glb(make_scene(), dir / "good.glb").ok());
    const std::string good = read_bytes(dir / "good.glb");
    const fs::path path = dir / "bad.glb";
    for (size_t n = 0; n < good.size(); n += 13) {
        write_bytes(path, good.substr(0, n));
        EXPECT_FALSE(load_gltf(path).ok()) << n;
    }
    std::mt19937 rng(11);
    for (int trial = 0; trial < 300; ++trial) {
        std::string bad = good;
        for (int k = 0; k < 3; ++k) bad[rng() % bad.size()] = char(rng());
        write_bytes(path, bad);
        Result<Scene> r = load_gltf(path);  // either outcome, but no crash and a named file
        if (!r.ok()) {
            EXPECT_EQ(r.error().message.rfind(path.string(), 0), 0u);
        }
    }
}

TEST(Gltf, SaveIntoMissingDirectoryFailsAndLeavesNothing) {
    TempDir dir;
    const fs::path path = dir / "no_such_dir" / "scene.glb";
    Status s = save_glb(make_scene(), path);
    ASSERT_FALSE(s.ok());
    EXPECT_NE(s.error().message.find("scene.glb"), std::string::npos) << s.error().message;
    EXPECT_FALSE(fs::exists(dir / "no_such_dir"));
    EXPECT_TRUE(fs::is_empty(dir.path()));
}

TEST(Gltf, RefusesToWriteAnInconsistentSceneAndKeepsTheOldFile) {
    TempDir dir;
    const fs::path path = dir / "scene.glb";
    ASSERT_TRUE(save_glb(make_scene(), path).ok());
    const std::string before = read_bytes(path);
    Scene bad = make_scene();
    bad.meshes[0].primitives[0].indices[4] = 99;
    Status s = save_glb(bad, path);
    ASSERT_FALSE(s.ok());
    EXPECT_NE(s.error().message.find("index 99"), std::string::npos) << s.error().message;
    EXPECT_EQ(read_bytes(path), before);
    size_t files = 0;
    for (auto& e : fs::directory_iterator(dir.path())) files += e.is_regular_file();
    EXPECT_EQ(files, 1u);
}

// glTF numbers attribute sets from 0: a TEXCOORD_1 without TEXCOORD_0 gets a TEXCOORD_0 accessor
// without data (zeros), which reads back as "no uv0".
TEST(Gltf, Texcoord1AloneGetsAnEmptyTexcoord0) {
    TempDir dir;
    Scene s = make_scene();
    s.meshes[0].primitives[0].uv0.clear();
    const fs::path path = dir / "scene.glb";
    ASSERT_TRUE(save_glb(s, path).ok());
    const std::string glb = read_bytes(path);
    uint32_t json_length = 0;
    std::memcpy(&json_length, glb.data() + 12, 4);
    const Json doc = Json::parse(glb.substr(20, json_length));
    const Json& attributes = doc["meshes"][0]["primitives"][0]["attributes"];
    ASSERT_TRUE(attributes.contains("TEXCOORD_0"));
    const Json& uv0 = doc["accessors"][attributes["TEXCOORD_0"].get<int>()];
    EXPECT_FALSE(uv0.contains("bufferView"));
    EXPECT_EQ(uv0["count"], 4);
    Result<Scene> back = load_gltf(path);
    ASSERT_TRUE(back.ok()) << back.error().message;
    EXPECT_TRUE(back->meshes[0].primitives[0].uv0.empty());
    EXPECT_EQ(back->meshes[0].primitives[0].uv1, s.meshes[0].primitives[0].uv1);
    EXPECT_TRUE(back->meshes[1].primitives[0].uv0.empty());  // no uv1 either: nothing added
}

// COLOR_0 must lie in [0, 1] in glTF: the writer refuses anything else (light goes in _LIGHT_0).
TEST(Gltf, RefusesColoursOutsideZeroOne) {
    TempDir dir;
    Scene s = make_scene();
    s.meshes[0].primitives[0].colors[2].g = 1.5f;
    Status st = save_glb(s, dir / "scene.glb");
    ASSERT_FALSE(st.ok());
    EXPECT_NE(st.error().message.find("COLOR_0 2 component 1 = 1.5"), std::string::npos)
        << st.error().message;
    EXPECT_FALSE(fs::exists(dir / "scene.glb"));
    // Round-off of interpolated colours (here 1 + 5e-5, -5e-5) is clamped into the range.
    s = make_scene();
    s.meshes[0].primitives[0].colors[2].g = 1.00005f;
    s.meshes[0].primitives[0].colors[1].r = -0.00005f;
    ASSERT_TRUE(save_glb(s, dir / "scene.glb").ok());
    Result<Scene> back = load_gltf(dir / "scene.glb");
    ASSERT_TRUE(back.ok()) << back.error().message;
    EXPECT_EQ(back->meshes[0].primitives[0].colors[2].g, 1.0f);
    EXPECT_EQ(back->meshes[0].primitives[0].colors[1].r, 0.0f);
    fs::remove(dir / "scene.glb");
    s = make_scene();
    s.meshes[0].primitives[0].light[1].r = std::numeric_limits<float>::quiet_NaN();
    st = save_glb(s, dir / "scene.glb");
    ASSERT_FALSE(st.ok());
    EXPECT_NE(st.error().message.find("_LIGHT_0 1 is not finite"), std::string::npos)
        << st.error().message;
}

// Files baked before _LIGHT_0 held the light as opaque COLOR_0 = E / pi, above 1 where bright:
// such colours load as light (E = colour x pi); colours within [0, 1] stay colours.
TEST(Gltf, ReadsOldBakedColoursAboveOneAsLight) {
    TempDir dir;
    const std::vector<float> positions(kQuad.begin(), kQuad.begin() + 9);
    const std::vector<float> colours = {2, 0.5f, 0.25f, 1, 0, 0, 0, 1, 0.1f, 0.2f, 0.3f, 1};
    const std::string buf = raw(positions) + raw(colours);
    Json doc = mesh_doc(positions, {});
    doc["buffers"][0] = {{"byteLength", buf.size()},
                         {"uri", "data:application/octet-stream;base64," + base64(buf)}};
    doc["bufferViews"].push_back({{"buffer", 0}, {"byteOffset", 36}, {"byteLength", 48}});
    doc["accessors"].push_back(
        {{"bufferView", 1}, {"componentType", 5126}, {"count", 3}, {"type", "VEC4"}});
    doc["meshes"][0]["primitives"][0]["attributes"]["COLOR_0"] = 1;
    doc["meshes"][0]["primitives"][0]["material"] = 0;
    doc["materials"] = Json::array(
        {{{"emissiveFactor", {1, 0.5, 0.25}},
          {"extensions", {{"KHR_materials_emissive_strength", {{"emissiveStrength", 8}}}}}}});
    doc["extensionsUsed"] = {"KHR_materials_emissive_strength"};
    const std::string json = doc.dump();
    write_bytes(dir / "old.gltf", json);
    Result<Scene> s = load_gltf(dir / "old.gltf");
    ASSERT_TRUE(s.ok()) << s.error().message;
    const Primitive& p = s->meshes[0].primitives[0];
    EXPECT_TRUE(p.colors.empty());
    ASSERT_EQ(p.light.size(), 3u);
    const float pi = std::numbers::pi_v<float>;
    EXPECT_FLOAT_EQ(p.light[0].r, 2.0f * pi);
    EXPECT_FLOAT_EQ(p.light[0].g, 0.5f * pi);
    EXPECT_FLOAT_EQ(p.light[2].b, 0.3f * pi);
    // KHR_materials_emissive_strength multiplies the factor.
    EXPECT_EQ(s->materials[0].emissive_factor, glm::vec3(8.0f, 4.0f, 2.0f));
}

}  // namespace
}  // namespace hmdnode
