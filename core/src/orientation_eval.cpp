// Orientation error against a reference with the constant world and body alignments fitted
// (orientation_eval.hpp): alternating Markley quaternion means from 24 starting body rotations.
// Cost: O((24 * 30 + k) * n) quaternion products for n samples (k <= 5000 refining rounds, until
// converged), O(n) memory.
#include "hmdnode/core/orientation_eval.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <string>

#include "hmdnode/core/pose.hpp"
#include "hmdnode/core/time.hpp"

namespace hmdnode {
namespace {

constexpr double kRadToDeg = 180.0 / kPi;

using Mat4 = std::array<std::array<double, 4>, 4>;

glm::dvec4 as_vec(const glm::dquat& q) {
    return {q.w, q.x, q.y, q.z};
}

// Markley et al. 2007: the mean of unit quaternions (sign-free) is the eigenvector of the
// largest eigenvalue of sum q q^T; power iteration from `start` (the previous mean, close to it).
glm::dquat quaternion_mean(const Mat4& m, const glm::dquat& start) {
    glm::dvec4 v = as_vec(start);
    for (int it = 0; it < 60; ++it) {
        glm::dvec4 w(0.0);
        for (int i = 0; i < 4; ++i)
            for (int j = 0; j < 4; ++j) w[i] += m[size_t(i)][size_t(j)] * v[j];
        const double n = glm::length(w);
        if (!(n > 0)) break;
        v = w / n;
    }
    return glm::normalize(glm::dquat(v[0], v[1], v[2], v[3]));
}

void add_outer(Mat4& m, const glm::dquat& q) {
    const glm::dvec4 v = as_vec(q);
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j) m[size_t(i)][size_t(j)] += v[i] * v[j];
}

// The 24 rotations of the cube: starting body alignments spread over SO(3).
std::vector<glm::dquat> cube_rotations() {
    std::vector<glm::dquat> out;
    const glm::dvec3 axes[3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    // Which face is +y (6 ways) times a turn about it (4 ways).
    const glm::dquat faces[6] = {
        glm::dquat(1, 0, 0, 0),           glm::angleAxis(kPi, axes[0]),
        glm::angleAxis(kPi / 2, axes[0]), glm::angleAxis(-kPi / 2, axes[0]),
        glm::angleAxis(kPi / 2, axes[2]), glm::angleAxis(-kPi / 2, axes[2])};
    for (const glm::dquat& f : faces)
        for (int k = 0; k < 4; ++k) out.push_back(f * glm::angleAxis(k * kPi / 2, axes[1]));
    return out;
}

}  // namespace

ErrorPercentiles error_percentiles(std::vector<double> v) {
    ErrorPercentiles p;
    if (v.empty()) return p;
    std::sort(v.begin(), v.end());
    auto rank = [&](double q) {
        const size_t k = size_t(std::ceil(q * double(v.size())));
        return v[std::clamp<size_t>(k, 1, v.size()) - 1];
    };
    p.p50 = rank(0.50);
    p.p95 = rank(0.95);
    p.max = v.back();
    return p;
}

Result<OrientationEval> evaluate_orientation(const Trace& reference, const Trace& estimate,
                                             const OrientationEvalOptions& options) {
    if (!(options.start_s >= 0) || !(options.duration_s >= 0))
        return make_error("the window's start and duration must not be negative");
    if (reference.samples.empty() || estimate.samples.empty())
        return make_error(reference.samples.empty() ? "the reference has no samples"
                                                    : "the estimate has no samples");
    OrientationEval r;
    r.window_start_ns = reference.start_ns() + int64_t(std::llround(options.start_s * 1e9));
    r.window_end_ns = options.duration_s > 0
                          ? r.window_start_ns + int64_t(std::llround(options.duration_s * 1e9))
                          : reference.end_ns();
    std::vector<glm::dquat> ref, est;
    for (const TraceSample& s : reference.samples) {
        if (s.time_ns < r.window_start_ns || s.time_ns > r.window_end_ns) continue;
        if (s.time_ns < estimate.start_ns() || s.time_ns > estimate.end_ns()) continue;
        r.time_ns.push_back(s.time_ns);
        ref.push_back(glm::normalize(s.orientation));
        est.push_back(glm::normalize(estimate.pose_at(s.time_ns).orientation));
    }
    if (ref.size() < 10) {
        char buf[256];
        std::snprintf(buf, sizeof buf,
                      "%zu reference samples in the window [%.3f, %.3f] s inside the estimate's "
                      "span [%.3f, %.3f] s (at least 10 needed; do the traces share a timeline?)",
                      ref.size(), ns_to_s(r.window_start_ns), ns_to_s(r.window_end_ns),
                      ns_to_s(estimate.start_ns()), ns_to_s(estimate.end_ns()));
        return make_error(buf);
    }
    const size_t n = ref.size();

    auto cost = [&](const glm::dquat& w, const glm::dquat& b) {
        double c = 0;
        for (size_t i = 0; i < n; ++i) {
            const double d = glm::dot(ref[i], w * est[i] * b);
            c += 1.0 - d * d;
        }
        return c;
    };
    // One round of the alternation; returns how far B moved (radians).
    auto round = [&](glm::dquat& w, glm::dquat& b, bool first) {
        Mat4 mw{};
        for (size_t i = 0; i < n; ++i) add_outer(mw, ref[i] * glm::conjugate(est[i] * b));
        w = quaternion_mean(mw, first ? ref[0] * glm::conjugate(est[0] * b) : w);
        Mat4 mb{};
        for (size_t i = 0; i < n; ++i) add_outer(mb, glm::conjugate(w * est[i]) * ref[i]);
        const glm::dquat before = b;
        b = quaternion_mean(mb, b);
        return 2.0 * std::acos(std::min(1.0, std::abs(glm::dot(before, b))));
    };
    double best = INFINITY;
    for (const glm::dquat& b0 : cube_rotations()) {
        glm::dquat b = b0, w(1, 0, 0, 0);
        for (int it = 0; it < 30; ++it) round(w, b, it == 0);
        const double c = cost(w, b);
        if (c < best) {
            best = c;
            r.world_alignment = w;
            r.body_alignment = b;
        }
    }
    // The alternation converges linearly (W and B are coupled): refine the best start until B
    // stops moving.
    for (int it = 0; it < 5000; ++it)
        if (round(r.world_alignment, r.body_alignment, false) < 1e-11) break;

    const glm::dquat& w = r.world_alignment;
    const glm::dvec3 up(0, 1, 0);
    for (size_t i = 0; i < n; ++i) {
        // The error rotation in the estimate's world.
        const glm::dquat e =
            glm::conjugate(w) * ref[i] * glm::conjugate(w * est[i] * r.body_alignment) * w;
        const double angle = 2.0 * std::acos(std::min(1.0, std::abs(e.w)));
        const glm::dvec3 moved_up = e * up;
        const double tilt = std::acos(std::clamp(glm::dot(moved_up, up), -1.0, 1.0));
        double heading = 2.0 * std::atan2(e.y, e.w);  // twist about +y
        heading = std::remainder(heading, 2.0 * kPi);
        r.error_deg.push_back(angle * kRadToDeg);
        r.tilt_deg.push_back(tilt * kRadToDeg);
        r.heading_deg.push_back(std::abs(heading) * kRadToDeg);
    }
    r.samples = n;
    r.error = error_percentiles(r.error_deg);
    r.tilt = error_percentiles(r.tilt_deg);
    r.heading = error_percentiles(r.heading_deg);
    return r;
}

}  // namespace hmdnode
