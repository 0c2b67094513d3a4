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

constexpr int kN = 12;  // [dt, dtheta, v, omega]
using MatN = Eigen::Matrix<double, kN, kN>;
using VecN = Eigen::Matrix<double, kN, 1>;
using Mat6 = Eigen::Matrix<double, 6, 6>;
using State = FitAngle::State;

// The fit's unknowns: the pose at the reference time and, with the velocity model, the velocities.
struct X {
    RigidPose pose;
    glm::dvec3 v{0.0}, w{0.0};
};

glm::dquat rotation_vector(const glm::dvec3& w) {
    const double a = glm::length(w);
    return a > 0 ? glm::angleAxis(a, w / a) : glm::dquat(1, 0, 0, 0);
}

// The point in the base station's frame at the angle's time; `rp_out`: its rotated model point.
glm::dvec3 station_point(const FitAngle& a, const X& x, glm::dvec3* rp_out = nullptr) {
    glm::dvec3 rp = x.pose.orientation * a.point;
    if (rp_out) *rp_out = rp;
    glm::dvec3 p = rp + x.pose.position;
    if (a.dt_s != 0) p = rotation_vector(x.w * a.dt_s) * rp + x.pose.position + x.v * a.dt_s;
    return a.outer_r * p + a.outer_t;
}

double residual(const FitAngle& a, const X& x) {
    return std::remainder(a.angle - predict_angle(a, station_point(a, x)), 2 * M_PI);
}

// The prior's weights on v and omega, in the residuals' units (rad^2 per (m/s)^2, (rad/s)^2).
struct Prior {
    double v = 0, w = 0;
};

double cost(const std::vector<FitAngle>& angles, const X& x, const Prior& pr) {
    double c = pr.v * glm::dot(x.v, x.v) + pr.w * glm::dot(x.w, x.w);
    for (const FitAngle& a : angles)
        if (a.state == State::used) c += residual(a, x) * residual(a, x);
    return c;
}

// J^T J and J^T r of the used angles (J: d predicted / d [dt, dtheta, v, omega]) and the prior.
void normal_equations(const std::vector<FitAngle>& angles, const X& x, bool velocity,
                      const Prior& pr, MatN& h, VecN& g) {
    h.setZero();
    g.setZero();
    for (const FitAngle& a : angles) {
        if (a.state != State::used) continue;
        glm::dvec3 rp;
        const glm::dvec3 q = station_point(a, x, &rp);
        const double f = predict_angle(a, q);
        constexpr double kH = 1e-7;
        glm::dvec3 dfdq;
        for (int k = 0; k < 3; ++k) {
            glm::dvec3 qk = q;
            qk[k] += kH;
            dfdq[k] = std::remainder(predict_angle(a, qk) - f, 2 * M_PI) / kH;
        }
        // d q / d dt = outer_r; d q / d dtheta = outer_r * Rw * -[rp]x (Rw = exp(dt [w]x)),
        // d q / d v = dt * outer_r, d q / d omega ~ dt * outer_r * -[Rw rp]x
        const glm::dvec3 jt = glm::transpose(a.outer_r) * dfdq;
        VecN j = VecN::Zero();
        j.head<3>() << jt.x, jt.y, jt.z;
        if (velocity && a.dt_s != 0) {
            const glm::dquat rw = rotation_vector(x.w * a.dt_s);
            const glm::dvec3 jw = glm::cross(rp, glm::conjugate(rw) * jt);
            const glm::dvec3 jo = a.dt_s * glm::cross(rw * rp, jt);
            j.segment<3>(3) << jw.x, jw.y, jw.z;
            j.segment<3>(6) << a.dt_s * jt.x, a.dt_s * jt.y, a.dt_s * jt.z;
            j.segment<3>(9) << jo.x, jo.y, jo.z;
        } else {
            const glm::dvec3 jw = glm::cross(rp, jt);  // jt * -[rp]x
            j.segment<3>(3) << jw.x, jw.y, jw.z;
        }
        const double res = std::remainder(a.angle - f, 2 * M_PI);
        h.selfadjointView<Eigen::Upper>().rankUpdate(j);
        g += j * res;
    }
    h = h.selfadjointView<Eigen::Upper>();
    for (int k = 6; k < 12; ++k) {
        const double wgt = velocity ? (k < 9 ? pr.v : pr.w) : 1.0;
        h(k, k) += wgt;
        g(k) -= velocity ? wgt * (k < 9 ? x.v[k - 6] : x.w[k - 9]) : 0.0;
    }
}

X step(const X& x, const VecN& d, bool velocity) {
    X y = x;
    y.pose.position += glm::dvec3(d(0), d(1), d(2));
    y.pose.orientation =
        glm::normalize(rotation_vector(glm::dvec3(d(3), d(4), d(5))) * x.pose.orientation);
    if (velocity) {
        y.v += glm::dvec3(d(6), d(7), d(8));
        y.w += glm::dvec3(d(9), d(10), d(11));
    }
    return y;
}

