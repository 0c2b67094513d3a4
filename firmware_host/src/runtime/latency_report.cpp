// Per-vsync series, table, JSON report and SVG of `hmdnode latency` (latency_report.hpp). The
// vsync walk is summarize_presents' (replay.cpp) so that the plots show what the summary counts.
// Costs in the header; the SVG is built in one string (about 100 bytes per vsync and mode): the
// axes all modes share (latency_axes), then per mode a histogram panel and a timeline panel.
#include "hmdnode/firmware_host/latency_report.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <sstream>

#include <nlohmann/json.hpp>

#include "hmdnode/core/time.hpp"

namespace hmdnode {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Fewer digits in the long series: 1e-4 of a millisecond or degree is below anything measured.
nlohmann::json rounded(double v) {
    return std::isfinite(v) ? nlohmann::json(std::round(v * 1e4) / 1e4) : nlohmann::json();
}

const char* shown_name(VsyncShown s) {
    switch (s) {
        case VsyncShown::new_frame:
            return "new";
        case VsyncShown::rewarp:
            return "rewarp";
        case VsyncShown::repeat:
            return "repeat";
    }
    return "repeat";
}

std::string fmt(const char* f, double v) {
    if (!std::isfinite(v)) return "n/a";
    char b[64];
    std::snprintf(b, sizeof b, f, v);
    return b;
}

// XML text: & < > escaped.
std::string xml_escape(const std::string& s) {
    std::string o;
    for (char c : s) {
        if (c == '&')
            o += "&amp;";
        else if (c == '<')
            o += "&lt;";
        else if (c == '>')
            o += "&gt;";
        else if (c == '"')
            o += "&quot;";
        else
            o += c;
    }
    return o;
}

// A 1-2-5 step giving about `count` intervals over [0, range].
double nice_step(double range, int count) {
    if (!(range > 0.0)) return 1.0;
    const double raw = range / count, mag = std::pow(10.0, std::floor(std::log10(raw)));
    for (double m : {1.0, 2.0, 5.0, 10.0})
        if (raw <= m * mag) return m * mag;
    return 10.0 * mag;
}

}  // namespace

std::vector<LatencyMode> all_latency_modes() {
    return {{"none", false, false},
            {"predict", true, false},
            {"warp", false, true},
            {"predict+warp", true, true}};
}

Result<std::vector<LatencyMode>> parse_latency_modes(const std::string& list) {
    const std::vector<LatencyMode> all = all_latency_modes();
    if (list == "all") return all;
    std::vector<LatencyMode> out;
    std::stringstream ss(list);
    std::string name;
    while (std::getline(ss, name, ',')) {
        auto it = std::find_if(all.begin(), all.end(),
                               [&](const LatencyMode& m) { return m.name == name; });
        if (it == all.end())
            return make_error("--modes: unknown mode \"" + name +
                              "\" (all, or a list of none, predict, warp, predict+warp)");
        if (std::any_of(out.begin(), out.end(),
                        [&](const LatencyMode& m) { return m.name == name; }))
            return make_error("--modes: \"" + name + "\" given twice");
        out.push_back(*it);
    }
    if (out.empty() || (!list.empty() && list.back() == ','))
        return make_error(
            "--modes: give all, or a comma-separated list of none, predict, warp, "
            "predict+warp");
    return out;
}

Percentiles series_latency_ms(const std::vector<VsyncSample>& series) {
    std::vector<double> v;
    v.reserve(series.size());
    for (const VsyncSample& s : series) v.push_back(s.latency_ms);
    return percentiles(std::move(v));
}

Percentiles series_registration_error_deg(const std::vector<VsyncSample>& series) {
    std::vector<double> v;
    v.reserve(series.size());
    for (const VsyncSample& s : series) v.push_back(s.registration_error_deg);
    return percentiles(std::move(v));
}

