// Least-squares conformal maps: Levy, Petitjean, Ray & Maillot, "Least Squares Conformal Maps for
// Automatic Texture Atlas Generation", ACM Transactions on Graphics 21(3), SIGGRAPH 2002,
// section 3. On every triangle, in its own orthonormal frame, the Cauchy-Riemann equations
// u_x = v_y, u_y = -v_x of the piecewise-linear map are residuals weighted by sqrt(area); two
// pinned vertices remove the similarity freedom and the remaining least-squares problem is solved
// through its normal equations (sparse, SPD) with Eigen's SimplicialLDLT. Also here: the orthogonal
// projection used for near-planar charts and the Jacobian-based quality measure (conformal
// distortion sigma_max/sigma_min, area ratio, flipped triangles, and overlaps: triangle centroids
// strictly inside another triangle, found through a uniform grid) that both the atlas and its tests
// use.
// Cost: O(V + F) to assemble, sparse Cholesky of a 2V x 2V matrix with ~18 non-zeros per row
// (about O(V^1.5) for a disc-like chart); memory O(V + F).
// Departures: the real-valued gradient form of the energy (equivalent to the paper's complex
// form); the pins are a two-sweep diameter estimate; a weak graph-Laplacian term (1e-9 of the
// conformal weight) keeps vertices touched only by zero-area triangles determined; the result is
// rescaled so that the uv area equals the 3D area and mirrored if the majority is clockwise.
#include <algorithm>
#include <cassert>
#include <cmath>

#include <Eigen/Sparse>
#include <Eigen/SparseCholesky>

#include "hmdnode/bake/uv_atlas.hpp"

