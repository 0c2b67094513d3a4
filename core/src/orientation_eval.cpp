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

#include "hmdnode/core/percentile.hpp"
#include "hmdnode/core/pose.hpp"
#include "hmdnode/core/time.hpp"

namespace hmdnode {
namespace {

constexpr double kRadToDeg = 180.0 / kPi;

using Mat4 = std::array<std::array<double, 4>, 4>;

glm::dvec4 as_vec(const glm::dquat& q) {
    return {q.w, q.x, q.y, q.z};
}

// F. L. Markley, Y. Cheng, J. L. Crassidis, Y. Oshman, "Averaging quaternions", Journal of
// Guidance, Control, and Dynamics 30(4), 2007: the mean of unit quaternions (sign-free) is the
// eigenvector of the largest eigenvalue of sum q q^T; power iteration from `start` (the previous
// mean, close to it).
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
    p.p50 = percentile_sorted(v, 0.50);
    p.p95 = percentile_sorted(v, 0.95);
    p.max = v.back();
    return p;
}

namespace {

// Least-squares W, B for fixed sample pairs (orientation_eval.hpp).
class AlignmentFit {
  public:
    AlignmentFit(const std::vector<glm::dquat>& ref, const std::vector<glm::dquat>& est)
        : ref_(ref), est_(est) {}

    double cost(const glm::dquat& w, const glm::dquat& b) const {
        double c = 0;
        for (size_t i = 0; i < ref_.size(); ++i) {
            const double d = glm::dot(ref_[i], w * est_[i] * b);
            c += 1.0 - d * d;
        }
        return c;
    }
    // One round of the alternation; returns how far B moved (radians).
    double round(glm::dquat& w, glm::dquat& b, bool first) const {
        Mat4 mw{};
        for (size_t i = 0; i < ref_.size(); ++i)
            add_outer(mw, ref_[i] * glm::conjugate(est_[i] * b));
        w = quaternion_mean(mw, first ? ref_[0] * glm::conjugate(est_[0] * b) : w);
        Mat4 mb{};
        for (size_t i = 0; i < ref_.size(); ++i)
            add_outer(mb, glm::conjugate(w * est_[i]) * ref_[i]);
        const glm::dquat before = b;
        b = quaternion_mean(mb, b);
        return 2.0 * std::acos(std::min(1.0, std::abs(glm::dot(before, b))));
    }
    // From the 24 cube rotations as starting B, then refined until B stops moving (the
    // alternation converges linearly: W and B are coupled).
    double global(glm::dquat& w_out, glm::dquat& b_out) const {
        double best = INFINITY;
        for (const glm::dquat& b0 : cube_rotations()) {
            glm::dquat b = b0, w(1, 0, 0, 0);
            for (int it = 0; it < 30; ++it) round(w, b, it == 0);
            const double c = cost(w, b);
            if (c < best) {
                best = c;
                w_out = w;
                b_out = b;
            }
        }
        for (int it = 0; it < 5000; ++it)
            if (round(w_out, b_out, false) < 1e-11) break;
        return cost(w_out, b_out);
    }
    // `rounds` rounds from a given W, B (a nearby time offset's fit).
    double local(glm::dquat w, glm::dquat b, int rounds) const {
        for (int it = 0; it < rounds; ++it) round(w, b, false);
        return cost(w, b);
    }

