// Least-squares vertex baking: Kavan, Bargteil & Sloan, "Least Squares Vertex Baking", Computer
// Graphics Forum 30(4) (EGSR 2011), section 3: the vertex values c minimise the L2 distance between
// the signal f and its piecewise-linear interpolant  E(c) = integral |f - sum_i c_i phi_i|^2, i.e.
// M c = b with the mass matrix M_ij = integral phi_i phi_j and b_i = integral f phi_i, both
// integrated here by the same sampling rule (n^2 sub-triangle centroids per face, equal weights),
// so that a signal that is itself piecewise linear is reproduced exactly. Section 4's
// regularisation, simplified: an optional term  seam_weight * a * sum |c_i - c_j|^2  over vertex
// pairs sharing a position (a = mean triangle area) pulls the two sides of a seam together. Also
// here: the dispatcher bake_vertex_irradiance and the L2 error measure used to compare both
// methods.
// Cost: O(F n^2) oracle calls, a sparse Cholesky (SimplicialLDLT) of the V x V mass matrix (7
// non-zeros per row on a regular mesh), three right-hand sides; memory O(V + F).
// Departures: no edge-based regularisation of the paper's section 4.2 (smoothness term); the
// integration rule is the sampled one rather than exact per-triangle quadrature.
#include <algorithm>
#include <cassert>
#include <cmath>

#include <Eigen/Sparse>
#include <Eigen/SparseCholesky>

#include "hmdnode/bake/uv_atlas.hpp"
#include "hmdnode/bake/vertex_bake.hpp"
#include "vertex_sampling.hpp"

