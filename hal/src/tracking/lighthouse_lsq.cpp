// Levenberg-Marquardt on lighthouse angle residuals (Levenberg 1944, Marquardt 1963; the damping
// scaled by diag(J^T J) as in Moré's MINPACK, which libsurvive's poser_mpfit.c uses through
// mpfit): the residual of an angle is measured - predicted (lh2_predict_angle / lh1_predict_angle
// with the base station's calibration), wrapped to (-pi, pi]; the pose is updated on the left,
// X <- (exp(dtheta), dt) X, so the covariance is in the target frame's axes. The model's
// derivative in the base station's frame is taken by forward differences (h = 1e-7 m: error
// ~1e-7 relative, which slows Gauss-Newton's convergence, not its fixed point); the chain rule
// does the rest. After convergence, angles with |r| > k * max(1.4826 * median |r|, floor) are
// outliers (libsurvive has no such rule: it drops whole solves above max-error) and the fit
// re-runs without them; sensors whose normal faces away from their base station at the current
// pose are left out before each round.
// Cost: 4 model evaluations per angle per iteration, a 6x6 solve per iteration; memory O(n).
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <set>

#include "hmdnode/core/str_cat.hpp"
#include "tracking/lighthouse_fit.hpp"

namespace hmdnode::lighthouse::detail {
namespace {

using Mat6 = Eigen::Matrix<double, 6, 6>;
using Vec6 = Eigen::Matrix<double, 6, 1>;
using State = FitAngle::State;

glm::dvec3 station_point(const FitAngle& a, const RigidPose& x) {
    return a.outer_r * (x.orientation * a.point + x.position) + a.outer_t;
}

double residual(const FitAngle& a, const RigidPose& x) {
    return std::remainder(a.angle - predict_angle(a, station_point(a, x)), 2 * M_PI);
}

double cost(const std::vector<FitAngle>& angles, const RigidPose& x) {
    double c = 0;
    for (const FitAngle& a : angles)
        if (a.state == State::used) c += residual(a, x) * residual(a, x);
    return c;
}

// J^T J and J^T r of the used angles (J: d predicted / d [dt, dtheta]).
void normal_equations(const std::vector<FitAngle>& angles, const RigidPose& x, Mat6& h, Vec6& g) {
    h.setZero();
    g.setZero();
    const glm::dmat3 r = glm::mat3_cast(x.orientation);
    for (const FitAngle& a : angles) {
        if (a.state != State::used) continue;
        const glm::dvec3 rp = r * a.point;
        const glm::dvec3 q = a.outer_r * (rp + x.position) + a.outer_t;
        const double f = predict_angle(a, q);
        constexpr double kH = 1e-7;
        glm::dvec3 dfdq;
        for (int k = 0; k < 3; ++k) {
            glm::dvec3 qk = q;
            qk[k] += kH;
            dfdq[k] = std::remainder(predict_angle(a, qk) - f, 2 * M_PI) / kH;
        }
        // d q / d dt = outer_r; d q / d dtheta = outer_r * -[rp]x
        const glm::dvec3 jt = glm::transpose(a.outer_r) * dfdq;  // row vector dfdq * outer_r
        const glm::dvec3 jw = glm::cross(rp, jt);                // jt * -[rp]x
        Vec6 j;
        j << jt.x, jt.y, jt.z, jw.x, jw.y, jw.z;
        const double res = std::remainder(a.angle - f, 2 * M_PI);
        h += j * j.transpose();
        g += j * res;
    }
}

RigidPose step(const RigidPose& x, const Vec6& d) {
    RigidPose y = x;
    y.position += glm::dvec3(d(0), d(1), d(2));
    const glm::dvec3 w(d(3), d(4), d(5));
    const double angle = glm::length(w);
    if (angle > 0) y.orientation = glm::normalize(glm::angleAxis(angle, w / angle) * x.orientation);
    return y;
}

// Levenberg-Marquardt over the used angles; returns the iterations taken.
int levenberg_marquardt(const std::vector<FitAngle>& angles, RigidPose& x, int max_iterations) {
    double c = cost(angles, x);
    double lambda = 1e-3;
    int it = 0;
    for (; it < max_iterations; ++it) {
        Mat6 h;
        Vec6 g;
        normal_equations(angles, x, h, g);
        bool accepted = false;
        while (!accepted && lambda < 1e10) {
            Mat6 damped = h;
            for (int k = 0; k < 6; ++k) damped(k, k) += lambda * std::max(h(k, k), 1e-12);
            const Vec6 d = damped.ldlt().solve(g);
            const RigidPose y = step(x, d);
            const double c2 = cost(angles, y);
            if (c2 <= c) {
                accepted = true;
                const double gain = c - c2;
                x = y;
                c = c2;
                lambda = std::max(lambda * 0.1, 1e-9);
                if (d.norm() < 1e-12 || gain <= 1e-16 * c + 1e-30) return it + 1;
            } else {
                lambda *= 10;
            }
        }
        if (!accepted) return it + 1;
    }
    return it;
}

// Leaves out (facing_away) the angles of sensors facing away at pose x, takes back those that
// face again; returns whether any changed.
bool update_facing(std::vector<FitAngle>& angles, const RigidPose& x, double cos_max) {
    bool changed = false;
    for (FitAngle& a : angles) {
        if (a.state == State::outlier || a.normal == glm::dvec3(0.0)) continue;
        const glm::dvec3 q = station_point(a, x);
        const glm::dvec3 n = a.outer_r * (x.orientation * a.normal);
        const State s = glm::dot(n, -glm::normalize(q)) < cos_max ? State::facing_away : State::used;
        changed |= s != a.state;
        a.state = s;
    }
    return changed;
}

// Whether the used angles are enough; `why` says what is missing.
bool enough(const std::vector<FitAngle>& angles, const SolverOptions& o, std::string& why) {
    size_t used = 0;
    std::set<int> sensors;
    for (const FitAngle& a : angles)
        if (a.state == State::used) ++used, sensors.insert(a.sensor);
    if (used >= o.min_angles && sensors.size() >= o.min_sensors) return true;
    why = cat(used, " angles on ", sensors.size(), " sensors usable (need ", o.min_angles,
                  " angles on ", o.min_sensors, " sensors)");
    return false;
}

}  // namespace

double predict_angle(const FitAngle& a, const glm::dvec3& q) {
    return a.generation == Generation::lh2 ? lh2_predict_angle(a.cal, a.plane, q)
                                           : lh1_predict_angle(a.cal, a.plane, q);
}

FitResult fit_pose(std::vector<FitAngle>& angles, const RigidPose& start, const SolverOptions& o) {
    FitResult out;
    out.pose = start;
    const double cos_max = std::cos(o.max_incidence_rad);
    for (FitAngle& a : angles) a.state = State::used;
    std::vector<double> abs_r;
    for (int round = 0; round <= o.outlier_rounds; ++round) {
        update_facing(angles, out.pose, cos_max);
        if (!enough(angles, o, out.why)) return out;
        out.iterations += levenberg_marquardt(angles, out.pose, o.max_iterations);
        if (update_facing(angles, out.pose, cos_max)) {
            if (!enough(angles, o, out.why)) return out;
            out.iterations += levenberg_marquardt(angles, out.pose, o.max_iterations);
        }
        abs_r.clear();
        for (const FitAngle& a : angles)
            if (a.state == State::used) abs_r.push_back(std::abs(residual(a, out.pose)));
        std::nth_element(abs_r.begin(), abs_r.begin() + long(abs_r.size() / 2), abs_r.end());
        const double sigma = 1.4826 * abs_r[abs_r.size() / 2];
        const double limit = o.outlier_k * std::max(sigma, o.sigma_floor_rad);
        bool rejected = false;
        if (round < o.outlier_rounds)
            for (FitAngle& a : angles)
                if (a.state == State::used && std::abs(residual(a, out.pose)) > limit) {
                    a.state = State::outlier;
                    rejected = true;
                }
        if (!rejected) break;
    }
    if (!enough(angles, o, out.why)) return out;

    Mat6 h;
    Vec6 g;
    normal_equations(angles, out.pose, h, g);
    double ssr = 0;
    for (const FitAngle& a : angles) {
        if (a.state == State::used) ++out.used, ssr += residual(a, out.pose) * residual(a, out.pose);
        out.outliers += a.state == State::outlier;
        out.facing_away += a.state == State::facing_away;
    }
    out.rms = std::sqrt(ssr / double(out.used));
    // Observability: the normal matrix must be well conditioned in every direction (positions in
    // metres and rotations in radians are commensurate at a base station's distance).
    Eigen::SelfAdjointEigenSolver<Mat6> eig(h);
    const double max_eig = eig.eigenvalues().maxCoeff();
    if (!(eig.eigenvalues().minCoeff() > 1e-10 * max_eig) || !(max_eig > 0)) {
        out.why = cat(out.used, " angles do not fix all six degrees of freedom");
        return out;
    }
    const double s2 = std::max(out.used > 6 ? ssr / double(out.used - 6) : 0.0,
                               o.sigma_floor_rad * o.sigma_floor_rad);
    const Mat6 cov = h.inverse() * s2;
    for (int r = 0; r < 6; ++r)
        for (int c = 0; c < 6; ++c) out.covariance[size_t(r * 6 + c)] = cov(r, c);
    out.enough = true;
    return out;
}

}  // namespace hmdnode::lighthouse::detail
