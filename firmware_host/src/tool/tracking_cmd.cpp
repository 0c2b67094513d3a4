// `hmdnode tracking eval`: the orientation error of an estimated trace (e.g. `hmdnode record
// --backend rec`'s fused output) against a reference trace (e.g. its lighthouse poses), after the
// constant world and body alignments (core/orientation_eval.hpp); a JSON report and an SVG plot of
// the error against time. Docs: docs/tracking.md §8.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "hmdnode/core/atomic_file.hpp"
#include "hmdnode/core/orientation_eval.hpp"
#include "hmdnode/core/position_eval.hpp"
#include "hmdnode/core/time.hpp"
#include "hmdnode/core/trace.hpp"
#include "tool/cli_errors.hpp"
#include "tool/commands.hpp"
#include "tool/tracking_commands.hpp"

namespace hmdnode::tool {
namespace {

const CliErrors errors{"tracking eval"};

struct EvalArgs {
    std::string reference, estimate, report, plot;
    std::string imu_only;           // an IMU-only trace compared with the estimate's orientation
    std::string time_offset = "0";  // "auto" or milliseconds
    OrientationEvalOptions options;
};

nlohmann::json percentiles(const ErrorPercentiles& p) {
    auto r = [](double v) { return std::round(v * 1e4) / 1e4; };
    return {{"p50", r(p.p50)}, {"p95", r(p.p95)}, {"max", r(p.max)}};
}

// Intervals the estimate marks as disturbed by saturated IMU samples (`hmdnode record --backend
// rec` writes comments `saturated_ns FIRST LAST COUNT`, estimate times), widened to what they
// disturb: 50 ms before (the slerp between samples), 0.5 s after (the fusion's recovery).
struct Saturation {
    std::vector<std::pair<int64_t, int64_t>> intervals;  // disturbed spans, estimate times
    uint64_t samples = 0;                                // saturated IMU samples
};

Saturation saturation_of(const Trace& est) {
    Saturation sat;
    for (const std::string& c : est.comments) {
        long long first = 0, last = 0;
        unsigned long long count = 0;
        if (std::sscanf(c.c_str(), " saturated_ns %lld %lld %llu", &first, &last, &count) != 3)
            continue;
        sat.intervals.emplace_back(first - 50 * kNsPerMs, last + 500 * kNsPerMs);
        sat.samples += count;
    }
    return sat;
}

nlohmann::json quat_wxyz(const glm::dquat& q) {
    return {q.w, q.x, q.y, q.z};
}

// Error, tilt and heading (degrees) against seconds from the window's start, as an SVG.
std::string error_plot_svg(const OrientationEval& e, const std::string& title) {
    const double w = 900, h = 360, left = 60, right = 20, top = 30, bottom = 40;
    const double t_end = std::max(1e-9, ns_to_s(e.time_ns.back() - e.time_ns.front()));
    double y_max = 0.1;
    for (double v : e.error_deg) y_max = std::max(y_max, v);
    y_max *= 1.1;
    auto x_of = [&](int64_t t) {
        return left + (w - left - right) * ns_to_s(t - e.time_ns.front()) / t_end;
    };
    auto y_of = [&](double v) { return top + (h - top - bottom) * (1.0 - v / y_max); };
    std::string s;
    char buf[256];
    std::snprintf(buf, sizeof buf,
                  "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"%.0f\" height=\"%.0f\" "
                  "font-family=\"sans-serif\" font-size=\"12\">\n<rect width=\"100%%\" "
                  "height=\"100%%\" fill=\"white\"/>\n",
                  w, h);
    s += buf;
    std::string esc;
    for (char c : title) esc += c == '<' ? "&lt;" : c == '&' ? "&amp;" : std::string(1, c);
    std::snprintf(buf, sizeof buf, "<text x=\"%.0f\" y=\"18\">%s</text>\n", left, esc.c_str());
    s += buf;
    for (int k = 0; k <= 4; ++k) {  // y grid
        const double v = y_max * k / 4, y = y_of(v);
        std::snprintf(buf, sizeof buf,
                      "<line x1=\"%.1f\" y1=\"%.1f\" x2=\"%.1f\" y2=\"%.1f\" stroke=\"#ddd\"/>"
                      "<text x=\"%.1f\" y=\"%.1f\" text-anchor=\"end\">%.2f&#176;</text>\n",
                      left, y, w - right, y, left - 4, y + 4, v);
        s += buf;
    }
    for (int k = 0; k <= 5; ++k) {  // x labels
        const double t = t_end * k / 5, x = left + (w - left - right) * k / 5;
        std::snprintf(buf, sizeof buf,
                      "<text x=\"%.1f\" y=\"%.1f\" text-anchor=\"middle\">%.1f s</text>\n", x,
                      h - bottom + 16, t);
        s += buf;
    }
    auto series = [&](const std::vector<double>& v, const char* colour, const char* name, int row) {
        s += "<polyline fill=\"none\" stroke-width=\"1\" stroke=\"";
        s += colour;
        s += "\" points=\"";
        for (size_t i = 0; i < v.size(); ++i) {
            std::snprintf(buf, sizeof buf, "%.1f,%.1f ", x_of(e.time_ns[i]), y_of(v[i]));
            s += buf;
        }
        s += "\"/>\n";
        std::snprintf(buf, sizeof buf, "<text x=\"%.0f\" y=\"%d\" fill=\"%s\">%s</text>\n",
                      w - right - 200, int(top) + 14 * row, colour, name);
        s += buf;
    };
    series(e.error_deg, "black", "error (deg)", 1);
    series(e.tilt_deg, "#1f77b4", "tilt error (deg)", 2);
    series(e.heading_deg, "#d62728", "heading error (deg)", 3);
    s += "</svg>\n";
    return s;
}

// The warning for a fitted time offset at the edge of its search range (both in ms).
std::string offset_at_limit_warning(double offset_ms, double range_ms) {
    char b[200];
    std::snprintf(b, sizeof b,
                  "the fitted time offset %.3f ms is at the edge of the search range (+-%.0f ms; "
                  "--max-time-offset widens it)",
                  offset_ms, range_ms);
    return b;
}

// Time bases (the traces' `time_base` comments): traces whose time 0 differ pair unrelated
// instants, so they are refused (false: the error is set); a trace without one cannot be checked
// (a note).
bool check_time_bases(const EvalArgs& args, const Trace& ref, const Trace& est) {
    const auto ref_base = trace_time_base(ref), est_base = trace_time_base(est);
    if (ref_base && est_base && *ref_base != *est_base) {
        errors.fail("--reference " + args.reference + " is on the time base \"" + *ref_base +
                    "\" and --estimate " + args.estimate + " on \"" + *est_base +
                    "\": their times do not share a zero, so comparing them would pair "
                    "unrelated instants (record both from the same input: `record "
                    "--backend rec` writes the estimate and --reference-out on the "
                    "recording's TIME)");
        return false;
    }
    if (!ref_base || !est_base)
        errors.note(std::string(!ref_base ? "--reference " + args.reference
                                          : "--estimate " + args.estimate) +
                    " has no time_base comment: that the two traces share a timeline is assumed, "
                    "not checked");
    return true;
}

// The warnings of the reference's glitch check.
void warn_reference_glitches(const EvalArgs& args, const ReferenceGlitches& g) {
    if (g.steps > 0) {
        char b[600];
        std::snprintf(b, sizeof b,
                      "--reference %s: %zu step(s) the estimate's gyro does not see (threshold "
                      "%.2f deg a step; the worst %.2f deg at %.3f s: the reference turns %.0f "
                      "deg/s, the estimate %.1f deg/s); %zu excursion(s) the reference returns "
                      "from: %zu reference samples left out",
                      args.reference.c_str(), g.steps, g.threshold_deg, g.worst_step_deg,
                      ns_to_s(g.worst_at_ns), g.worst_reference_rate_deg_s,
                      g.worst_estimate_rate_deg_s, g.excursions, g.samples_left_out);
        errors.warning(b);
    }
    if (g.unreturned_steps > 0) {
        char b[400];
        std::snprintf(b, sizeof b,
                      "--reference %s: %zu step(s) the reference does not come back from within "
                      "%.1f s (the first at %.3f s): its alignment changes there and nothing is "
                      "left out; evaluate the windows either side (--start, --duration)",
                      args.reference.c_str(), g.unreturned_steps,
                      args.options.glitch_max_excursion_s, ns_to_s(g.unreturned_at_ns.front()));
        errors.warning(b);
    }
}

// Both traces with positions: the position error on the orientation fit's samples, offset and
// world rotation, a constant translation and lever arm fitted (position_eval.hpp), into the report;
// returns the lines to print. Neither: nothing. One only: a note.
std::string evaluate_positions(const EvalArgs& args, const Trace& ref, const Trace& est,
                               const OrientationEval& e, nlohmann::json* report) {
    const bool ref_p = !ref.samples.empty() && ref.samples.front().position.has_value();
    const bool est_p = !est.samples.empty() && est.samples.front().position.has_value();
    char b[600];
    if (!ref_p || !est_p) {
        if (ref_p == est_p) return {};
        std::snprintf(b, sizeof b, "  position: not compared (%s has no positions)\n",
                      ref_p ? args.estimate.c_str() : args.reference.c_str());
        return b;
    }
    PositionEvalOptions po;
    po.fit_time_offset = args.options.fit_time_offset;
    auto p = evaluate_position(ref, est, e, po);
    if (!p) {
        errors.warning("position not compared: " + p.error().message);
        return {};
    }
    const double rot_deg =
        2.0 * std::acos(std::min(1.0, std::abs(p->world_rotation.w))) * 180.0 / 3.14159265358979;
    std::snprintf(b, sizeof b,
                  "  %-20s %8s %8s %8s\n  %-20s %8.2f %8.2f %8.2f\n  position alignment "
                  "(fitted): world %.2f deg and (%.1f %.1f %.1f) mm, lever arm (%.1f %.1f %.1f) "
                  "mm; time offset %.3f ms (%s)\n",
                  "error (mm)", "p50", "p90", "max", "position", p->p50_mm, p->p90_mm, p->max_mm,
                  rot_deg, p->world_offset.x * 1e3, p->world_offset.y * 1e3,
                  p->world_offset.z * 1e3, p->lever_arm.x * 1e3, p->lever_arm.y * 1e3,
                  p->lever_arm.z * 1e3, double(p->time_offset_ns) * 1e-6,
                  p->time_offset_fitted ? "fitted to the positions, +-50 ms" : "the orientation's");
    auto r3 = [](const glm::dvec3& v) {
        return nlohmann::json::array({std::round(v.x * 1e6) / 1e6, std::round(v.y * 1e6) / 1e6,
                                      std::round(v.z * 1e6) / 1e6});
    };
    (*report)["summary"]["position_error_mm"] = {
        {"p50", std::round(p->p50_mm * 1e3) / 1e3},
        {"p90", std::round(p->p90_mm * 1e3) / 1e3},
        {"max", std::round(p->max_mm * 1e3) / 1e3},
        {"samples", p->samples},
        {"time_offset_ms", std::round(double(p->time_offset_ns) * 1e-3) / 1e3}};
    (*report)["alignment"]["position_offset_m"] = r3(p->world_offset);
    (*report)["alignment"]["lever_arm_m"] = r3(p->lever_arm);
    (*report)["alignment"]["position_world_wxyz"] = {p->world_rotation.w, p->world_rotation.x,
                                                     p->world_rotation.y, p->world_rotation.z};
    return b;
}

// --imu-only FILE: that trace's orientation against the estimate's (a light + IMU one: the
// reference the orientation fusion is judged against) over the same window, W and B fitted, the
// time offset 0 (one recording, one timeline); into the report; returns the lines to print. An
// error is a failure naming the file (the caller stops).
std::string compare_imu_only(const EvalArgs& args, const Trace& est, const OrientationEval& e,
                             nlohmann::json* report, bool* ok) {
    *ok = true;
    if (args.imu_only.empty()) return {};
    auto imu = read_trace_csv(args.imu_only);
    if (!imu) {
        errors.fail("--imu-only " + imu.error().message);
        *ok = false;
        return {};
    }
    const auto a = trace_time_base(est), b = trace_time_base(*imu);
    if (a && b && *a != *b) {
        errors.fail("--imu-only " + args.imu_only + " is on the time base \"" + *b +
                    "\" and --estimate " + args.estimate + " on \"" + *a + "\"");
        *ok = false;
        return {};
    }
    OrientationEvalOptions o;
    o.start_s = std::max(0.0, ns_to_s(e.window_start_ns - est.start_ns()));
    o.duration_s = std::max(1e-9, ns_to_s(e.window_end_ns - e.window_start_ns));
    auto r = evaluate_orientation(est, *imu, o);
    if (!r) {
        errors.fail("--imu-only " + args.imu_only + ": " + r.error().message);
        *ok = false;
        return {};
    }
    (*report)["summary"]["imu_only_vs_estimate"] = {
        {"file", args.imu_only},
        {"error_deg", percentiles(r->error)},
        {"tilt_error_deg", percentiles(r->tilt)},
        {"heading_error_deg", percentiles(r->heading)},
        {"samples", r->samples},
        {"glitches_left_out", r->glitches.samples_left_out}};
    char b2[700];
    std::snprintf(b2, sizeof b2,
                  "  IMU-only %s against the estimate's orientation (%zu samples, %.3f to %.3f s; "
                  "%zu of the estimate's samples left out as steps its gyro does not see):\n"
                  "  %-20s %8.3f %8.3f %8.3f\n  %-20s %8.3f %8.3f %8.3f\n  %-20s %8.3f %8.3f "
                  "%8.3f\n",
                  args.imu_only.c_str(), r->samples, ns_to_s(r->time_ns.front()),
                  ns_to_s(r->time_ns.back()), r->glitches.samples_left_out, "orientation",
                  r->error.p50, r->error.p95, r->error.max, "tilt", r->tilt.p50, r->tilt.p95,
                  r->tilt.max, "heading", r->heading.p50, r->heading.p95, r->heading.max);
    return b2;
}

void run_eval(EvalArgs args) {
    if (args.time_offset == "auto") {
        args.options.fit_time_offset = true;
    } else {
        char* end = nullptr;
        const double ms = std::strtod(args.time_offset.c_str(), &end);
        if (args.time_offset.empty() || *end != '\0' || !std::isfinite(ms))
            return errors.usage("--time-offset \"" + args.time_offset +
                                "\" is neither auto nor milliseconds");
        args.options.time_offset_s = ms * 1e-3;
    }
    if (!errors.check_outputs({{"--report", args.report}, {"--plot", args.plot}})) return;
    auto ref = read_trace_csv(args.reference);
    if (!ref) return errors.fail("--reference " + ref.error().message);
    auto est = read_trace_csv(args.estimate);
    if (!est) return errors.fail("--estimate " + est.error().message);
    if (!check_time_bases(args, *ref, *est)) return;
    auto e = evaluate_orientation(*ref, *est, args.options);
    if (!e) return errors.fail(e.error().message);
    const ReferenceGlitches& g = e->glitches;
    warn_reference_glitches(args, g);
    // The same alignment and offset, the reference samples in the disturbed intervals left out.
    const Saturation sat = saturation_of(*est);
    std::vector<double> err_ex, tilt_ex, heading_ex;
    for (size_t i = 0; i < e->samples; ++i) {
        const int64_t t = e->time_ns[i] - e->time_offset_ns;
        bool disturbed = false;
        for (const auto& [a, b] : sat.intervals) disturbed |= t >= a && t <= b;
        if (disturbed) continue;
        err_ex.push_back(e->error_deg[i]);
        tilt_ex.push_back(e->tilt_deg[i]);
        heading_ex.push_back(e->heading_deg[i]);
    }
    nlohmann::json report = {
        {"reference", args.reference},
        {"estimate", args.estimate},
        {"window_s", {{"start", ns_to_s(e->window_start_ns)}, {"end", ns_to_s(e->window_end_ns)}}},
        {"alignment",
         {{"world_wxyz", quat_wxyz(e->world_alignment)},
          {"body_wxyz", quat_wxyz(e->body_alignment)}}},
        {"summary",
         {{"error_deg", percentiles(e->error)},
          {"tilt_error_deg", percentiles(e->tilt)},
          {"heading_error_deg", percentiles(e->heading)},
          {"samples", e->samples},
          {"time_offset_ms", std::round(double(e->time_offset_ns) * 1e-3) / 1e3},
          {"time_offset_fitted", args.options.fit_time_offset && e->time_offset_observable}}}};
    if (!sat.intervals.empty())
        report["summary"]["excluding_saturation"] = {
            {"error_deg", percentiles(error_percentiles(err_ex))},
            {"tilt_error_deg", percentiles(error_percentiles(tilt_ex))},
            {"heading_error_deg", percentiles(error_percentiles(heading_ex))},
            {"samples", err_ex.size()},
            {"excluded_samples", e->samples - err_ex.size()},
            {"saturated_imu_samples", sat.samples},
            {"intervals", sat.intervals.size()}};
    report["summary"]["reference_glitches"] = {{"steps", g.steps},
                                               {"excursions", g.excursions},
                                               {"samples_left_out", g.samples_left_out},
                                               {"unreturned_steps", g.unreturned_steps},
                                               {"threshold_deg", g.threshold_deg},
                                               {"worst_step_deg", g.worst_step_deg}};
    if (args.options.fit_time_offset) {
        report["summary"]["time_offset_observable"] = e->time_offset_observable;
        report["summary"]["time_offset_sigma_ms"] = std::round(e->time_offset_sigma_ms * 1e3) / 1e3;
        report["summary"]["reference_rate_rms_deg_s"] =
            std::round(e->reference_rate_rms_deg_s * 1e3) / 1e3;
    }
    if (args.options.fit_time_offset && !e->time_offset_observable) {
        char b[500];
        std::snprintf(b, sizeof b,
                      "not enough motion to observe a time offset: over +-%.0f ms the fit's "
                      "error hardly changes (the reference turns %.2f deg/s rms over 50 ms; the "
                      "offset is known to about %.0f ms only); the search's %.3f ms is noise and "
                      "is not used (offset %.3f ms); a wider search cannot help: give "
                      "--time-offset MS, or a window with motion",
                      args.options.max_time_offset_s * 1e3, e->reference_rate_rms_deg_s,
                      e->time_offset_sigma_ms, e->unobservable_fit_ms,
                      double(e->time_offset_ns) * 1e-6);
        errors.warning(b);
    } else if (e->time_offset_at_range_limit) {
        errors.warning(offset_at_limit_warning(double(e->time_offset_ns) * 1e-6,
                                               args.options.max_time_offset_s * 1e3));
    }
    const std::string position_lines = evaluate_positions(args, *ref, *est, *e, &report);
    bool imu_ok = true;
    const std::string imu_lines = compare_imu_only(args, *est, *e, &report, &imu_ok);
    if (!imu_ok) return;
    if (!args.report.empty()) {
        Status st = write_file_atomically(args.report, report.dump(2) + "\n");
        if (!st.ok()) return errors.fail(st.error().message);
    }
    if (!args.plot.empty()) {
        Status st = write_file_atomically(
            args.plot,
            error_plot_svg(*e, "orientation error of " + args.estimate + " vs " + args.reference));
        if (!st.ok()) return errors.fail(st.error().message);
    }
    std::printf("%s vs %s: %zu reference samples, %.3f to %.3f s\n", args.estimate.c_str(),
                args.reference.c_str(), e->samples, ns_to_s(e->time_ns.front()),
                ns_to_s(e->time_ns.back()));
    std::printf("  %-20s %8s %8s %8s\n", "error (deg)", "p50", "p95", "max");
    auto row = [](const char* name, const ErrorPercentiles& p) {
        std::printf("  %-20s %8.3f %8.3f %8.3f\n", name, p.p50, p.p95, p.max);
    };
    row("orientation", e->error);
    row("tilt", e->tilt);
    row("heading", e->heading);
    if (!sat.intervals.empty()) {
        std::printf(
            "  without the %zu interval(s) disturbed by %llu saturated IMU samples (%zu "
            "reference samples left out, %zu kept):\n",
            sat.intervals.size(), static_cast<unsigned long long>(sat.samples),
            e->samples - err_ex.size(), err_ex.size());
        row("orientation", error_percentiles(err_ex));
        row("tilt", error_percentiles(tilt_ex));
        row("heading", error_percentiles(heading_ex));
    }
    std::fputs(position_lines.c_str(), stdout);
    std::fputs(imu_lines.c_str(), stdout);
    std::printf("  time offset: %.3f ms (%s; estimate time + offset = reference time)\n",
                double(e->time_offset_ns) * 1e-6,
                !args.options.fit_time_offset ? "given"
                : e->time_offset_observable   ? "fitted"
                                              : "not observable: not fitted");
    if (g.steps > 0)
        std::printf("  reference glitches: %zu steps, %zu excursions, %zu samples left out\n",
                    g.steps, g.excursions, g.samples_left_out);
    auto angle = [](const glm::dquat& q) {
        return 2.0 * std::acos(std::min(1.0, std::abs(q.w))) * 180.0 / 3.14159265358979323846;
    };
    std::printf("  alignment: world %.2f deg, body %.2f deg (fitted over the window)\n",
                angle(e->world_alignment), angle(e->body_alignment));
    if (!args.report.empty()) std::printf("  report %s\n", args.report.c_str());
    if (!args.plot.empty()) std::printf("  plot %s\n", args.plot.c_str());
}

void add_tracking_command(CLI::App& app) {
    CLI::App* tracking = app.add_subcommand(
        "tracking", "Evaluate tracking against a reference; place the base stations");
    tracking->require_subcommand(1);
    auto args = std::make_shared<EvalArgs>();
    CLI::App* eval = tracking->add_subcommand(
        "eval",
        "Orientation error (and position error, when both traces have positions) of an "
        "estimated trace against a reference trace, after fitting the constant world and body "
        "rotations (and a translation and lever arm) between them");
    eval->add_option("--reference", args->reference, "Reference trace CSV (e.g. lighthouse poses)")
        ->required();
    eval->add_option("--estimate", args->estimate, "Estimated trace CSV (e.g. fused IMU)")
        ->required();
    eval->add_option("--report", args->report, "JSON report to write");
    eval->add_option("--imu-only", args->imu_only,
                     "An IMU-only trace of the same recording (record without a light path): its "
                     "orientation against the estimate's (a light + IMU trace) over the window");
    eval->add_option("--plot", args->plot, "SVG plot of the error against time to write");
    eval->add_option("--start", args->options.start_s,
                     "Window start, seconds after the reference's first sample")
        ->check(CLI::NonNegativeNumber)
        ->capture_default_str();
    eval->add_option("--duration", args->options.duration_s, "Window length in seconds (0: all)")
        ->check(CLI::NonNegativeNumber)
        ->capture_default_str();
    eval->add_option("--time-offset", args->time_offset,
                     "Estimate time + offset = reference time: milliseconds, or auto to fit it "
                     "with the rotations")
        ->capture_default_str();
    eval->add_option("--max-time-offset", args->options.max_time_offset_s,
                     "Search range of --time-offset auto, +- seconds")
        ->check(CLI::PositiveNumber)
        ->capture_default_str();
    eval->add_flag(
        "--keep-reference-glitches",
        [args](int64_t) { args->options.leave_out_reference_glitches = false; },
        "Keep the reference's excursions the estimate's gyro does not see (left out by default)");
    eval->callback([args] { run_eval(*args); });
    add_tracking_place_command(*tracking);
}

const CommandRegistration reg{57, add_tracking_command};

}  // namespace
}  // namespace hmdnode::tool