std::string latency_table(const std::vector<LatencyModeResult>& results) {
    std::ostringstream out;
    char b[128];
    std::snprintf(b, sizeof b, "%-30s", "");
    out << b;
    for (const LatencyModeResult& r : results) {
        std::snprintf(b, sizeof b, "%14s", r.mode.name.c_str());
        out << b;
    }
    out << '\n';
    auto row = [&](const char* label, auto value) {
        std::snprintf(b, sizeof b, "%-30s", label);
        out << b;
        for (const LatencyModeResult& r : results) {
            std::snprintf(b, sizeof b, "%14s", value(r).c_str());
            out << b;
        }
        out << '\n';
    };
    auto pct_rows = [&](const char* what, const char* unit, const char* f,
                        Percentiles ReplaySummary::*field) {
        for (int i = 0; i < 4; ++i) {
            static const char* names[] = {"p50", "p95", "p99", "max"};
            std::string label = std::string(what) + " " + names[i] + " (" + unit + ")";
            row(label.c_str(), [&](const LatencyModeResult& r) {
                const Percentiles& p = r.summary.*field;
                return fmt(f, i == 0 ? p.p50 : i == 1 ? p.p95 : i == 2 ? p.p99 : p.max);
            });
        }
    };
    pct_rows("MTP", "ms", "%.2f", &ReplaySummary::latency_ms);
    pct_rows("registration error", "deg", "%.3f", &ReplaySummary::registration_error_deg);
    row("on time (% of vsyncs)",
        [](const LatencyModeResult& r) { return fmt("%.1f", 100.0 * r.summary.on_time_rate); });
    row("vsyncs", [](const LatencyModeResult& r) { return std::to_string(r.summary.vsyncs); });
    row("missed vsyncs",
        [](const LatencyModeResult& r) { return std::to_string(r.summary.missed_vsyncs); });
    row("late frames",
        [](const LatencyModeResult& r) { return std::to_string(r.summary.late_frames); });
    row("longest missed run (vsyncs)",
        [](const LatencyModeResult& r) { return std::to_string(r.summary.longest_late_run); });
    row("new frames / re-warps", [](const LatencyModeResult& r) {
        return std::to_string(r.summary.new_frames) + "/" + std::to_string(r.summary.rewarps);
    });
    row("warp p50 (ms)",
        [](const LatencyModeResult& r) { return fmt("%.2f", r.summary.warp_ms.p50); });
    row("warp p99 (ms)",
        [](const LatencyModeResult& r) { return fmt("%.2f", r.summary.warp_ms.p99); });
    row("render p50 (ms)",
        [](const LatencyModeResult& r) { return fmt("%.2f", r.summary.render_ms.p50); });
    row("MTP floor (ms)",
        [](const LatencyModeResult& r) { return fmt("%.2f", r.summary.mtp_floor_ms); });
    row("lens pass", [](const LatencyModeResult& r) { return r.summary.lens_pass; });
    row("full-resolution presents (%)", [](const LatencyModeResult& r) {
        const ReplaySummary& s = r.summary;
        return s.ladder.empty() || s.frames == 0
                   ? std::string("n/a")
                   : fmt("%.1f", 100.0 * double(s.ladder[0].presents) / double(s.frames));
    });
    row("render rate 1/1 presents (%)", [](const LatencyModeResult& r) {
        const ReplaySummary& s = r.summary;
        return s.presents_by_divisor.empty() || s.frames == 0
                   ? std::string("n/a")
                   : fmt("%.1f", 100.0 * double(s.presents_by_divisor[0]) / double(s.frames));
    });
    for (const LatencyModeResult& r : results)
        out << r.mode.name << ": " << lens_pass_summary(r.summary);
    return out.str();
}

nlohmann::json latency_report_json(const nlohmann::json& options, const std::string& renderer,
                                   const std::vector<LatencyModeResult>& results) {
    using nlohmann::json;
    json modes = json::array();
    for (const LatencyModeResult& r : results) {
        const ReplaySummary& s = r.summary;
        json summary = replay_summary_json(s);
        summary["on_time_vsyncs"] = r.on_time_vsyncs;
        json t_ms = json::array(), lat = json::array(), reg = json::array(), shown = json::array(),
             on_time = json::array();
        const int64_t v0 = r.series.empty() ? 0 : r.series.front().vsync_ns;
        for (const VsyncSample& v : r.series) {
            t_ms.push_back(rounded(ns_to_ms(v.vsync_ns - v0)));
            lat.push_back(rounded(v.latency_ms));
            reg.push_back(rounded(v.registration_error_deg));
            shown.push_back(shown_name(v.shown));
            on_time.push_back(v.on_time);
        }
        modes.push_back({{"name", r.mode.name},
                         {"prediction", r.mode.predict},
                         {"warp", r.mode.warp},
                         {"summary", summary},
                         {"series",
                          {{"vsync_period_ms", ns_to_ms(r.period_ns)},
                           {"t_ms", std::move(t_ms)},
                           {"latency_ms", std::move(lat)},
                           {"registration_error_deg", std::move(reg)},
                           {"shown", std::move(shown)},
                           {"on_time", std::move(on_time)}}}});
    }
    return {{"format", "hmdnode-latency-report/1"},
            {"options", options},
            {"renderer", renderer},
            {"modes", std::move(modes)}};
}

