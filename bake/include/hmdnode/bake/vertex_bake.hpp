// Per-vertex baking of irradiance into _LIGHT_0 (Primitive::light; docs/baking.md "Per-vertex
// mode"), two ways side by side:
//  * AngleWeighted (vertex_angle_weighted.cpp): as Lazányi 2003 section 3 does it -- every face is
//    sampled at several points, its value is their mean, and a vertex takes the average of its
//    incident faces' values weighted by each face's corner angle at that vertex;
//  * LeastSquares (vertex_least_squares.cpp): Kavan, Bargteil & Sloan 2011, "Least Squares
//    Vertex Baking" -- the vertex values c minimise  sum over samples of w |f(x) - sum_i c_i
//    phi_i(x)|^2  (linear hat functions phi_i, the same sample points as above), i.e. M c = b with
//    the sampled mass matrix; optional seam regularisation across vertices that share a position.
// plus optional longest-edge bisection of large triangles before baking (split_long_edges).
//
// The oracle gives irradiance E (rgb) at a world point with a unit world normal; the bake's path
// tracer passes its estimator, tests pass closed forms. It is called from the calling thread
// only, in a deterministic order. Stored result (docs/formats.md shading contract):
// _LIGHT_0 = max(E, 0) as float (any brightness; glTF's COLOR_0 must stay within [0, 1]), and the
// renderer's albedo * E / pi is the outgoing radiance of a Lambertian surface. COLOR_0, a real
// vertex colour, is left alone.
#pragma once

#include <cstddef>
#include <functional>
#include <vector>

#include <glm/glm.hpp>

#include "hmdnode/core/result.hpp"
#include "hmdnode/core/scene.hpp"

namespace hmdnode {

using IrradianceOracle =
    std::function<glm::vec3(const glm::vec3& world_p, const glm::vec3& world_n)>;

enum class VertexBakeMethod { AngleWeighted, LeastSquares };

struct VertexBakeOptions {
    VertexBakeMethod method = VertexBakeMethod::LeastSquares;
    // Each triangle is sampled at the centroids of its subdivision into n x n similar
    // sub-triangles (n^2 samples, equal weights area / n^2). n >= 2 for LeastSquares.
    int subdivisions = 4;
    // LeastSquares: weight of the seam term  seam_weight * sum over vertex pairs sharing a
    // position of |c_i - c_j|^2 * (mean area of the triangles around them); 0 = off (the paper's
    // regularisation, simplified). Ignored by AngleWeighted (which already averages per index).
    double seam_weight = 0.0;
    // > 0: split_long_edges(primitive, max_edge_m / world scale) first (metres in world space).
    double max_edge_m = 0.0;
};

// Irradiance per vertex of `prim` placed by `world` (normals transformed by the inverse
// transpose; area-weighted face normals when the primitive has none). Vertices used by no
// triangle get the oracle at the vertex itself. Error: non-finite positions, subdivisions out of
// range, a singular system (LeastSquares).
Result<std::vector<glm::vec3>> vertex_irradiance_angle_weighted(const Primitive& prim,
                                                                const glm::dmat4& world,
                                                                const IrradianceOracle& oracle,
                                                                int subdivisions);
Result<std::vector<glm::vec3>> vertex_irradiance_least_squares(const Primitive& prim,
                                                               const glm::dmat4& world,
                                                               const IrradianceOracle& oracle,
                                                               int subdivisions,
                                                               double seam_weight = 0.0);

// Splits, conformingly (no T-junctions, also across vertices that share a position), every
// triangle edge longer than max_edge (in the primitive's own space) by repeated longest-edge
// bisection, interpolating every attribute at the midpoints (normals renormalised). Returns the
// number of triangles added.
size_t split_long_edges(Primitive& prim, double max_edge);

struct VertexBakeReport {
    size_t vertices = 0;
    size_t triangles_added = 0;  // by split_long_edges
};
// Bakes one primitive: optional split, irradiance by options.method, _LIGHT_0 = max(E, 0).
Result<VertexBakeReport> bake_vertex_irradiance(Primitive& prim, const glm::dmat4& world,
                                                const IrradianceOracle& oracle,
                                                const VertexBakeOptions& options);

// Root-mean-square over the surface of |f - sum c_i phi_i| (per channel, then the vector norm),
// by the sampling rule above with `subdivisions` per triangle: the L2 error of vertex values
// against the true field, normalised by the area. For comparing the two methods.
double vertex_l2_error(const Primitive& prim, const glm::dmat4& world,
                       const IrradianceOracle& oracle, const std::vector<glm::vec3>& vertex_values,
                       int subdivisions);

}  // namespace hmdnode