  private:
    const std::vector<glm::dquat>& ref_;
    const std::vector<glm::dquat>& est_;
};

double angle_rad(const glm::dquat& a, const glm::dquat& b) {
    return 2.0 * std::acos(std::min(1.0, std::abs(glm::dot(a, b))));
}

// The reference's glitches (orientation_eval.hpp, top) among the reference samples `idx` (in time
// order, each inside the estimate's span at `offset_ns`); left_out[i] set for those left out.
ReferenceGlitches find_glitches(const Trace& reference, const Trace& estimate,
                                const std::vector<size_t>& idx, int64_t offset_ns,
                                const OrientationEvalOptions& o, std::vector<char>* left_out) {
    ReferenceGlitches g;
    if (idx.size() < 3) return g;
    auto ref_q = [&](size_t k) { return glm::normalize(reference.samples[idx[k]].orientation); };
    auto time = [&](size_t k) { return reference.samples[idx[k]].time_ns; };
    auto est_q = [&](size_t k) {
        return glm::normalize(estimate.pose_at(time(k) - offset_ns).orientation);
    };
    // The reference's rotation from sample a to b less the estimate's, degrees.
    auto excess = [&](size_t a, size_t b) {
        return (angle_rad(ref_q(a), ref_q(b)) - angle_rad(est_q(a), est_q(b))) * kRadToDeg;
    };
    std::vector<double> ex(idx.size() - 1);
    for (size_t k = 0; k + 1 < idx.size(); ++k) ex[k] = excess(k, k + 1);
    std::vector<double> sorted = ex;
    std::sort(sorted.begin(), sorted.end());
    const double med = percentile_sorted(sorted, 0.5);
    std::vector<double> dev(ex.size());
    for (size_t k = 0; k < ex.size(); ++k) dev[k] = std::abs(ex[k] - med);
    std::sort(dev.begin(), dev.end());
    const double sigma = 1.4826 * percentile_sorted(dev, 0.5);
    g.threshold_deg = std::max(o.glitch_min_step_deg, med + 20.0 * sigma);
    const int64_t max_ns = int64_t(std::llround(o.glitch_max_excursion_s * 1e9));
    for (size_t k = 0; k < ex.size(); ++k) {
        if (!(ex[k] > g.threshold_deg)) continue;
        ++g.steps;
        if (ex[k] > g.worst_step_deg) {
            const double dt = ns_to_s(time(k + 1) - time(k));
            g.worst_step_deg = ex[k];
            g.worst_at_ns = time(k);
            g.worst_reference_rate_deg_s = angle_rad(ref_q(k), ref_q(k + 1)) * kRadToDeg / dt;
            g.worst_estimate_rate_deg_s = angle_rad(est_q(k), est_q(k + 1)) * kRadToDeg / dt;
        }
        // A later step after which the reference agrees with the estimate across both: an
        // excursion, samples k+1..m left out.
        bool closed = false;
        for (size_t m = k + 1; m < ex.size() && time(m + 1) - time(k) <= max_ns; ++m) {
            if (!(ex[m] > g.threshold_deg) || !(excess(k, m + 1) <= g.threshold_deg)) continue;
            for (size_t j = k + 1; j <= m; ++j) (*left_out)[idx[j]] = 1;
            g.samples_left_out += m - k;
            ++g.excursions;
            ++g.steps;
            for (size_t j = k + 1; j <= m; ++j)  // steps inside the excursion, counted
                if (j < m && ex[j] > g.threshold_deg) ++g.steps;
            k = m;
            closed = true;
            break;
        }
        if (!closed) {
            ++g.unreturned_steps;
            g.unreturned_at_ns.push_back(time(k));
        }
    }
    return g;
}

// The offset's scale (orientation_eval.hpp, top): the rms error at the fit (w, b) over the
// reference's rms rotation rate over 50 ms spans, into r.
void offset_scale(const std::vector<glm::dquat>& ref, const std::vector<glm::dquat>& est,
                  const std::vector<int64_t>& times, const glm::dquat& w, const glm::dquat& b,
                  OrientationEval* r) {
    double e2 = 0, w2 = 0;
    size_t nw = 0;
    for (size_t i = 0, j = 0; i < ref.size(); ++i) {
        const double e = angle_rad(ref[i], w * est[i] * b);
        e2 += e * e;
        while (j < ref.size() && times[j] < times[i] + 50 * kNsPerMs) ++j;
        if (j >= ref.size()) continue;
        const double rate = angle_rad(ref[i], ref[j]) / ns_to_s(times[j] - times[i]);
        w2 += rate * rate;
        ++nw;
    }
    const double rms_e = std::sqrt(e2 / double(ref.size()));
    const double rms_w = nw ? std::sqrt(w2 / double(nw)) : 0.0;
    r->reference_rate_rms_deg_s = rms_w * kRadToDeg;
    r->time_offset_sigma_ms = rms_w > 0 ? rms_e / rms_w * 1e3 : INFINITY;
}

}  // namespace

std::optional<std::string> trace_time_base(const Trace& trace) {
    for (const std::string& c : trace.comments) {
        const size_t at = c.find_first_not_of(' ');
        if (at != std::string::npos && c.compare(at, 10, "time_base ") == 0)
            return c.substr(at + 10);
    }
    return std::nullopt;
}

Result<OrientationEval> evaluate_orientation(const Trace& reference, const Trace& estimate,
                                             const OrientationEvalOptions& options) {
    if (!(options.start_s >= 0) || !(options.duration_s >= 0))
        return make_error("the window's start and duration must not be negative");
    if (!(options.max_time_offset_s > 0) || !std::isfinite(options.time_offset_s))
        return make_error("the time offset must be finite and its search range positive");
    if (reference.samples.empty() || estimate.samples.empty())
        return make_error(reference.samples.empty() ? "the reference has no samples"
                                                    : "the estimate has no samples");
    OrientationEval r;
    r.window_start_ns = reference.start_ns() + int64_t(std::llround(options.start_s * 1e9));
    r.window_end_ns = options.duration_s > 0
                          ? r.window_start_ns + int64_t(std::llround(options.duration_s * 1e9))
                          : reference.end_ns();
    // Reference samples in the window whose estimate, `margin` either side, is inside its span.
    // Reference samples left out as glitches (found at the given offset, 0 when it is fitted).
    std::vector<char> left_out(reference.samples.size(), 0);
    auto collect = [&](int64_t offset_ns, int64_t margin_ns, std::vector<int64_t>* times,
                       std::vector<glm::dquat>* ref, std::vector<size_t>* indices = nullptr) {
        times->clear();
        ref->clear();
        for (size_t i = 0; i < reference.samples.size(); ++i) {
            const TraceSample& s = reference.samples[i];
            if (s.time_ns < r.window_start_ns || s.time_ns > r.window_end_ns || left_out[i])
                continue;
            const int64_t t = s.time_ns - offset_ns;
            if (t - margin_ns < estimate.start_ns() || t + margin_ns > estimate.end_ns()) continue;
            times->push_back(s.time_ns);
            ref->push_back(glm::normalize(s.orientation));
            if (indices) indices->push_back(i);
        }
    };
    auto estimate_at = [&](const std::vector<int64_t>& times, int64_t offset_ns,
                           std::vector<glm::dquat>* est) {
        est->resize(times.size());
        for (size_t i = 0; i < times.size(); ++i)
            (*est)[i] = glm::normalize(estimate.pose_at(times[i] - offset_ns).orientation);
    };
    auto too_few = [&](size_t n) {
        char buf[256];
        std::snprintf(buf, sizeof buf,
                      "%zu reference samples in the window [%.3f, %.3f] s inside the estimate's "
                      "span [%.3f, %.3f] s (at least 10 needed; do the traces share a timeline?)",
                      n, ns_to_s(r.window_start_ns), ns_to_s(r.window_end_ns),
                      ns_to_s(estimate.start_ns()), ns_to_s(estimate.end_ns()));
        return make_error(buf);
    };

    std::vector<int64_t> times;
    std::vector<glm::dquat> ref, est;
    int64_t offset_ns = int64_t(std::llround(options.time_offset_s * 1e9));
    if (options.leave_out_reference_glitches) {
        std::vector<size_t> idx;
        collect(offset_ns, 0, &times, &ref, &idx);
        r.glitches = find_glitches(reference, estimate, idx, offset_ns, options, &left_out);
    }
    if (options.fit_time_offset) {
        // The time offset: a grid of 1 ms steps over +-max_time_offset_s (each offset's W, B a few
        // rounds from the zero offset's fit: the alignment hardly depends on the offset), then a
        // golden-section search in the best step's neighbourhood, to 1 us. The same samples
        // throughout: those inside the estimate's span at every offset searched.
        const int64_t range_ns = int64_t(std::llround(options.max_time_offset_s * 1e9));
        collect(0, range_ns, &times, &ref);
        if (ref.size() < 10) return too_few(ref.size());
        estimate_at(times, 0, &est);
        AlignmentFit fit(ref, est);
        glm::dquat w0, b0;
        fit.global(w0, b0);
        offset_scale(ref, est, times, w0, b0, &r);
        auto cost_at = [&](int64_t off, int rounds) {
            estimate_at(times, off, &est);
            return fit.local(w0, b0, rounds);
        };
        constexpr int64_t kStep = 1'000'000;
        int64_t best = 0;
        double best_cost = INFINITY;
        double worst_cost = 0;
        for (int64_t off = -(range_ns / kStep) * kStep; off <= range_ns; off += kStep) {
            const double c = cost_at(off, 3);
            worst_cost = std::max(worst_cost, c);
            if (c < best_cost) {
                best_cost = c;
                best = off;
            }
        }
        // Flat: over the whole range the cost does not double (the offset moves the error less
        // than the error's own floor).
        r.time_offset_observable = worst_cost > 2.0 * best_cost;
        const int64_t edge = (range_ns / kStep) * kStep;
        double lo = double(std::max(best - kStep, -edge)),
               hi = double(std::min(best + kStep, edge));
        const double g = (std::sqrt(5.0) - 1.0) / 2.0;
        double x1 = hi - g * (hi - lo), x2 = lo + g * (hi - lo);
        double f1 = cost_at(std::llround(x1), 20), f2 = cost_at(std::llround(x2), 20);
        while (hi - lo > 1000.0) {
            if (f1 < f2) {
                hi = x2;
                x2 = x1;
                f2 = f1;
                x1 = hi - g * (hi - lo);
                f1 = cost_at(std::llround(x1), 20);
            } else {
                lo = x1;
                x1 = x2;
                f1 = f2;
                x2 = lo + g * (hi - lo);
                f2 = cost_at(std::llround(x2), 20);
            }
        }
        offset_ns = std::llround((lo + hi) / 2.0);
        r.time_offset_at_range_limit = std::llabs(best) >= edge;
        if (!r.time_offset_observable) {  // noise: the given offset (0) instead
            r.unobservable_fit_ms = double(offset_ns) * 1e-6;
            offset_ns = int64_t(std::llround(options.time_offset_s * 1e9));
            r.time_offset_at_range_limit = false;
        }
    }
    r.time_offset_ns = offset_ns;
    collect(offset_ns, 0, &times, &ref);
    if (ref.size() < 10) return too_few(ref.size());
    estimate_at(times, offset_ns, &est);
    r.time_ns = times;
    const size_t n = ref.size();
    AlignmentFit(ref, est).global(r.world_alignment, r.body_alignment);

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