// Levenberg-Marquardt over the used angles; returns the iterations taken.
int levenberg_marquardt(const std::vector<FitAngle>& angles, X& x, bool velocity, const Prior& pr,
                        int max_iterations) {
    double c = cost(angles, x, pr);
    double lambda = 1e-3;
    int it = 0;
    for (; it < max_iterations; ++it) {
        MatN h;
        VecN g;
        normal_equations(angles, x, velocity, pr, h, g);
        bool accepted = false;
        while (!accepted && lambda < 1e10) {
            MatN damped = h;
            for (int k = 0; k < kN; ++k) damped(k, k) += lambda * std::max(h(k, k), 1e-12);
            const VecN d = damped.ldlt().solve(g);
            const X y = step(x, d, velocity);
            const double c2 = cost(angles, y, pr);
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
bool update_facing(std::vector<FitAngle>& angles, const X& x, double cos_max) {
    bool changed = false;
    for (FitAngle& a : angles) {
        if (a.state == State::outlier || a.normal == glm::dvec3(0.0)) continue;
        const glm::dvec3 q = station_point(a, x);
        const glm::dvec3 n = a.outer_r * (x.pose.orientation * a.normal);
        const State s =
            glm::dot(n, -glm::normalize(q)) < cos_max ? State::facing_away : State::used;
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

FitResult fit_pose(std::vector<FitAngle>& angles, const RigidPose& start, const SolverOptions& o,
                   bool velocity) {
    FitResult out;
    X x{start};
    const Prior pr{
        velocity ? std::pow(o.sigma_floor_rad / o.velocity_prior_m_s, 2) : 0.0,
        velocity ? std::pow(o.sigma_floor_rad / o.angular_velocity_prior_rad_s, 2) : 0.0};
    const double cos_max = std::cos(o.max_incidence_rad);
    for (FitAngle& a : angles) a.state = State::used;
    std::vector<double> abs_r;
    for (int round = 0; round <= o.outlier_rounds; ++round) {
        update_facing(angles, x, cos_max);
        if (!enough(angles, o, out.why)) return out;
        out.iterations += levenberg_marquardt(angles, x, velocity, pr, o.max_iterations);
        if (update_facing(angles, x, cos_max)) {
            if (!enough(angles, o, out.why)) return out;
            out.iterations += levenberg_marquardt(angles, x, velocity, pr, o.max_iterations);
        }
        abs_r.clear();
        for (const FitAngle& a : angles)
            if (a.state == State::used) abs_r.push_back(std::abs(residual(a, x)));
        std::nth_element(abs_r.begin(), abs_r.begin() + long(abs_r.size() / 2), abs_r.end());
        const double sigma = 1.4826 * abs_r[abs_r.size() / 2];
        const double limit = o.outlier_k * std::max(sigma, o.sigma_floor_rad);
        bool rejected = false;
        if (round < o.outlier_rounds)
            for (FitAngle& a : angles)
                if (a.state == State::used && std::abs(residual(a, x)) > limit) {
                    a.state = State::outlier;
                    rejected = true;
                }
        if (!rejected) break;
    }
    if (!enough(angles, o, out.why)) return out;

    MatN h;
    VecN g;
    normal_equations(angles, x, velocity, pr, h, g);
    double ssr = 0;
    for (const FitAngle& a : angles) {
        if (a.state == State::used) ++out.used, ssr += residual(a, x) * residual(a, x);
        out.outliers += a.state == State::outlier;
        out.facing_away += a.state == State::facing_away;
    }
    out.rms = std::sqrt(ssr / double(out.used));
    // Observability of the pose: its information once the velocities are marginalised (the Schur
    // complement) must be well conditioned in every direction (metres and radians are
    // commensurate at a base station's distance).
    const Mat6 info = h.topLeftCorner<6, 6>() - h.topRightCorner<6, 6>() *
                                                    h.bottomRightCorner<6, 6>().inverse() *
                                                    h.bottomLeftCorner<6, 6>();
    Eigen::SelfAdjointEigenSolver<Mat6> eig(info);
    const double max_eig = eig.eigenvalues().maxCoeff();
    if (!(eig.eigenvalues().minCoeff() > 1e-10 * max_eig) || !(max_eig > 0)) {
        out.why = cat(out.used, " angles do not fix all six degrees of freedom");
        return out;
    }
    const size_t unknowns = velocity ? 12 : 6;
    const double s2 = std::max(out.used > unknowns ? ssr / double(out.used - unknowns) : 0.0,
                               o.sigma_floor_rad * o.sigma_floor_rad);
    const Mat6 cov = info.inverse() * s2;
    for (int r = 0; r < 6; ++r)
        for (int c = 0; c < 6; ++c) out.covariance[size_t(r * 6 + c)] = cov(r, c);
    out.pose = x.pose;
    out.velocity = x.v;
    out.angular_velocity = x.w;
    out.moving = velocity;
    out.enough = true;
    return out;
}

}  // namespace hmdnode::lighthouse::detail
