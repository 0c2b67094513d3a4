// glTF 2.0 writer: Scene -> tinygltf::Model with one buffer (tightly packed attributes, indices,
// PNG textures) -> GLB bytes in memory -> write_file_atomically.
//
// What goes out: POSITION (with min/max), NORMAL, TEXCOORD_0, TEXCOORD_1, COLOR_0 (in [0, 1];
// within 1e-4 of it clamped, farther an error) and _LIGHT_0 (baked irradiance, any value >= 0) as
// float; a primitive with TEXCOORD_1 but no TEXCOORD_0 gets a TEXCOORD_0 accessor without data
// (zeros, no bytes), since glTF numbers attribute sets from 0; indices as UNSIGNED_SHORT when every
// vertex fits, else UNSIGNED_INT; materials with baseColorFactor/-Texture, doubleSided,
// metallicFactor 0 (the scene model is diffuse; glTF's default of 1 would make other viewers draw
// metal), emissiveFactor (scaled into [0, 1] by a KHR_materials_emissive_strength when brighter)
// and MOZ_lightmap; textures as PNG; nodes as TRS with MSFT_lod, extras.MSFT_screencoverage and
// extras.geometric_error (every node with geometric_error_m >= 0); KHR_lights_punctual; one scene
// holding the roots.
// A scene the format cannot hold (index out of range, attribute counts that differ, a node graph
// that is not a forest) is an error, never a file the loader would reject.
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <sstream>
#include <string>
#include <vector>

#include <tiny_gltf.h>

#include "hmdnode/core/atomic_file.hpp"
#include "hmdnode/core/gltf.hpp"
#include "hmdnode/core/image.hpp"
#include "hmdnode/core/str_cat.hpp"

// note: libstb exports this, but stb_image_write.h declares it only in its implementation part

