// Position error against a reference with a constant rigid alignment and lever arm fitted
// (position_eval.hpp): Horn's (1987) closed-form absolute orientation alternated with a linear
// least squares for the lever arm, over the orientation evaluation's samples; the time offset
// given or found on a grid. Cost: O(rounds * n) per offset, O(n) memory.
#include "hmdnode/core/position_eval.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include "hmdnode/core/percentile.hpp"

namespace hmdnode {
namespace position_eval_detail {

using Mat6 = std::array<std::array<double, 6>, 6>;

// Solves a x = b (n <= 6) by Gaussian elimination with partial pivoting; false when a pivot is
// below 1e-12 times the largest diagonal entry (singular).
bool solve_small(Mat6 a, std::array<double, 6> b, int n, std::array<double, 6>* x) {
    double scale = 0;
    for (int i = 0; i < n; ++i) scale = std::max(scale, std::abs(a[size_t(i)][size_t(i)]));
    for (int c = 0; c < n; ++c) {
        int p = c;
        for (int r = c + 1; r < n; ++r)
            if (std::abs(a[size_t(r)][size_t(c)]) > std::abs(a[size_t(p)][size_t(c)])) p = r;
        if (!(std::abs(a[size_t(p)][size_t(c)]) > 1e-12 * scale)) return false;
        std::swap(a[size_t(p)], a[size_t(c)]);
        std::swap(b[size_t(p)], b[size_t(c)]);
        for (int r = c + 1; r < n; ++r) {
            const double f = a[size_t(r)][size_t(c)] / a[size_t(c)][size_t(c)];
            for (int k = c; k < n; ++k) a[size_t(r)][size_t(k)] -= f * a[size_t(c)][size_t(k)];
            b[size_t(r)] -= f * b[size_t(c)];
        }
    }
    for (int r = n - 1; r >= 0; --r) {
        double s = b[size_t(r)];
        for (int k = r + 1; k < n; ++k) s -= a[size_t(r)][size_t(k)] * (*x)[size_t(k)];
        (*x)[size_t(r)] = s / a[size_t(r)][size_t(r)];
    }
    return true;
}

struct Sample {
    glm::dvec3 ref;    // reference position
    glm::dvec3 est;    // estimate position
    glm::dmat3 r_est;  // estimate orientation
};

struct Fit {
    glm::dquat w_rot{1, 0, 0, 0};
    glm::dvec3 w{0.0}, l{0.0};
    double cost = INFINITY;  // mean squared distance (m^2)
};

// B. K. P. Horn, "Closed-form solution of absolute orientation using unit quaternions", JOSA A
// 4(4), 1987: the rotation taking the centred points a_i onto b_i is the principal eigenvector
// of his symmetric 4x4 N (power iteration on N + |N| I, from the previous rotation).
glm::dquat horn_rotation(const std::vector<glm::dvec3>& a, const std::vector<glm::dvec3>& b,
                         const glm::dquat& start) {
    double s[3][3] = {};
    for (size_t i = 0; i < a.size(); ++i)
        for (int j = 0; j < 3; ++j)
            for (int k = 0; k < 3; ++k) s[j][k] += a[i][j] * b[i][k];
    const double sxx = s[0][0], sxy = s[0][1], sxz = s[0][2], syx = s[1][0], syy = s[1][1],
                 syz = s[1][2], szx = s[2][0], szy = s[2][1], szz = s[2][2];
    double n[4][4] = {{sxx + syy + szz, syz - szy, szx - sxz, sxy - syx},
                      {syz - szy, sxx - syy - szz, sxy + syx, szx + sxz},
                      {szx - sxz, sxy + syx, -sxx + syy - szz, syz + szy},
                      {sxy - syx, szx + sxz, syz + szy, -sxx - syy + szz}};
    double norm = 0;
    for (auto& row : n)
        for (double v : row) norm += v * v;
    norm = std::sqrt(norm);
    for (int i = 0; i < 4; ++i) n[i][i] += norm;  // positive semi-definite, same eigenvectors
    double v[4] = {start.w, start.x, start.y, start.z};
    for (int it = 0; it < 200; ++it) {
        double w[4] = {};
        for (int i = 0; i < 4; ++i)
            for (int j = 0; j < 4; ++j) w[i] += n[i][j] * v[j];
        const double len = std::sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2] + w[3] * w[3]);
        if (!(len > 0)) break;
        for (int i = 0; i < 4; ++i) v[i] = w[i] / len;
    }
    return glm::normalize(glm::dquat(v[0], v[1], v[2], v[3]));
}

