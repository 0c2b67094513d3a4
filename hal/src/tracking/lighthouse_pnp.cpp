// Perspective-n-point by orthogonal iteration: Lu, Hager & Mjolsness, "Fast and globally
// convergent pose estimation from video images", IEEE PAMI 22(6), 2000. With V_i = v_i v_i^T the
// projector onto ray i, the object-space error E(R, t) = sum |(I - V_i)(R p_i + t)|^2; for a
// given R the best t is closed form, t(R) = (I - mean V)^-1 mean((V_i - I) R p_i), and R is then
// updated as the absolute orientation (Horn / Kabsch by SVD) of the points onto their projections
// on the rays, q_i = V_i (R p_i + t(R)). The rays here are a base station's ideal directions to
// its sensors (lh2_ideal_direction / lh1_ideal_direction), which the lighthouse literature
// (libsurvive's poser_barycentric_svd.c, an EPnP) treats as a pinhole camera's.
// Cost: O(n) per iteration, <= 50 iterations from each of 24 starts; memory O(n).
#include <Eigen/Dense>
#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>

#include "tracking/lighthouse_fit.hpp"

namespace hmdnode::lighthouse::detail {
namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;

Vector3d ev(const glm::dvec3& v) {
    return {v.x, v.y, v.z};
}

// The rotation R minimising sum |R a_i + t - b_i|^2 (centred sets).
Matrix3d absolute_orientation(std::span<const Vector3d> a, std::span<const Vector3d> b) {
    Vector3d ma = Vector3d::Zero(), mb = Vector3d::Zero();
    for (size_t i = 0; i < a.size(); ++i) ma += a[i], mb += b[i];
    ma /= double(a.size());
    mb /= double(b.size());
    Matrix3d h = Matrix3d::Zero();
    for (size_t i = 0; i < a.size(); ++i) h += (b[i] - mb) * (a[i] - ma).transpose();
    Eigen::JacobiSVD<Matrix3d> svd(h, Eigen::ComputeFullU | Eigen::ComputeFullV);
    Matrix3d d = Matrix3d::Identity();
    d(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1.0 : 1.0;
    return svd.matrixU() * d * svd.matrixV().transpose();
}

// The 24 rotations of a cube: the starts that cover the rotation group.
std::array<Matrix3d, 24> cube_rotations() {
    std::array<Matrix3d, 24> out;
    size_t k = 0;
    const Matrix3d rx = Eigen::AngleAxisd(M_PI / 2, Vector3d::UnitX()).toRotationMatrix();
    const Matrix3d ry = Eigen::AngleAxisd(M_PI / 2, Vector3d::UnitY()).toRotationMatrix();
    const Matrix3d rz = Eigen::AngleAxisd(M_PI / 2, Vector3d::UnitZ()).toRotationMatrix();
    // six directions for the x axis, four turns about it each
    const Matrix3d faces[6] = {Matrix3d::Identity(), rz, rz * rz, rz * rz * rz, ry, ry.transpose()};
    for (const Matrix3d& f : faces) {
        Matrix3d turn = Matrix3d::Identity();
        for (int i = 0; i < 4; ++i, turn = turn * rx) out[k++] = f * turn;
    }
    return out;
}

std::optional<RigidPose> pnp_once(std::span<const glm::dvec3> points,
                                  std::span<const glm::dvec3> rays,
                                  std::span<const glm::dvec3> normals, double max_incidence_rad) {
    assert(points.size() == rays.size());
    assert(normals.empty() || normals.size() == points.size());
    const size_t n = points.size();
    if (n < 3) return std::nullopt;
    std::vector<Vector3d> p(n), v(n), q(n), rp(n);
    std::vector<Matrix3d> proj(n);
    Matrix3d mean_v = Matrix3d::Zero();
    for (size_t i = 0; i < n; ++i) {
        p[i] = ev(points[i]);
        v[i] = ev(rays[i]).normalized();
        proj[i] = v[i] * v[i].transpose();
        mean_v += proj[i];
    }
    mean_v /= double(n);
    const Matrix3d t_factor = (Matrix3d::Identity() - mean_v).inverse() / double(n);
    auto best_t = [&](const Matrix3d& r) {
        Vector3d s = Vector3d::Zero();
        for (size_t i = 0; i < n; ++i) s += (proj[i] - Matrix3d::Identity()) * (r * p[i]);
        return Vector3d(t_factor * s);
    };
    auto error = [&](const Matrix3d& r, const Vector3d& t) {
        double e = 0;
        for (size_t i = 0; i < n; ++i)
            e += ((Matrix3d::Identity() - proj[i]) * (r * p[i] + t)).squaredNorm();
        return e;
    };
    // The first start: the rays' spread aligned with the points' (rotation only; scale-free).
    const Matrix3d r0 = absolute_orientation(p, v);
    const double cos_max = std::cos(max_incidence_rad);

    std::optional<RigidPose> best;
    size_t best_away = std::numeric_limits<size_t>::max();
    double best_e = std::numeric_limits<double>::infinity();
    for (const Matrix3d& c : cube_rotations()) {
        Matrix3d r = r0 * c;
        Vector3d t = best_t(r);
        double e = error(r, t);
        for (int it = 0; it < 50; ++it) {
            for (size_t i = 0; i < n; ++i) q[i] = proj[i] * (r * p[i] + t);
            r = absolute_orientation(p, q);
            t = best_t(r);
            const double e2 = error(r, t);
            const bool done = e - e2 <= 1e-12 * e + 1e-30;
            e = e2;
            if (done) break;
        }
        size_t behind = 0, away = 0;
        for (size_t i = 0; i < n; ++i) {
            const Vector3d x = r * p[i] + t;
            if (x.dot(v[i]) <= 0) ++behind;
            if (!normals.empty() && (r * ev(normals[i])).dot(-x.normalized()) < cos_max) ++away;
        }
        away += behind;  // (an outlying ray among them: the fit's outlier rule decides later)
        if (away < best_away || (away == best_away && e < best_e)) {
            const Eigen::Quaterniond qr(r);
            best = RigidPose{{t.x(), t.y(), t.z()},
                             glm::normalize(glm::dquat(qr.w(), qr.x(), qr.y(), qr.z()))};
            best_away = away;
            best_e = e;
        }
    }
    return best;
}

}  // namespace

std::optional<RigidPose> pnp_orthogonal_iteration(std::span<const glm::dvec3> points,
                                                  std::span<const glm::dvec3> rays,
                                                  std::span<const glm::dvec3> normals,
                                                  double max_incidence_rad) {
    std::vector<glm::dvec3> p(points.begin(), points.end()), v(rays.begin(), rays.end()),
        n(normals.begin(), normals.end());
    // A stray ray (a reflection, a hit at the sweep's edge) pulls the whole solution: up to three
    // times, the point whose ray it misses most (angle), when 5 times the median miss and over
    // 20 mrad, is left out and the pose solved again.
    for (int drop = 0;; ++drop) {
        std::optional<RigidPose> pose = pnp_once(p, v, n, max_incidence_rad);
        if (!pose || drop == 3 || p.size() <= 4) return pose;
        std::vector<double> miss(p.size());
        for (size_t i = 0; i < p.size(); ++i) {
            const glm::dvec3 x = pose->orientation * p[i] + pose->position;
            miss[i] =
                std::acos(std::clamp(glm::dot(glm::normalize(x), glm::normalize(v[i])), -1.0, 1.0));
        }
        std::vector<double> sorted = miss;
        std::nth_element(sorted.begin(), sorted.begin() + long(sorted.size() / 2), sorted.end());
        const size_t worst = size_t(std::max_element(miss.begin(), miss.end()) - miss.begin());
        if (miss[worst] <= std::max(5 * sorted[sorted.size() / 2], 0.02)) return pose;
        p.erase(p.begin() + long(worst));
        v.erase(v.begin() + long(worst));
        if (!n.empty()) n.erase(n.begin() + long(worst));
    }
}

}  // namespace hmdnode::lighthouse::detail