namespace hmdnode {
namespace {

bool finite_position(const glm::dvec3& v) {
    return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

// COLOR_0 within this of [0, 1] is float round-off of interpolated colours (LOD, splitting): it is
// clamped into the range; farther out is an error.
constexpr float kColourSlack = 1e-4f;

bool in_range(int index, size_t size) {
    return index >= 0 && size_t(index) < size;
}

// Why the scene cannot be written as glTF, or empty.
std::string check_scene(const Scene& s) {
    for (size_t i = 0; i < s.textures.size(); ++i) {
        const Texture& t = s.textures[i];
        if (t.width <= 0 || t.height <= 0 ||
            t.rgba8.size() != size_t(t.width) * size_t(t.height) * 4)
            return cat("texture ", i, ": ", t.width, "x", t.height, " with ", t.rgba8.size(),
                       " bytes is not an RGBA8 image");
    }
    for (size_t i = 0; i < s.materials.size(); ++i) {
        const Material& m = s.materials[i];
        if (m.base_color_texture != -1 && !in_range(m.base_color_texture, s.textures.size()))
            return cat("material ", i, ": base colour texture ", m.base_color_texture,
                       " does not exist");
        if (m.lightmap.texture != -1 && !in_range(m.lightmap.texture, s.textures.size()))
            return cat("material ", i, ": lightmap texture ", m.lightmap.texture,
                       " does not exist");
        for (int c = 0; c < 3; ++c)
            if (!(m.emissive_factor[c] >= 0.0f && std::isfinite(m.emissive_factor[c])))
                return cat("material ", i, ": emissive factor ", m.emissive_factor[c],
                           " is not a finite number >= 0");
        if (m.lightmap.texture != -1 && m.lightmap.tex_coord < 0)
            return cat("material ", i, ": lightmap texCoord ", m.lightmap.tex_coord,
                       " is negative");
    }
    for (size_t i = 0; i < s.meshes.size(); ++i) {
        if (s.meshes[i].primitives.empty())
            return cat("mesh ", i, ": no primitives (glTF needs one)");
        for (size_t j = 0; j < s.meshes[i].primitives.size(); ++j) {
            const Primitive& p = s.meshes[i].primitives[j];
            const std::string label = cat("mesh ", i, " primitive ", j);
            const size_t n = p.positions.size();
            if (n == 0) return label + ": no vertices";
            if (n > 0xFFFFFFFFu) return label + ": too many vertices for 32-bit indices";
            for (const glm::vec3& v : p.positions)
                if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z))
                    return label + ": a position is not finite";
            if ((!p.normals.empty() && p.normals.size() != n) ||
                (!p.uv0.empty() && p.uv0.size() != n) || (!p.uv1.empty() && p.uv1.size() != n) ||
                (!p.colors.empty() && p.colors.size() != n) ||
                (!p.light.empty() && p.light.size() != n))
                return label + ": an attribute's count differs from the position count";
            for (size_t v = 0; v < p.colors.size(); ++v)
                for (int c = 0; c < 4; ++c)
                    if (!(p.colors[v][c] >= -kColourSlack && p.colors[v][c] <= 1.0f + kColourSlack))
                        return cat(label, ": COLOR_0 ", v, " component ", c, " = ", p.colors[v][c],
                                   " is outside [0, 1] (glTF's range; light above 1 goes in "
                                   "_LIGHT_0)");
            for (size_t v = 0; v < p.light.size(); ++v)
                for (int c = 0; c < 3; ++c)
                    if (!std::isfinite(p.light[v][c]))
                        return cat(label, ": _LIGHT_0 ", v, " is not finite");
            if (p.indices.empty() || p.indices.size() % 3 != 0)
                return cat(label, ": ", p.indices.size(),
                           " indices is not a positive multiple of 3");
            for (uint32_t x : p.indices)
                if (x >= n) return cat(label, ": index ", x, " is out of range (", n, " vertices)");
            if (p.material != -1 && !in_range(p.material, s.materials.size()))
                return cat(label, ": material ", p.material, " does not exist");
        }
    }
    std::vector<int> parent(s.nodes.size(), -1);
    for (size_t i = 0; i < s.nodes.size(); ++i) {
        const Node& n = s.nodes[i];
        if (n.mesh != -1 && !in_range(n.mesh, s.meshes.size()))
            return cat("node ", i, ": mesh ", n.mesh, " does not exist");
        for (int c : n.children) {
            if (!in_range(c, s.nodes.size()))
                return cat("node ", i, ": child ", c, " does not exist");
            if (parent[size_t(c)] >= 0)
                return cat("node ", c, " has two parents (", parent[size_t(c)], " and ", i, ")");
            parent[size_t(c)] = int(i);
        }
        for (int id : n.lod_ids)
            if (!in_range(id, s.nodes.size()) || id == int(i))
                return cat("node ", i, ": MSFT_lod id ", id, " is out of range or the node itself");
        const bool finite = finite_position(n.translation) && finite_position(n.scale) &&
                            std::isfinite(n.rotation.w) && std::isfinite(n.rotation.x) &&
                            std::isfinite(n.rotation.y) && std::isfinite(n.rotation.z);
        if (!finite) return cat("node ", i, ": transform is not finite");
        if (glm::length(n.rotation) < 1e-12)
            return cat("node ", i, ": rotation is a zero quaternion");
        if (!std::isfinite(n.geometric_error_m))
            return cat("node ", i, ": geometric error is not finite");
    }
    for (size_t i = 0; i < s.nodes.size(); ++i) {  // a cycle: walking up never reaches a root
        int k = int(i);
        for (size_t step = 0; k >= 0 && step <= s.nodes.size(); ++step) k = parent[size_t(k)];
        if (k >= 0) return cat("node graph cycle through node ", i);
    }
    for (int r : s.roots) {
        if (!in_range(r, s.nodes.size())) return cat("root ", r, " does not exist");
        if (parent[size_t(r)] >= 0)
            return cat("root ", r, " is a child of node ", parent[size_t(r)]);
    }
    for (size_t i = 0; i < s.lights.size(); ++i)
        if (s.lights[i].node != -1 && !in_range(s.lights[i].node, s.nodes.size()))
            return cat("light ", i, ": node ", s.lights[i].node, " does not exist");
    return {};
}

class ModelBuilder {
  public:
    tinygltf::Model model;

