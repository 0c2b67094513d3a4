#include "hmdnode/core/scene.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <set>

#include <glm/gtc/matrix_transform.hpp>

namespace hmdnode {

void compute_vertex_normals(Primitive& p, glm::vec3 no_area) {
    p.normals.assign(p.positions.size(), glm::vec3(0.0f));
    for (size_t t = 0; t + 2 < p.indices.size(); t += 3) {
        const glm::vec3& a = p.positions[p.indices[t]];
        // note: the cross product's length is twice the triangle's area: area weighting for free
        const glm::vec3 n =
            glm::cross(p.positions[p.indices[t + 1]] - a, p.positions[p.indices[t + 2]] - a);
        for (size_t k = 0; k < 3; ++k) p.normals[p.indices[t + k]] += n;
    }
    for (glm::vec3& n : p.normals) {
        const float len = glm::length(n);
        n = len > 0.0f && std::isfinite(len) ? n / len : no_area;
    }
}

size_t Mesh::triangle_count() const {
    size_t n = 0;
    for (const Primitive& p : primitives) n += p.triangle_count();
    return n;
}

glm::dmat4 Node::local_matrix() const {
    glm::dmat4 t = glm::translate(glm::dmat4(1.0), translation);
    glm::dmat4 r = glm::mat4_cast(rotation);
    glm::dmat4 s = glm::scale(glm::dmat4(1.0), scale);
    return t * r * s;
}

namespace {

// Bounding sphere of a mesh in world space: centre of the world AABB, radius to its farthest
// vertex.
void mesh_bounds(const Mesh& mesh, const glm::dmat4& world, glm::dvec3* out_center,
                 double* out_radius) {
    glm::dvec3 lo(1e300), hi(-1e300);
    bool any = false;
    for (const Primitive& p : mesh.primitives)
        for (const glm::vec3& v : p.positions) {
            glm::dvec3 w = glm::dvec3(world * glm::dvec4(glm::dvec3(v), 1.0));
            lo = glm::min(lo, w);
            hi = glm::max(hi, w);
            any = true;
        }
    if (!any) {
        *out_center = glm::dvec3(world[3]);
        *out_radius = 0.0;
        return;
    }
    glm::dvec3 c = 0.5 * (lo + hi);
    double r2 = 0.0;
    for (const Primitive& p : mesh.primitives)
        for (const glm::vec3& v : p.positions) {
            glm::dvec3 w = glm::dvec3(world * glm::dvec4(glm::dvec3(v), 1.0));
            r2 = std::max(r2, glm::dot(w - c, w - c));
        }
    *out_center = c;
    *out_radius = std::sqrt(r2);
}

double max_scale(const glm::dmat4& m) {
    return std::max({glm::length(glm::dvec3(m[0])), glm::length(glm::dvec3(m[1])),
                     glm::length(glm::dvec3(m[2]))});
}

}  // namespace

std::vector<SceneObject> flatten_objects(const Scene& scene) {
    std::set<int> alternates;
    for (const Node& n : scene.nodes)
        for (int id : n.lod_ids) alternates.insert(id);

    std::vector<SceneObject> out;
    std::vector<char> visiting(scene.nodes.size(), 0);
    std::function<void(int, const glm::dmat4&)> visit = [&](int idx, const glm::dmat4& parent) {
        if (idx < 0 || size_t(idx) >= scene.nodes.size() || visiting[idx])
            return;  // cycles: loader rejects
        visiting[idx] = 1;
        const Node& node = scene.nodes[idx];
        glm::dmat4 world = parent * node.local_matrix();
        if (node.mesh >= 0 && size_t(node.mesh) < scene.meshes.size() && !alternates.count(idx)) {
            SceneObject obj;
            obj.name = node.name.empty() ? scene.meshes[node.mesh].name : node.name;
            obj.node = idx;
            obj.world = world;
            double s = max_scale(world);
            auto add_level = [&](const Node& n) {
                if (n.mesh < 0 || size_t(n.mesh) >= scene.meshes.size()) return;
                LodLevel lvl;
                lvl.mesh = n.mesh;
                lvl.geometric_error_m = std::max(0.0, n.geometric_error_m) * s;
                lvl.triangles = scene.meshes[n.mesh].triangle_count();
                obj.levels.push_back(lvl);
            };
            add_level(node);
            for (int id : node.lod_ids)
                if (id >= 0 && size_t(id) < scene.nodes.size()) add_level(scene.nodes[id]);
            mesh_bounds(scene.meshes[node.mesh], world, &obj.bounds_center, &obj.bounds_radius);
            out.push_back(std::move(obj));
        }
        for (int c : node.children) visit(c, world);
        visiting[idx] = 0;
    };
    for (int r : scene.roots) visit(r, glm::dmat4(1.0));
    return out;
}

}  // namespace hmdnode