namespace {

// latency_svg's layout: a title line, then one row per mode: histogram (left), timeline (right).
constexpr double kSvgWidth = 1200, kRowH = 230, kTop = 56, kLeftX = 70, kHistW = 380, kTlX = 540,
                 kTlW = 620, kPlotH = 160;

// The axes every mode's row shares: the MTP bins and range, the histograms' percentage (the
// tallest bin of any mode), the error range and the time range.
struct LatencyAxes {
    double bin = 1.0;
    int bins = 1;
    double lat_axis = 1.0;
    double pct_step = 1.0, pct_axis = 1.0;
    double err_step = 1.0, err_axis = 1.0;
    double t_step = 1.0, t_axis = 1.0;
};

// One mode's MTP histogram: vsyncs per bin of `bin` ms (*total: the vsyncs with a latency).
std::vector<size_t> latency_histogram(const LatencyModeResult& r, double bin, int bins,
                                      size_t* total) {
    std::vector<size_t> counts(size_t(bins), 0);
    *total = 0;
    for (const VsyncSample& v : r.series) {
        if (!std::isfinite(v.latency_ms)) continue;
        counts[size_t(std::clamp(int(v.latency_ms / bin), 0, bins - 1))]++;
        ++*total;
    }
    return counts;
}

LatencyAxes latency_axes(const std::vector<LatencyModeResult>& results) {
    double lat_max = 0.0, err_max = 0.0, t_max = 0.0;
    for (const LatencyModeResult& r : results) {
        for (const VsyncSample& v : r.series) {
            if (std::isfinite(v.latency_ms)) lat_max = std::max(lat_max, v.latency_ms);
            if (std::isfinite(v.registration_error_deg))
                err_max = std::max(err_max, v.registration_error_deg);
        }
        if (!r.series.empty())
            t_max = std::max(t_max, ns_to_s(r.series.back().vsync_ns - r.series.front().vsync_ns));
    }
    LatencyAxes a;
    a.bin = nice_step(lat_max, 40);
    a.bins = std::max(1, int(std::ceil((lat_max + 1e-9) / a.bin)));
    a.lat_axis = a.bin * a.bins;
    double pct_max = 0.0;
    for (const LatencyModeResult& r : results) {
        size_t total = 0;
        for (size_t c : latency_histogram(r, a.bin, a.bins, &total))
            pct_max = std::max(pct_max, 100.0 * double(c) / double(std::max<size_t>(total, 1)));
    }
    a.pct_step = nice_step(pct_max, 4);
    a.pct_axis = std::max(a.pct_step, std::ceil(pct_max / a.pct_step - 1e-9) * a.pct_step);
    a.err_step = nice_step(err_max, 4);
    a.err_axis = std::max(a.err_step, std::ceil(err_max / a.err_step - 1e-9) * a.err_step);
    a.t_step = nice_step(t_max, 8);
    a.t_axis = std::max(a.t_step, std::ceil(t_max / a.t_step - 1e-9) * a.t_step);
    return a;
}

void svg_text(std::ostream& o, double x, double y, const std::string& s,
              const char* anchor = "middle", const char* extra = "") {
    o << "<text x=\"" << x << "\" y=\"" << y << "\" text-anchor=\"" << anchor << "\"" << extra
      << ">" << xml_escape(s) << "</text>\n";
}

void svg_line(std::ostream& o, double x0, double y0, double x1, double y1, const char* stroke) {
    o << "<line x1=\"" << x0 << "\" y1=\"" << y0 << "\" x2=\"" << x1 << "\" y2=\"" << y1
      << "\" stroke=\"" << stroke << "\"/>\n";
}

// An axis label: up to 6 decimals, no trailing zeros.
std::string axis_num(double v) {
    char b[32];
    std::snprintf(b, sizeof b, "%g", std::round(v * 1e6) / 1e6);
    return std::string(b);
}

// A mode's MTP histogram (% of vsyncs per bin) between the plot's top y0 and bottom y1, with
// its axes and the p50 and p99 marks.
void histogram_panel(std::ostream& o, const LatencyModeResult& r, const LatencyAxes& a, double y0,
                     double y1) {
    size_t total = 0;
    const std::vector<size_t> counts = latency_histogram(r, a.bin, a.bins, &total);
    for (int i = 0; i < a.bins; ++i) {
        if (counts[size_t(i)] == 0) continue;
        const double pct = 100.0 * double(counts[size_t(i)]) / double(total);
        const double h = kPlotH * pct / a.pct_axis, bw = kHistW / a.bins;
        o << "<rect x=\"" << kLeftX + bw * i << "\" y=\"" << y1 - h << "\" width=\""
          << std::max(bw - 1.0, 0.5) << "\" height=\"" << h << "\" fill=\"#4a7ebb\"><title>"
          << axis_num(a.bin * i) << "-" << axis_num(a.bin * (i + 1)) << " ms: " << counts[size_t(i)]
          << " vsyncs</title></rect>\n";
    }
    svg_line(o, kLeftX, y1, kLeftX + kHistW, y1, "black");
    svg_line(o, kLeftX, y0, kLeftX, y1, "black");
    const double lat_step = nice_step(a.lat_axis, 8);
    for (double v = 0.0; v <= a.lat_axis + 1e-9; v += lat_step) {
        const double x = kLeftX + kHistW * v / a.lat_axis;
        svg_line(o, x, y1, x, y1 + 4, "black");
        svg_text(o, x, y1 + 16, axis_num(v));
    }
    svg_text(o, kLeftX + kHistW / 2, y1 + 32,
             "MTP latency (ms), bins of " + axis_num(a.bin) + " ms");
    for (double v = 0.0; v <= a.pct_axis + 1e-9; v += a.pct_step) {
        const double y = y1 - kPlotH * v / a.pct_axis;
        svg_line(o, kLeftX - 4, y, kLeftX, y, "black");
        svg_text(o, kLeftX - 6, y + 4, axis_num(v), "end");
    }
    o << "<text transform=\"translate(" << kLeftX - 42 << ',' << (y0 + y1) / 2
      << ") rotate(-90)\" text-anchor=\"middle\">% of vsyncs</text>\n";
    const Percentiles& lp = r.summary.latency_ms;
    for (auto [q, name, colour] : {std::tuple{lp.p50, "p50", "#2a2"}, {lp.p99, "p99", "#c60"}}) {
        if (!std::isfinite(q)) continue;
        const double x = kLeftX + kHistW * std::min(q, a.lat_axis) / a.lat_axis;
        o << "<line x1=\"" << x << "\" y1=\"" << y0 << "\" x2=\"" << x << "\" y2=\"" << y1
          << "\" stroke=\"" << colour << "\" stroke-dasharray=\"4 3\"/>\n";
    }
    svg_text(o, kLeftX + kHistW, y0 - 3,
             "p50 " + fmt("%.1f", lp.p50) + " ms, p99 " + fmt("%.1f", lp.p99) + " ms", "end");
}

// A mode's registration error over time between the plot's top y0 and bottom y1, with its axes
// and the missed vsyncs as ticks.
void timeline_panel(std::ostream& o, const LatencyModeResult& r, const LatencyAxes& a, double y0,
                    double y1) {
    svg_line(o, kTlX, y1, kTlX + kTlW, y1, "black");
    svg_line(o, kTlX, y0, kTlX, y1, "black");
    for (double v = 0.0; v <= a.t_axis + 1e-9; v += a.t_step) {
        const double x = kTlX + kTlW * v / a.t_axis;
        svg_line(o, x, y1, x, y1 + 4, "black");
        svg_text(o, x, y1 + 16, axis_num(v));
    }
    svg_text(o, kTlX + kTlW / 2, y1 + 32, "time (s)");
    for (double v = 0.0; v <= a.err_axis + 1e-9; v += a.err_step) {
        const double y = y1 - kPlotH * v / a.err_axis;
        svg_line(o, kTlX - 4, y, kTlX, y, "black");
        if (v > 0) svg_line(o, kTlX, y, kTlX + kTlW, y, "#ddd");
        svg_text(o, kTlX - 6, y + 4, axis_num(v), "end");
    }
    o << "<text transform=\"translate(" << kTlX - 40 << ',' << (y0 + y1) / 2
      << ") rotate(-90)\" text-anchor=\"middle\">error (deg)</text>\n";
    if (!r.series.empty()) {
        const int64_t v0 = r.series.front().vsync_ns;
        o << "<path fill=\"none\" stroke=\"#1f3f7a\" stroke-width=\"1\" d=\"";
        bool pen = false;
        o.precision(2);
        for (const VsyncSample& v : r.series) {
            if (!std::isfinite(v.registration_error_deg)) {
                pen = false;
                continue;
            }
            const double x = kTlX + kTlW * ns_to_s(v.vsync_ns - v0) / a.t_axis;
            const double y = y1 - kPlotH * v.registration_error_deg / a.err_axis;
            o << (pen ? 'L' : 'M') << x << ',' << y << ' ';
            pen = true;
        }
        o << "\"/>\n";
        o << "<path stroke=\"#f39c12\" d=\"";
        for (const VsyncSample& v : r.series) {
            if (v.on_time) continue;
            const double x = kTlX + kTlW * ns_to_s(v.vsync_ns - v0) / a.t_axis;
            o << 'M' << x << ',' << y1 - 1 << " v-5 ";
        }
        o << "\"/>\n";
        o.precision(1);
    }
    const Percentiles& ep = r.summary.registration_error_deg;
    svg_text(o, kTlX + kTlW, y0 - 3,
             "p50 " + fmt("%.2f", ep.p50) + " deg, p99 " + fmt("%.2f", ep.p99) + " deg, on time " +
                 fmt("%.1f", 100.0 * r.summary.on_time_rate) + "% of " +
                 std::to_string(r.summary.vsyncs) + " vsyncs",
             "end");
}

}  // namespace