    ModelBuilder() {
        model.asset.version = "2.0";
        model.asset.generator = "hmdnode";
        model.buffers.emplace_back();
    }

    // Appends bytes (4-byte aligned) as a new bufferView; returns its index.
    int add_view(const void* data, size_t size, int target) {
        std::vector<unsigned char>& bin = model.buffers[0].data;
        bin.resize((bin.size() + 3) & ~size_t(3), 0);
        tinygltf::BufferView view;
        view.buffer = 0;
        view.byteOffset = bin.size();
        view.byteLength = size;
        view.target = target;
        const auto* bytes = static_cast<const unsigned char*>(data);
        bin.insert(bin.end(), bytes, bytes + size);
        model.bufferViews.push_back(view);
        return int(model.bufferViews.size() - 1);
    }

    template <class Vec>
    int add_attribute(const std::vector<Vec>& values, int type, bool with_bounds) {
        tinygltf::Accessor a;
        a.bufferView =
            add_view(values.data(), values.size() * sizeof(Vec), TINYGLTF_TARGET_ARRAY_BUFFER);
        a.componentType = TINYGLTF_COMPONENT_TYPE_FLOAT;
        a.type = type;
        a.count = values.size();
        if (with_bounds) {  // the spec requires min/max on POSITION
            Vec lo = values[0], hi = values[0];
            for (const Vec& v : values) {
                lo = glm::min(lo, v);
                hi = glm::max(hi, v);
            }
            for (int c = 0; c < Vec::length(); ++c) {
                a.minValues.push_back(lo[c]);
                a.maxValues.push_back(hi[c]);
            }
        }
        model.accessors.push_back(a);
        return int(model.accessors.size() - 1);
    }

    // An accessor without a bufferView: `count` zeros, no bytes in the buffer.
    int add_zeros(size_t count, int type) {
        tinygltf::Accessor a;
        a.bufferView = -1;
        a.componentType = TINYGLTF_COMPONENT_TYPE_FLOAT;
        a.type = type;
        a.count = count;
        model.accessors.push_back(a);
        return int(model.accessors.size() - 1);
    }

    int add_indices(const std::vector<uint32_t>& indices, size_t vertex_count) {
        tinygltf::Accessor a;
        a.type = TINYGLTF_TYPE_SCALAR;
        a.count = indices.size();
        if (vertex_count <= 0xFFFF) {
            std::vector<uint16_t> narrow(indices.begin(), indices.end());
            a.componentType = TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT;
            a.bufferView =
                add_view(narrow.data(), narrow.size() * 2, TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER);
        } else {
            a.componentType = TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT;
            a.bufferView =
                add_view(indices.data(), indices.size() * 4, TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER);
        }
        model.accessors.push_back(a);
        return int(model.accessors.size() - 1);
    }

