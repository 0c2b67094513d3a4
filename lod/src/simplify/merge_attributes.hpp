// The attributes of a merged vertex: where two free positions u and v merge at a new point (qem's
// optimal placement), its normal, UVs and colour come from where that point lies on the surface
// before the collapse: the barycentric coordinates of its projection into the face around u or v
// that contains the projection (a face on the edge where one does; else, of those that do, the
// nearest plane). A point on the edge, or one whose
// projection falls into no face (a placement beyond the fan), keeps the interpolation along the
// edge at the parameter of its projection (lerp_wedge()). Interpolating along the edge alone made
// the texture drift where the point lies off the edge: on a height field, UVs moved by up to half
// an edge.
//
// Paper: H. Hoppe, "New quadric metric for simplifying meshes with appearance attributes", IEEE
// Visualization 1999 (attributes of the new vertex where it lies on the surface, rather than
// along the edge); M. Garland, P. Heckbert, "Simplifying surfaces with color and texture using
// quadric error metrics", IEEE Visualization 1998.
// Cost: one walk of the faces around each endpoint, O(valence), no allocation.
#pragma once

#include <algorithm>
#include <array>
#include <limits>

#include "collapse_mesh.hpp"

namespace hmdnode::lod_detail {

template <class Around, class WedgeOf>
bool EngineCore::merged_attributes(uint32_t u, uint32_t v, const glm::dvec3& target,
                                   Around&& around, WedgeOf&& wedge_of, PendingBlend& out) const {
    // note: a point on the edge (up to rounding) gets the edge's interpolation from either face
    // on it: the caller's lerp, without reading the faces.
    const glm::dvec3 pu = m_.positions[u], e = glm::dvec3(m_.positions[v]) - pu;
    const glm::dvec3 off = glm::cross(target - pu, e);
    const double ee = glm::dot(e, e);
    if (glm::dot(off, off) <= 1e-12 * ee * ee) return false;
    double best_outside = std::numeric_limits<double>::infinity(), best_distance = 0.0;
    glm::dvec3 best_l(0.0);
    std::array<uint32_t, 3> best_c{};  // the corners of the best face, in the order of best_l
    auto consider = [&](uint32_t f, uint32_t k, uint32_t p0, uint32_t p1, uint32_t p2) {
        const glm::dvec3 a = glm::dvec3(m_.positions[p0]) - target,
                         b = glm::dvec3(m_.positions[p1]) - target,
                         c = glm::dvec3(m_.positions[p2]) - target;
        const glm::dvec3 n = glm::cross(b - a, c - a);
        const double nn = glm::dot(n, n);
        if (!(nn > 0.0)) return;
        // note: the barycentric coordinates of target's projection on the face's plane (moving
        // target along n changes none of these triple products), scaled by nn.
        const double l0 = glm::dot(glm::cross(b, c), n), l1 = glm::dot(glm::cross(c, a), n);
        const double l2 = nn - l0 - l1;
        const double outside = std::max(0.0, -std::min({l0, l1, l2})) / nn;
        if (outside > best_outside + 1e-9) return;
        const double h = glm::dot(a, n);
        const double distance = h * h / nn;  // squared distance to the plane
        if (outside < best_outside - 1e-9 || distance < best_distance) {
            best_outside = outside, best_distance = distance;
            best_l = glm::dvec3(l0, l1, l2) / nn;
            const uint32_t base = 3 * f;
            best_c = {base + k, base + (k == 2 ? 0 : k + 1), base + (k == 0 ? 2 : k - 1)};
        }
    };
    // note: the new point lies near the edge, so its projection mostly falls into a face on the
    // edge: those first, and the other faces around u and v only where neither contains it.
    around(u, [&](uint32_t f, uint32_t k, uint32_t a, uint32_t b) {
        if (a == v || b == v) consider(f, k, u, a, b);
        return true;
    });
    if (best_outside > 1e-9) {
        around(u, [&](uint32_t f, uint32_t k, uint32_t a, uint32_t b) {
            if (a != v && b != v) consider(f, k, u, a, b);
            return true;
        });
        around(v, [&](uint32_t f, uint32_t k, uint32_t a, uint32_t b) {
            if (a != u && b != u) consider(f, k, v, a, b);
            return true;
        });
    }
    // note: a projection outside every face by more than rounding: no face to read it from.
    if (best_outside > 1e-6) return false;
    out.src = {wedge_of(best_c[0]), wedge_of(best_c[1]), wedge_of(best_c[2])};
    out.l = {float(best_l.x), float(best_l.y), float(best_l.z)};
    out.fallback = out.src[0];
    return true;
}

}  // namespace hmdnode::lod_detail