std::string latency_svg(const std::vector<LatencyModeResult>& results, const std::string& title,
                        const std::string& subtitle) {
    const double width = kSvgWidth, height = kTop + kRowH * double(results.size()) + 30;
    const LatencyAxes axes = latency_axes(results);

    std::ostringstream o;
    o.setf(std::ios::fixed);
    o.precision(1);
    o << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << width << "\" height=\"" << height
      << "\" viewBox=\"0 0 " << width << ' ' << height
      << "\" font-family=\"sans-serif\" font-size=\"12\">\n";
    o << "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
    o << "<text x=\"" << width / 2 << "\" y=\"20\" text-anchor=\"middle\" font-size=\"15\">"
      << xml_escape(title) << "</text>\n";
    o << "<text x=\"" << width / 2 << "\" y=\"38\" text-anchor=\"middle\" fill=\"#555\">"
      << xml_escape(subtitle)
      << "; left: motion-to-photon latency per displayed vsync; right: registration error at "
         "each vsync (orange ticks: missed vsyncs)</text>\n";
    for (size_t m = 0; m < results.size(); ++m) {
        const LatencyModeResult& r = results[m];
        const double y0 = kTop + kRowH * double(m) + 30, y1 = y0 + kPlotH;  // plot top, bottom
        svg_text(o, kLeftX - 60, y0 - 16,
                 r.mode.name + "  (prediction " + (r.mode.predict ? "on" : "off") + ", warp " +
                     (r.mode.warp ? "on" : "off") + ")",
                 "start", " font-weight=\"bold\" font-size=\"13\"");
        histogram_panel(o, r, axes, y0, y1);
        timeline_panel(o, r, axes, y0, y1);
    }
    o << "</svg>\n";
    return o.str();
}

}  // namespace hmdnode