namespace hmdnode {

namespace {

// Triangle in its own frame: q0 = (0,0), q1 = (|p1-p0|, 0), q2 above the x axis. Returns the
// area (0 when degenerate).
double local_frame(const glm::dvec3& p0, const glm::dvec3& p1, const glm::dvec3& p2,
                   glm::dvec2 q[3]) {
    const glm::dvec3 e1 = p1 - p0, e2 = p2 - p0;
    const glm::dvec3 n = glm::cross(e1, e2);
    const double nl = glm::length(n), l1 = glm::length(e1);
    if (!(nl > 0.0) || !(l1 > 0.0)) return 0.0;
    const glm::dvec3 x = e1 / l1, y = glm::cross(n / nl, x);
    q[0] = {0.0, 0.0};
    q[1] = {l1, 0.0};
    q[2] = {glm::dot(e2, x), glm::dot(e2, y)};
    return 0.5 * nl;
}

double signed_area(const glm::dvec2& a, const glm::dvec2& b, const glm::dvec2& c) {
    return 0.5 * ((b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x));
}

// Triangles whose uv centroid lies strictly inside another triangle (uniform grid of about 2
// triangles per cell: O(F) expected).
size_t count_overlaps(const ChartMesh& chart, const std::vector<glm::dvec2>& uv) {
    const size_t nf = chart.indices.size() / 3;
    if (nf < 2) return 0;
    glm::dvec2 lo(1e300), hi(-1e300);
    double area = 0.0;
    for (size_t f = 0; f < nf; ++f) {
        const uint32_t* t = &chart.indices[3 * f];
        area += std::abs(signed_area(uv[t[0]], uv[t[1]], uv[t[2]]));
        for (int k = 0; k < 3; ++k) lo = glm::min(lo, uv[t[k]]), hi = glm::max(hi, uv[t[k]]);
    }
    const glm::dvec2 ext = hi - lo;
    if (!(ext.x > 0.0) || !(ext.y > 0.0)) return 0;
    const double cell =
        std::max(std::sqrt(2.0 * area / double(nf)), std::sqrt(ext.x * ext.y / (4.0 * double(nf))));
    if (!(cell > 0.0)) return 0;
    const int gx = std::min(int(ext.x / cell) + 1, 1 << 14);
    const int gy = std::min(int(ext.y / cell) + 1, 1 << 14);
    auto cx = [&](double x) { return std::clamp(int((x - lo.x) / cell), 0, gx - 1); };
    auto cy = [&](double y) { return std::clamp(int((y - lo.y) / cell), 0, gy - 1); };
    std::vector<std::vector<uint32_t>> grid(size_t(gx) * size_t(gy));
    for (size_t f = 0; f < nf; ++f) {
        const uint32_t* t = &chart.indices[3 * f];
        const glm::dvec2 a = glm::min(uv[t[0]], glm::min(uv[t[1]], uv[t[2]]));
        const glm::dvec2 b = glm::max(uv[t[0]], glm::max(uv[t[1]], uv[t[2]]));
        for (int y = cy(a.y); y <= cy(b.y); ++y)
            for (int x = cx(a.x); x <= cx(b.x); ++x)
                grid[size_t(y) * size_t(gx) + size_t(x)].push_back(uint32_t(f));
    }
    size_t count = 0;
    for (size_t f = 0; f < nf; ++f) {
        const uint32_t* t = &chart.indices[3 * f];
        const glm::dvec2 c = (uv[t[0]] + uv[t[1]] + uv[t[2]]) / 3.0;
        for (uint32_t g : grid[size_t(cy(c.y)) * size_t(gx) + size_t(cx(c.x))]) {
            if (g == f) continue;
            const uint32_t* s = &chart.indices[3 * size_t(g)];
            const glm::dvec2 A = uv[s[0]], B = uv[s[1]], C = uv[s[2]];
            const double d = signed_area(A, B, C);
            if (!(std::abs(d) > 0.0)) continue;
            // Barycentric coordinates of c in (A, B, C).
            const double u = signed_area(A, c, C) / d, v = signed_area(A, B, c) / d;
            const double eps = 1e-6;
            if (u > eps && v > eps && 1.0 - u - v > eps) {
                ++count;
                break;
            }
        }
    }
    return count;
}

}  // namespace

Result<std::vector<glm::dvec2>> lscm_parameterise(const ChartMesh& chart) {
    const size_t nv = chart.positions.size(), nf = chart.indices.size() / 3;
    if (nv < 3 || nf == 0) return make_error("lscm: chart has fewer than 3 vertices or no face");

    // Pins: a two-sweep estimate of the chart's diameter.
    auto farthest = [&](size_t from) {
        size_t best = from;
        double d = -1.0;
        for (size_t i = 0; i < nv; ++i) {
            double di = glm::length(chart.positions[i] - chart.positions[from]);
            if (di > d) d = di, best = i;
        }
        return best;
    };
    assert(chart.indices.size() % 3 == 0);
    assert(std::all_of(chart.indices.begin(), chart.indices.end(),
                       [nv](uint32_t i) { return i < nv; }));
    const size_t pin_a = farthest(0), pin_b = farthest(pin_a);
    const double diameter = glm::length(chart.positions[pin_b] - chart.positions[pin_a]);
    if (pin_a == pin_b || !(diameter > 0.0)) return make_error("lscm: chart has zero extent");

    // Unknown numbering: vertex i -> columns 2c, 2c+1 (u, v) for free vertices; pins fixed.
    std::vector<int> col(nv, -1);
    int nfree = 0;
    for (size_t i = 0; i < nv; ++i)
        if (i != pin_a && i != pin_b) col[i] = nfree++;
    assert(nfree == int(nv) - 2);  // two pins, the rest free
    std::vector<glm::dvec2> uv(nv, glm::dvec2(0.0));
    uv[pin_a] = {0.0, 0.0};
    uv[pin_b] = {diameter, 0.0};

    const int n = 2 * nfree;
    std::vector<Eigen::Triplet<double>> trip;
    trip.reserve(nf * 2 * 36 + nf * 3 * 8);
    Eigen::VectorXd rhs = Eigen::VectorXd::Zero(n);

    // Adds one residual row  sum_k coef[k] * x[var[k]]  (var = 2*vertex + {0 u, 1 v}).
    auto add_row = [&](const double* coef, const size_t* var, int count, double weight) {
        double fixed = 0.0;
        for (int a = 0; a < count; ++a) {
            const size_t vtx = var[a] / 2;
            if (col[vtx] < 0) fixed += coef[a] * uv[vtx][int(var[a] % 2)];
        }
        for (int a = 0; a < count; ++a) {
            const size_t va = var[a] / 2;
            if (col[va] < 0) continue;
            const int ca = 2 * col[va] + int(var[a] % 2);
            rhs[ca] -= weight * coef[a] * fixed;
            for (int b = 0; b < count; ++b) {
                const size_t vb = var[b] / 2;
                if (col[vb] < 0) continue;
                const int cb = 2 * col[vb] + int(var[b] % 2);
                trip.emplace_back(ca, cb, weight * coef[a] * coef[b]);
            }
        }
    };

    double total_area = 0.0;
    for (size_t f = 0; f < nf; ++f) {
        const uint32_t* t = &chart.indices[3 * f];
        glm::dvec2 q[3];
        const double area =
            local_frame(chart.positions[t[0]], chart.positions[t[1]], chart.positions[t[2]], q);
        if (area <= 0.0) continue;
        total_area += area;
        double gx[3], gy[3];
        for (int m = 0; m < 3; ++m) {
            const glm::dvec2 e = q[(m + 2) % 3] - q[(m + 1) % 3];
            gx[m] = -e.y / (2.0 * area);
            gy[m] = e.x / (2.0 * area);
        }
        // u_x - v_y = 0
        double c1[6] = {gx[0], gx[1], gx[2], -gy[0], -gy[1], -gy[2]};
        size_t v1[6] = {2 * t[0], 2 * t[1], 2 * t[2], 2 * t[0] + 1, 2 * t[1] + 1, 2 * t[2] + 1};
        add_row(c1, v1, 6, area);
        // u_y + v_x = 0
        double c2[6] = {gy[0], gy[1], gy[2], gx[0], gx[1], gx[2]};
        add_row(c2, v1, 6, area);
    }
    if (!(total_area > 0.0)) return make_error("lscm: chart has zero area");

    // Weak graph Laplacian (dimensionless weight, like the conformal term).
    const double eps = 1e-9;
    for (size_t f = 0; f < nf; ++f) {
        const uint32_t* t = &chart.indices[3 * f];
        for (int e = 0; e < 3; ++e) {
            const uint32_t a = t[e], b = t[(e + 1) % 3];
            if (a == b) continue;
            for (size_t k = 0; k < 2; ++k) {
                double c[2] = {1.0, -1.0};
                size_t v[2] = {2 * size_t(a) + k, 2 * size_t(b) + k};
                add_row(c, v, 2, eps);
            }
        }
    }

    if (n > 0) {
        Eigen::SparseMatrix<double> A(n, n);
        A.setFromTriplets(trip.begin(), trip.end());
        Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> solver(A);
        if (solver.info() != Eigen::Success) return make_error("lscm: factorisation failed");
        Eigen::VectorXd x = solver.solve(rhs);
        if (solver.info() != Eigen::Success) return make_error("lscm: solve failed");
        for (size_t i = 0; i < nv; ++i) {
            if (col[i] < 0) continue;
            uv[i] = {x[2 * col[i]], x[2 * col[i] + 1]};
            if (!std::isfinite(uv[i].x) || !std::isfinite(uv[i].y))
                return make_error("lscm: non-finite solution");
        }
    }

    // Orientation and scale.
    double uv_area = 0.0;
    for (size_t f = 0; f < nf; ++f) {
        const uint32_t* t = &chart.indices[3 * f];
        uv_area += signed_area(uv[t[0]], uv[t[1]], uv[t[2]]);
    }
    if (uv_area < 0.0) {
        for (auto& w : uv) w.x = -w.x;
        uv_area = -uv_area;
    }
    if (!(uv_area > 0.0)) return make_error("lscm: the map collapsed the chart");
    const double s = std::sqrt(total_area / uv_area);
    for (auto& w : uv) w *= s;
    return uv;
}

std::vector<glm::dvec2> planar_parameterise(const ChartMesh& chart) {
    assert(chart.indices.size() % 3 == 0);
    glm::dvec3 sum(0.0);
    const size_t nf = chart.indices.size() / 3;
    for (size_t f = 0; f < nf; ++f) {
        const uint32_t* t = &chart.indices[3 * f];
        sum += glm::cross(chart.positions[t[1]] - chart.positions[t[0]],
                          chart.positions[t[2]] - chart.positions[t[0]]);
    }
    glm::dvec3 n = glm::length(sum) > 0.0 ? glm::normalize(sum) : glm::dvec3(0.0, 0.0, 1.0);
    const glm::dvec3 helper =
        std::abs(n.x) < 0.9 ? glm::dvec3(1.0, 0.0, 0.0) : glm::dvec3(0.0, 1.0, 0.0);
    const glm::dvec3 x = glm::normalize(glm::cross(helper, n));
    const glm::dvec3 y = glm::cross(n, x);
    std::vector<glm::dvec2> uv(chart.positions.size());
    for (size_t i = 0; i < uv.size(); ++i)
        uv[i] = {glm::dot(chart.positions[i], x), glm::dot(chart.positions[i], y)};
    return uv;
}

ParamQuality measure_parameterisation(const ChartMesh& chart, const std::vector<glm::dvec2>& uv) {
    assert(uv.size() == chart.positions.size() && chart.indices.size() % 3 == 0);
    ParamQuality q;
    const size_t nf = chart.indices.size() / 3;
    struct Tri {
        double area, s1, s2, det;
    };
    std::vector<Tri> tris;
    tris.reserve(nf);
    double area3 = 0.0, area2 = 0.0;
    size_t positive = 0, negative = 0;
    for (size_t f = 0; f < nf; ++f) {
        const uint32_t* t = &chart.indices[3 * f];
        glm::dvec2 p[3];
        const double a =
            local_frame(chart.positions[t[0]], chart.positions[t[1]], chart.positions[t[2]], p);
        if (a <= 0.0) {
            ++q.degenerate;
            continue;
        }
        // J maps local (x, y) to uv: J * [p1-p0, p2-p0] = [w1-w0, w2-w0].
        const glm::dmat2 P(p[1] - p[0], p[2] - p[0]);
        const glm::dmat2 W(uv[t[1]] - uv[t[0]], uv[t[2]] - uv[t[0]]);
        const glm::dmat2 J = W * glm::inverse(P);
        const double det = glm::determinant(J);
        // Singular values of a 2x2 matrix: sqrt of the eigenvalues of J^T J.
        const double a11 = J[0][0], a21 = J[0][1], a12 = J[1][0], a22 = J[1][1];
        const double E = (a11 + a22) / 2, F = (a11 - a22) / 2, G = (a21 + a12) / 2,
                     H = (a21 - a12) / 2;
        const double Qv = std::sqrt(E * E + H * H), R = std::sqrt(F * F + G * G);
        tris.push_back({a, Qv + R, std::abs(Qv - R), det});
        area3 += a;
        area2 += a * std::abs(det);
        (det >= 0.0 ? positive : negative)++;
    }
    if (tris.empty() || !(area3 > 0.0)) return q;
    q.area_ratio = area2 / area3;
    const double scale = std::sqrt(q.area_ratio);
    const bool majority_positive = positive >= negative;
    double sum = 0.0;
    q.max_conformal = 1.0;
    q.max_stretch = 0.0;
    q.min_stretch = 1e300;
    for (const Tri& t : tris) {
        const double c = t.s2 > 0.0 ? t.s1 / t.s2 : 1e9;
        sum += t.area * c;
        q.max_conformal = std::max(q.max_conformal, c);
        if (scale > 0.0) {
            q.max_stretch = std::max(q.max_stretch, t.s1 / scale);
            q.min_stretch = std::min(q.min_stretch, t.s2 / scale);
        }
        if ((t.det >= 0.0) != majority_positive) ++q.flipped;
        const double r = std::abs(t.det) / q.area_ratio;
        if (r > 0.0)
            q.max_area_distortion = std::max(q.max_area_distortion, std::max(r, 1.0 / r));
        else
            q.max_area_distortion = 1e9;
    }
    q.mean_conformal = sum / area3;
    q.overlapping = count_overlaps(chart, uv);
    return q;
}

}  // namespace hmdnode