namespace hmdnode {

Result<std::vector<glm::vec3>> vertex_irradiance_least_squares(const Primitive& prim,
                                                               const glm::dmat4& world,
                                                               const IrradianceOracle& oracle,
                                                               int subdivisions,
                                                               double seam_weight) {
    using namespace vertex_detail;
    if (subdivisions < 2 || subdivisions > 64)
        return make_error("vertex bake: least squares needs subdivisions in [2, 64]");
    if (!(seam_weight >= 0.0)) return make_error("vertex bake: seam_weight must be >= 0");
    auto placed = place(prim, world);
    if (!placed.ok()) return placed.error();
    const WorldPrimitive& w = *placed;
    const size_t nv = prim.positions.size();
    std::vector<Eigen::Triplet<double>> trip;
    trip.reserve(prim.triangle_count() * 9 + nv);
    Eigen::MatrixXd rhs = Eigen::MatrixXd::Zero(Eigen::Index(nv), 3);
    std::vector<char> used(nv, 0);
    std::vector<Sample> samples;
    double total_area = 0.0;
    for (size_t f = 0; f < prim.triangle_count(); ++f) {
        sample_triangle(w, prim, f, subdivisions, samples);
        const uint32_t* t = &prim.indices[3 * f];
        assert(t[0] < nv && t[1] < nv && t[2] < nv);  // place() checked the indices
        double m[3][3] = {};
        for (const Sample& s : samples) {
            total_area += s.w;
            const glm::dvec3 e = eval(oracle, s);
            for (int a = 0; a < 3; ++a) {
                for (int c = 0; c < 3; ++c) rhs(Eigen::Index(t[a]), c) += s.w * s.b[a] * e[c];
                for (int b = 0; b < 3; ++b) m[a][b] += s.w * s.b[a] * s.b[b];
            }
        }
        if (samples.empty() || samples[0].w <= 0.0) continue;  // zero-area face
        for (int a = 0; a < 3; ++a) {
            used[t[a]] = 1;
            for (int b = 0; b < 3; ++b) trip.emplace_back(int(t[a]), int(t[b]), m[a][b]);
        }
    }
    // Unused vertices: identity rows with the oracle at the vertex.
    for (size_t v = 0; v < nv; ++v)
        if (!used[v]) {
            trip.emplace_back(int(v), int(v), 1.0);
            const glm::dvec3 e = at_vertex(w, oracle, v);
            for (int c = 0; c < 3; ++c) rhs(Eigen::Index(v), c) = e[c];
        }
    if (seam_weight > 0.0 && prim.triangle_count() > 0) {
        const double k = seam_weight * total_area / double(prim.triangle_count());
        const std::vector<uint32_t> weld = weld_positions(prim.positions);
        for (size_t v = 0; v < nv; ++v) {
            const uint32_t u = weld[v];
            assert(u <= v);  // the lowest index of its position
            if (u == v || !used[v] || !used[u]) continue;
            trip.emplace_back(int(v), int(v), k);
            trip.emplace_back(int(u), int(u), k);
            trip.emplace_back(int(v), int(u), -k);
            trip.emplace_back(int(u), int(v), -k);
        }
    }
    const Eigen::Index dim = Eigen::Index(nv);
    Eigen::SparseMatrix<double> M(dim, dim);
    M.setFromTriplets(trip.begin(), trip.end());
    Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> solver(M);
    if (solver.info() != Eigen::Success)
        return make_error("vertex bake: the mass matrix is singular");
    Eigen::MatrixXd c = solver.solve(rhs);
    if (solver.info() != Eigen::Success) return make_error("vertex bake: solve failed");
    std::vector<glm::vec3> out(nv);
    for (size_t v = 0; v < nv; ++v) {
        out[v] = glm::vec3(float(c(Eigen::Index(v), 0)), float(c(Eigen::Index(v), 1)),
                           float(c(Eigen::Index(v), 2)));
        if (!std::isfinite(out[v].x) || !std::isfinite(out[v].y) || !std::isfinite(out[v].z))
            return make_error("vertex bake: non-finite solution at vertex " + std::to_string(v));
    }
    return out;
}

double vertex_l2_error(const Primitive& prim, const glm::dmat4& world,
                       const IrradianceOracle& oracle, const std::vector<glm::vec3>& values,
                       int subdivisions) {
    using namespace vertex_detail;
    auto placed = place(prim, world);
    if (!placed.ok() || values.size() != prim.positions.size() || subdivisions < 1) return -1.0;
    std::vector<Sample> samples;
    double err = 0.0, area = 0.0;
    for (size_t f = 0; f < prim.triangle_count(); ++f) {
        sample_triangle(*placed, prim, f, subdivisions, samples);
        const uint32_t* t = &prim.indices[3 * f];
        for (const Sample& s : samples) {
            glm::dvec3 approx(0.0);
            for (int a = 0; a < 3; ++a) approx += s.b[a] * glm::dvec3(values[t[a]]);
            const glm::dvec3 d = eval(oracle, s) - approx;
            err += s.w * glm::dot(d, d);
            area += s.w;
        }
    }
    return area > 0.0 ? std::sqrt(err / area) : 0.0;
}

Result<VertexBakeReport> bake_vertex_irradiance(Primitive& prim, const glm::dmat4& world,
                                                const IrradianceOracle& oracle,
                                                const VertexBakeOptions& options) {
    VertexBakeReport report;
    if (options.max_edge_m > 0.0) {
        const double s =
            std::max({glm::length(glm::dvec3(world[0])), glm::length(glm::dvec3(world[1])),
                      glm::length(glm::dvec3(world[2]))});
        if (!(s > 0.0)) return make_error("vertex bake: the world transform has zero scale");
        report.triangles_added = split_long_edges(prim, options.max_edge_m / s);
    }
    auto e = options.method == VertexBakeMethod::LeastSquares
                 ? vertex_irradiance_least_squares(prim, world, oracle, options.subdivisions,
                                                   options.seam_weight)
                 : vertex_irradiance_angle_weighted(prim, world, oracle, options.subdivisions);
    if (!e.ok()) return e.error();
    assert(e->size() == prim.positions.size());
    prim.light.resize(prim.positions.size());
    for (size_t v = 0; v < prim.positions.size(); ++v)
        prim.light[v] = glm::max((*e)[v], glm::vec3(0.0f));
    report.vertices = prim.positions.size();
    return report;
}

}  // namespace hmdnode
