// Private helpers shared by the per-vertex bakes (vertex_angle_weighted.cpp,
// vertex_least_squares.cpp): world placement of a primitive and the n x n sub-triangle centroid
// sampling rule of vertex_bake.hpp. Cost: O(V) to place, O(n^2) per triangle to sample.
#pragma once

#include <cassert>
#include <cmath>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "hmdnode/bake/vertex_bake.hpp"

namespace hmdnode::vertex_detail {

// The primitive in world space: positions, unit normals (vertex normals, or none).
struct WorldPrimitive {
    std::vector<glm::dvec3> p;
    std::vector<glm::dvec3> n;  // empty: use face normals
};

inline Result<WorldPrimitive> place(const Primitive& prim, const glm::dmat4& world) {
    WorldPrimitive w;
    w.p.reserve(prim.positions.size());
    for (size_t i = 0; i < prim.positions.size(); ++i) {
        const glm::vec3& v = prim.positions[i];
        if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z))
            return make_error("vertex bake: vertex " + std::to_string(i) +
                              " has a non-finite position");
        w.p.push_back(glm::dvec3(world * glm::dvec4(glm::dvec3(v), 1.0)));
    }
    for (uint32_t i : prim.indices)
        if (i >= prim.positions.size())
            return make_error("vertex bake: index " + std::to_string(i) + " out of range");
    if (prim.normals.size() == prim.positions.size()) {
        const glm::dmat3 nm = glm::transpose(glm::inverse(glm::dmat3(world)));
        for (const glm::vec3& n : prim.normals) {
            glm::dvec3 t = nm * glm::dvec3(n);
            const double l = glm::length(t);
            w.n.push_back(l > 0.0 ? t / l : glm::dvec3(0.0));
        }
    }
    return w;
}

struct Sample {
    glm::dvec3 p, n;
    double b[3];  // barycentric weights = the hat functions of the 3 corners
    double w;     // quadrature weight (area / n^2)
};

// The n^2 sub-triangle centroids of triangle f, with interpolated (or face) normals.
inline void sample_triangle(const WorldPrimitive& w, const Primitive& prim, size_t f, int n,
                            std::vector<Sample>& out) {
    assert(n >= 1 && 3 * f + 2 < prim.indices.size());  // place() checked the indices
    out.clear();
    const uint32_t i0 = prim.indices[3 * f], i1 = prim.indices[3 * f + 1],
                   i2 = prim.indices[3 * f + 2];
    const glm::dvec3 p0 = w.p[i0], p1 = w.p[i1], p2 = w.p[i2];
    const glm::dvec3 cr = glm::cross(p1 - p0, p2 - p0);
    const double area = 0.5 * glm::length(cr);
    const glm::dvec3 face_n = area > 0.0 ? cr / (2.0 * area) : glm::dvec3(0.0, 0.0, 1.0);
    const double wt = area / double(n * n);
    auto push = [&](double a, double b) {
        Sample s;
        s.b[0] = 1.0 - a - b, s.b[1] = a, s.b[2] = b;
        assert(s.b[0] > 0.0 && s.b[1] > 0.0 && s.b[2] > 0.0);  // a centroid inside the triangle
        s.p = s.b[0] * p0 + s.b[1] * p1 + s.b[2] * p2;
        glm::dvec3 nn = face_n;
        if (!w.n.empty()) {
            const glm::dvec3 t = s.b[0] * w.n[i0] + s.b[1] * w.n[i1] + s.b[2] * w.n[i2];
            if (glm::length(t) > 0.0) nn = glm::normalize(t);
        }
        s.n = nn;
        s.w = wt;
        out.push_back(s);
    };
    for (int i = 0; i < n; ++i)
        for (int j = 0; i + j < n; ++j) {
            push((i + 1.0 / 3.0) / n, (j + 1.0 / 3.0) / n);
            if (i + j <= n - 2) push((i + 2.0 / 3.0) / n, (j + 2.0 / 3.0) / n);
        }
    assert(out.size() == size_t(n) * size_t(n));  // n^2 similar sub-triangles, one centroid each
}

inline glm::dvec3 eval(const IrradianceOracle& oracle, const Sample& s) {
    assert(oracle);
    return glm::dvec3(oracle(glm::vec3(s.p), glm::vec3(s.n)));
}

// The oracle at a vertex itself (vertices used by no triangle).
inline glm::dvec3 at_vertex(const WorldPrimitive& w, const IrradianceOracle& oracle, size_t v) {
    assert(v < w.p.size() && (w.n.empty() || v < w.n.size()));
    const glm::dvec3 n = w.n.empty() ? glm::dvec3(0.0, 0.0, 1.0) : w.n[v];
    return glm::dvec3(oracle(glm::vec3(w.p[v]), glm::vec3(n)));
}

}  // namespace hmdnode::vertex_detail
