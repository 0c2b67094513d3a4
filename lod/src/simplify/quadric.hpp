// Garland-Heckbert quadrics, shared by the QEM-type costs (qem.cpp, curvature_qem.cpp): the
// quadric type, the optimal placement of a merged vertex, and the per-position quadrics of a mesh.
//
// Paper: M. Garland, P. Heckbert, "Surface simplification using quadric error metrics", SIGGRAPH
// 1997 (quadrics of face planes weighted by area, boundary planes, the placement solve).
// Cost: a quadric is 11 doubles; adding two or evaluating one is O(1); position_quadrics() is
// O(V + F) (defined in qem.cpp, as is optimal_placement(), O(1)).
#pragma once

#include <glm/glm.hpp>

#include "collapse_engine.hpp"

namespace hmdnode::lod_detail {

// A symmetric 4x4 quadric (Garland & Heckbert 1997) v^T A v + 2 b.v + c, plus the total weight
// (area) it gathered, for error estimates.
struct Quadric {
    double a00 = 0, a01 = 0, a02 = 0, a11 = 0, a12 = 0, a22 = 0;
    double b0 = 0, b1 = 0, b2 = 0, c = 0;
    double weight = 0;

    // The plane n.x + d = 0 (n unit length) with weight w.
    static Quadric plane(const glm::dvec3& n, double d, double w) {
        Quadric q;
        q.a00 = w * n.x * n.x, q.a01 = w * n.x * n.y, q.a02 = w * n.x * n.z;
        q.a11 = w * n.y * n.y, q.a12 = w * n.y * n.z, q.a22 = w * n.z * n.z;
        q.b0 = w * n.x * d, q.b1 = w * n.y * d, q.b2 = w * n.z * d;
        q.c = w * d * d;
        q.weight = w;
        return q;
    }
    Quadric& operator+=(const Quadric& o) {
        a00 += o.a00, a01 += o.a01, a02 += o.a02, a11 += o.a11, a12 += o.a12, a22 += o.a22;
        b0 += o.b0, b1 += o.b1, b2 += o.b2, c += o.c, weight += o.weight;
        return *this;
    }
    Quadric operator+(const Quadric& o) const {
        Quadric q = *this;
        q += o;
        return q;
    }
    Quadric operator*(double s) const {
        Quadric q;
        q.a00 = a00 * s, q.a01 = a01 * s, q.a02 = a02 * s, q.a11 = a11 * s, q.a12 = a12 * s;
        q.a22 = a22 * s, q.b0 = b0 * s, q.b1 = b1 * s, q.b2 = b2 * s, q.c = c * s;
        q.weight = weight * s;
        return q;
    }
    double evaluate(const glm::dvec3& v) const {
        const double ax = a00 * v.x + a01 * v.y + a02 * v.z;
        const double ay = a01 * v.x + a11 * v.y + a12 * v.z;
        const double az = a02 * v.x + a12 * v.y + a22 * v.z;
        const double r =
            v.x * ax + v.y * ay + v.z * az + 2.0 * (b0 * v.x + b1 * v.y + b2 * v.z) + c;
        return r > 0.0 ? r : 0.0;
    }
};

// The placement of Garland & Heckbert for merging p and q under quadric `q`: the minimiser of the
// 3x3 system when well conditioned (and not far off the edge), else the minimiser on the segment,
// else the best of the endpoints and the midpoint. Returns the point; `cost` its quadric value.
glm::dvec3 optimal_placement(const Quadric& q, const glm::dvec3& p0, const glm::dvec3& p1,
                             double& cost);

// Garland & Heckbert's per-position quadrics (qem.cpp): the planes of the faces around each
// position weighted by face area, plus, for every border edge and each side of every seam edge,
// the plane through the edge perpendicular to its face, weighted by kBoundaryWeight * length^2.
inline constexpr double kBoundaryWeight = 10.0;
Scratch<Quadric> position_quadrics(const CollapseMesh& mesh);

}  // namespace hmdnode::lod_detail