    void use_extension(const std::string& name) {
        for (const std::string& e : model.extensionsUsed)
            if (e == name) return;
        model.extensionsUsed.push_back(name);
    }
};

tinygltf::Value number_array(const std::vector<double>& values) {
    tinygltf::Value::Array a;
    for (double v : values) a.emplace_back(v);
    return tinygltf::Value(std::move(a));
}

// Returns an error message, or empty when the model is complete.
std::string build(const Scene& s, ModelBuilder* b) {
    tinygltf::Model& m = b->model;
    for (size_t i = 0; i < s.textures.size(); ++i) {
        const Texture& t = s.textures[i];
        const std::string png = encode_png(t.rgba8.data(), t.width, t.height);
        if (png.empty()) return cat("texture ", i, ": PNG encoding failed");
        tinygltf::Image image;
        image.name = t.name;
        image.mimeType = "image/png";
        image.bufferView = b->add_view(png.data(), png.size(), 0);
        m.images.push_back(std::move(image));
        tinygltf::Texture texture;
        texture.name = t.name;
        texture.source = int(i);
        m.textures.push_back(std::move(texture));
    }
    for (const Material& src : s.materials) {
        tinygltf::Material mat;
        mat.name = src.name;
        const glm::vec4& f = src.base_color_factor;
        mat.pbrMetallicRoughness.baseColorFactor = {f.r, f.g, f.b, f.a};
        mat.pbrMetallicRoughness.baseColorTexture.index = src.base_color_texture;
        mat.pbrMetallicRoughness.metallicFactor = 0.0;
        mat.doubleSided = src.double_sided;
        // glTF's emissiveFactor lies in [0, 1]; brighter emission is a factor times
        // KHR_materials_emissive_strength, a power of two so that factor x strength gives back
        // the same float.
        const glm::vec3 e = src.emissive_factor;
        const float peak = std::max({e.r, e.g, e.b});
        double strength = 1.0;
        while (peak > strength) strength *= 2.0;
        mat.emissiveFactor = {e.r / strength, e.g / strength, e.b / strength};
        if (strength > 1.0) {
            tinygltf::Value::Object es;
            es["emissiveStrength"] = tinygltf::Value(strength);
            mat.extensions["KHR_materials_emissive_strength"] = tinygltf::Value(std::move(es));
            b->use_extension("KHR_materials_emissive_strength");
        }
        if (src.lightmap.texture >= 0) {
            tinygltf::Value::Object lm;
            lm["index"] = tinygltf::Value(src.lightmap.texture);
            lm["texCoord"] = tinygltf::Value(src.lightmap.tex_coord);
            lm["intensity"] = tinygltf::Value(double(src.lightmap.intensity));
            if (src.lightmap.encoding == LightmapEncoding::Rgbm) {
                tinygltf::Value::Object extras;
                extras["encoding"] = tinygltf::Value(std::string("RGBM"));
                lm["extras"] = tinygltf::Value(std::move(extras));
            }
            mat.extensions["MOZ_lightmap"] = tinygltf::Value(std::move(lm));
            b->use_extension("MOZ_lightmap");
        }
        m.materials.push_back(std::move(mat));
    }
    for (const Mesh& src : s.meshes) {
        tinygltf::Mesh mesh;
        mesh.name = src.name;
        for (const Primitive& p : src.primitives) {
            tinygltf::Primitive prim;
            prim.mode = TINYGLTF_MODE_TRIANGLES;
            prim.material = p.material;
            prim.attributes["POSITION"] = b->add_attribute(p.positions, TINYGLTF_TYPE_VEC3, true);
            if (!p.normals.empty())
                prim.attributes["NORMAL"] = b->add_attribute(p.normals, TINYGLTF_TYPE_VEC3, false);
            if (!p.uv0.empty())
                prim.attributes["TEXCOORD_0"] = b->add_attribute(p.uv0, TINYGLTF_TYPE_VEC2, false);
            else if (!p.uv1.empty())  // glTF numbers sets from 0: TEXCOORD_1 needs a TEXCOORD_0
                prim.attributes["TEXCOORD_0"] =
                    b->add_zeros(p.positions.size(), TINYGLTF_TYPE_VEC2);
            if (!p.uv1.empty())
                prim.attributes["TEXCOORD_1"] = b->add_attribute(p.uv1, TINYGLTF_TYPE_VEC2, false);
            if (!p.colors.empty()) {
                std::vector<glm::vec4> colours = p.colors;  // round-off past [0, 1] clamped
                for (glm::vec4& c : colours) c = glm::clamp(c, 0.0f, 1.0f);
                prim.attributes["COLOR_0"] = b->add_attribute(colours, TINYGLTF_TYPE_VEC4, false);
            }
            if (!p.light.empty())
                prim.attributes["_LIGHT_0"] = b->add_attribute(p.light, TINYGLTF_TYPE_VEC3, false);
            prim.indices = b->add_indices(p.indices, p.positions.size());
            mesh.primitives.push_back(std::move(prim));
        }
        m.meshes.push_back(std::move(mesh));
    }
    for (const Node& src : s.nodes) {
        tinygltf::Node node;
        node.name = src.name;
        if (src.translation != glm::dvec3(0.0))
            node.translation = {src.translation.x, src.translation.y, src.translation.z};
        const glm::dquat q = glm::normalize(src.rotation);
        if (q != glm::dquat(1.0, 0.0, 0.0, 0.0)) node.rotation = {q.x, q.y, q.z, q.w};
        if (src.scale != glm::dvec3(1.0)) node.scale = {src.scale.x, src.scale.y, src.scale.z};
        node.mesh = src.mesh;
        node.children = src.children;
        if (!src.lod_ids.empty()) {
            tinygltf::Value::Array ids;
            for (int id : src.lod_ids) ids.emplace_back(id);
            tinygltf::Value::Object lod;
            lod["ids"] = tinygltf::Value(std::move(ids));
            node.extensions["MSFT_lod"] = tinygltf::Value(std::move(lod));
            b->use_extension("MSFT_lod");
        }
        tinygltf::Value::Object extras;
        if (!src.screen_coverage.empty())
            extras["MSFT_screencoverage"] = number_array(src.screen_coverage);
        if (src.geometric_error_m >= 0.0)
            extras["geometric_error"] = tinygltf::Value(src.geometric_error_m);
        if (!extras.empty()) node.extras = tinygltf::Value(std::move(extras));
        m.nodes.push_back(std::move(node));
    }
    for (size_t i = 0; i < s.lights.size(); ++i) {
        const Light& src = s.lights[i];
        tinygltf::Light light;
        light.name = src.name;
        light.type = src.type == Light::Type::Point  ? "point"
                     : src.type == Light::Type::Spot ? "spot"
                                                     : "directional";
        light.color = {src.color.r, src.color.g, src.color.b};
        light.intensity = src.intensity;
        light.range = src.range;
        light.spot.innerConeAngle = src.inner_cone_rad;
        light.spot.outerConeAngle = src.outer_cone_rad;
        m.lights.push_back(std::move(light));
        if (src.node >= 0) {
            tinygltf::Value::Object ref;
            ref["light"] = tinygltf::Value(int(i));
            m.nodes[size_t(src.node)].extensions["KHR_lights_punctual"] =
                tinygltf::Value(std::move(ref));
        }
        b->use_extension("KHR_lights_punctual");
    }
    // note: a light whose node already places another light cannot be expressed (one light per
    // node)
    std::vector<int> placed(s.nodes.size(), 0);
    for (const Light& l : s.lights)
        if (l.node >= 0 && ++placed[size_t(l.node)] > 1)
            return cat("node ", l.node,
                       " places more than one light (KHR_lights_punctual allows one)");
    tinygltf::Scene scene;
    scene.nodes = s.roots;
    m.scenes.push_back(std::move(scene));
    m.defaultScene = 0;
    if (m.buffers[0].data.empty()) m.buffers.clear();
    return {};
}

}  // namespace

Status save_glb(const Scene& scene, const std::filesystem::path& path) {
    try {
        if (std::string why = check_scene(scene); !why.empty())
            return make_error(path.string() + ": cannot write scene: " + why);
        ModelBuilder builder;
        if (std::string why = build(scene, &builder); !why.empty())
            return make_error(path.string() + ": cannot write scene: " + why);
        std::ostringstream out;
        tinygltf::TinyGLTF writer;
        if (!writer.WriteGltfSceneToStream(&builder.model, out, false, true) || !out)
            return make_error(path.string() + ": GLB serialisation failed");
        return write_file_atomically(path, out.str());
    } catch (const std::exception& e) {
        return make_error(path.string() + ": cannot write scene: " + e.what());
    }
}

}  // namespace hmdnode