// l and w given W (rows [I, W R_est] of ref - W est = w + W R_est l).
bool fit_lever(const std::vector<Sample>& s, const glm::dmat3& wm, bool lever, Fit* f) {
    const int n = lever ? 6 : 3;
    Mat6 m{};
    std::array<double, 6> rhs{};
    for (const Sample& p : s) {
        const glm::dmat3 a = wm * p.r_est;
        const glm::dvec3 d = p.ref - wm * p.est;
        std::array<std::array<double, 6>, 3> row{};
        for (int i = 0; i < 3; ++i) {
            row[size_t(i)][size_t(i)] = 1.0;
            for (int k = 0; k < 3 && lever; ++k) row[size_t(i)][size_t(3 + k)] = a[k][i];
        }
        for (int i = 0; i < n; ++i) {
            for (int j = 0; j < n; ++j)
                for (int k = 0; k < 3; ++k)
                    m[size_t(i)][size_t(j)] +=
                        row[size_t(k)][size_t(i)] * row[size_t(k)][size_t(j)];
            for (int k = 0; k < 3; ++k) rhs[size_t(i)] += row[size_t(k)][size_t(i)] * d[k];
        }
    }
    std::array<double, 6> x{};
    if (!solve_small(m, rhs, n, &x)) return false;
    f->w = glm::dvec3(x[0], x[1], x[2]);
    f->l = lever ? glm::dvec3(x[3], x[4], x[5]) : glm::dvec3(0.0);
    return true;
}

double residual(const Sample& p, const Fit& f) {
    const glm::dmat3 wm = glm::mat3_cast(f.w_rot);
    return glm::length(p.ref - (wm * (p.est + p.r_est * f.l) + f.w));
}

// `rounds` of the alternation from `f`; false when the lever arm is not observable.
bool refine(const std::vector<Sample>& s, const PositionEvalOptions& o, int rounds, Fit* f) {
    std::vector<glm::dvec3> a(s.size()), b(s.size());
    for (int round = 0; round < rounds; ++round) {
        if (o.fit_rotation) {
            glm::dvec3 ca(0.0), cb(0.0);
            for (size_t i = 0; i < s.size(); ++i) {
                a[i] = s[i].est + s[i].r_est * f->l;
                ca += a[i];
                cb += s[i].ref;
            }
            ca /= double(s.size());
            cb /= double(s.size());
            for (size_t i = 0; i < s.size(); ++i) {
                a[i] -= ca;
                b[i] = s[i].ref - cb;
            }
            f->w_rot = horn_rotation(a, b, f->w_rot);
        }
        if (!fit_lever(s, glm::mat3_cast(f->w_rot), o.fit_lever_arm, f)) return false;
    }
    double ss = 0;
    for (const Sample& p : s) ss += residual(p, *f) * residual(p, *f);
    f->cost = ss / double(s.size());
    return true;
}

std::vector<Sample> samples_at(const Trace& ref, const Trace& est,
                               const std::vector<int64_t>& times, int64_t offset_ns) {
    std::vector<Sample> s;
    s.reserve(times.size());
    for (int64_t t : times) {
        const Pose r = ref.pose_at(t);
        const Pose e = est.pose_at(t - offset_ns);
        s.push_back({r.position, e.position, glm::mat3_cast(glm::normalize(e.orientation))});
    }
    return s;
}

}  // namespace position_eval_detail

Result<PositionEval> evaluate_position(const Trace& reference, const Trace& estimate,
                                       const OrientationEval& o, const PositionEvalOptions& opt) {
    using namespace position_eval_detail;
    if (reference.samples.empty() || !reference.samples.front().position)
        return make_error("the reference has no positions (px, py, pz)");
    if (estimate.samples.empty() || !estimate.samples.front().position)
        return make_error("the estimate has no positions (px, py, pz)");
    if (o.time_ns.size() < 10)
        return make_error(std::to_string(o.time_ns.size()) +
                          " samples to compare positions at (at least 10 needed)");
    const Result<PositionEval> unobservable = make_error(
        "the lever arm between the traces' points cannot be fitted: the estimate hardly turns "
        "over the window");
    Fit base;
    base.w_rot = glm::normalize(o.world_alignment);
    int64_t offset = o.time_offset_ns;
    if (!refine(samples_at(reference, estimate, o.time_ns, offset), opt, 30, &base))
        return unobservable;
    if (opt.fit_time_offset) {
        const int64_t range = int64_t(std::llround(opt.max_time_offset_s * 1e9));
        double best = INFINITY;
        for (int64_t off = -range / 1'000'000 * 1'000'000; off <= range; off += 1'000'000) {
            Fit f = base;
            if (!refine(samples_at(reference, estimate, o.time_ns, off), opt, 3, &f)) continue;
            if (f.cost < best) best = f.cost, offset = off;
        }
        if (!refine(samples_at(reference, estimate, o.time_ns, offset), opt, 30, &base))
            return unobservable;
    }
    PositionEval out;
    out.world_rotation = base.w_rot;
    out.world_offset = base.w;
    out.lever_arm = base.l;
    out.time_offset_ns = offset;
    out.time_offset_fitted = opt.fit_time_offset;
    for (const Sample& p : samples_at(reference, estimate, o.time_ns, offset))
        out.error_mm.push_back(residual(p, base) * 1e3);
    std::vector<double> sorted = out.error_mm;
    std::sort(sorted.begin(), sorted.end());
    out.p50_mm = percentile_sorted(sorted, 0.5);
    out.p90_mm = percentile_sorted(sorted, 0.9);
    out.max_mm = sorted.back();
    out.samples = sorted.size();
    return out;
}

}  // namespace hmdnode
