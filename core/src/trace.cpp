// The project's tracker trace CSV (docs/trace-format.md): reader, writer, interpolation, figures.
// Reading is one pass over the lines, O(samples) time, the samples as the only large memory.
#include "hmdnode/core/trace.hpp"

#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <cstdio>

#include "hmdnode/core/atomic_file.hpp"
#include "hmdnode/core/percentile.hpp"
#include "hmdnode/core/time.hpp"
#include "trace_text.hpp"

namespace hmdnode {
namespace {

using trace_text::in_quotes;

// v1: head poses; v2 adds the optional gaze group. The writer writes v2 only when there is gaze,
// so a trace without it stays readable by a v1 reader.
constexpr std::string_view kVersionComment = "hmdnode trace v1";
constexpr std::string_view kVersion2Comment = "hmdnode trace v2";
constexpr std::string_view kVersionPrefix = "hmdnode trace v";
constexpr double kMinNorm = 0.9;
constexpr double kMaxNorm = 1.1;
// note: norms this close to 1 are left as they are so that write -> read is bit-exact.
constexpr double kNormTolerance = 1e-12;

// The columns of the format, in the order the writer writes them.
enum Col : int {
    kTime,
    kQw,
    kQx,
    kQy,
    kQz,
    kPx,
    kPy,
    kPz,
    kGx,
    kGy,
    kGz,
    kAx,
    kAy,
    kAz,
    kEx,
    kEy,
    kEz,
    kEc,
    kColCount
};
constexpr std::array<std::string_view, kColCount> kColNames = {
    "time_ns", "qw", "qx", "qy", "qz", "px",     "py",     "pz",     "gx",
    "gy",      "gz", "ax", "ay", "az", "gaze_x", "gaze_y", "gaze_z", "gaze_conf"};
struct Group {
    int first;
    bool required;
};
constexpr std::array<Group, 5> kGroups = {
    {{kQw, true}, {kPx, false}, {kGx, false}, {kAx, false}, {kEx, false}}};
constexpr int group_size(int first) {
    return first == kQw || first == kEx ? 4 : 3;
}

std::string known_columns() {
    std::string s;
    for (auto n : kColNames) trace_text::append_item(s, n, ",");
    return s;
}

using trace_text::where;

std::string column_ref(size_t index, std::string_view name) {
    return "column " + std::to_string(index + 1) + " '" + std::string(name) + "': ";
}

// The header: for each format column its field index, or -1.
struct Header {
    std::array<int, kColCount> field{};
    std::vector<std::string> names;  // as written, by field index
    bool has(int col) const { return field[col] >= 0; }
};

Result<Header> parse_header(std::string_view text, const std::string& source, size_t line) {
    Header h;
    h.field.fill(-1);
    std::string_view rest = text;
    while (true) {
        size_t comma = rest.find(',');
        h.names.emplace_back(trace_text::trim(rest.substr(0, comma)));
        if (comma == std::string_view::npos) break;
        rest.remove_prefix(comma + 1);
    }
    std::vector<std::string> unknown;
    for (size_t i = 0; i < h.names.size(); ++i) {
        const std::string& name = h.names[i];
        if (name.empty())
            return make_error(where(source, line) + "column " + std::to_string(i + 1) +
                              ": empty column name");
        auto it = std::find(kColNames.begin(), kColNames.end(), name);
        if (it == kColNames.end()) {
            unknown.push_back(name);
            continue;
        }
        int col = int(it - kColNames.begin());
        if (h.field[col] >= 0)
            return make_error(where(source, line) + column_ref(i, name) + "duplicate column");
        h.field[col] = int(i);
    }
    if (!unknown.empty()) {
        std::string list;
        for (auto& u : unknown) trace_text::append_item(list, in_quotes(u), ", ");
        return make_error(where(source, line) + "unknown column" +
                          (unknown.size() > 1 ? "s " : " ") + list + " (the format has " +
                          known_columns() + "; import other tables with `hmdnode trace import`)");
    }
    if (!h.has(kTime))
        return make_error(where(source, line) + "header lacks the required column 'time_ns'");
    for (const Group& g : kGroups) {
        std::string missing, present;
        for (int c = g.first; c < g.first + group_size(g.first); ++c) {
            std::string& list = h.has(c) ? present : missing;
            trace_text::append_item(list, kColNames[c], ",");
        }
        if (missing.empty()) continue;
        if (g.required)
            return make_error(where(source, line) + "header lacks the required column" +
                              (missing.find(',') != std::string::npos ? "s " : " ") + missing);
        if (!present.empty())
            return make_error(where(source, line) + "incomplete column group: has " + present +
                              " but lacks " + missing);
    }
    return h;
}

}  // namespace

Result<Trace> parse_trace_csv(const std::string& text, const std::string& source) {
    Trace trace;
    std::optional<Header> header;
    size_t header_line = 0;
    std::optional<size_t> prev_line;
    for (const trace_text::Line& line : trace_text::split_lines(text)) {
        if (trace_text::is_blank(line.text)) continue;
        if (trace_text::is_comment(line.text)) {
            std::string_view c = trace_text::trim(line.text).substr(1);
            if (!c.empty() && c.front() == ' ') c.remove_prefix(1);
            std::string_view ct = trace_text::trim(c);
            if (ct == kVersionComment || ct == kVersion2Comment) continue;
            if (ct.substr(0, kVersionPrefix.size()) == kVersionPrefix)
                return make_error(where(source, line.number) + "unsupported trace version " +
                                  in_quotes(ct) + " (this reader knows v1 and v2)");
            // note: a stray '\r' (not part of a line ending) is dropped; the writer refuses it.
            std::string& kept = trace.comments.emplace_back(c);
            kept.erase(std::remove(kept.begin(), kept.end(), '\r'), kept.end());
            continue;
        }
        if (!header) {
            Result<Header> h = parse_header(line.text, source, line.number);
            if (!h.ok()) return h.error();
            header = std::move(*h);
            header_line = line.number;
            continue;
        }
        // A sample.
        const size_t n_fields = header->names.size();
        std::array<std::string_view, kColCount> fields{};
        std::vector<std::string_view> row;
        row.reserve(n_fields);
        std::string_view rest = line.text;
        while (true) {
            size_t comma = rest.find(',');
            row.push_back(rest.substr(0, comma));
            if (comma == std::string_view::npos) break;
            rest.remove_prefix(comma + 1);
        }
        if (row.size() != n_fields) {
            std::string what = row.size() < n_fields
                                   ? column_ref(row.size(), header->names[row.size()]) + "missing"
                                   : "column " + std::to_string(n_fields + 1) + ": extra field";
            return make_error(where(source, line.number) + "found " + std::to_string(row.size()) +
                              " fields, the header (line " + std::to_string(header_line) +
                              ") has " + std::to_string(n_fields) + "; " + what);
        }
        for (int c = 0; c < kColCount; ++c)
            if (header->has(c)) fields[c] = row[size_t(header->field[c])];

        auto err = [&](int col, const std::string& what) {
            size_t f = size_t(header->field[col]);
            return make_error(where(source, line.number) + column_ref(f, header->names[f]) + what);
        };
        TraceSample s;
        std::optional<int64_t> t = trace_text::parse_int64(fields[kTime]);
        if (!t) {
            if (trace_text::parse_double(fields[kTime]))
                return err(kTime, "time_ns must be an integer number of nanoseconds, found " +
                                      in_quotes(trace_text::trim(fields[kTime])));
            return err(kTime, "not an integer: " + in_quotes(trace_text::trim(fields[kTime])));
        }
        s.time_ns = *t;
        if (!trace.samples.empty()) {
            int64_t prev = trace.samples.back().time_ns;
            std::string prev_at = " (line " + std::to_string(*prev_line) + ")";
            if (s.time_ns < prev)
                return err(kTime, "time goes backwards: " + std::to_string(s.time_ns) + " after " +
                                      std::to_string(prev) + prev_at);
            if (s.time_ns == prev)
                return err(kTime, "repeated time " + std::to_string(s.time_ns) + " (also at line " +
                                      std::to_string(*prev_line) + ")");
        }
        double v[kColCount] = {};
        for (int c = kQw; c < kColCount; ++c) {
            if (!header->has(c)) continue;
            std::optional<double> d = trace_text::parse_double(fields[c]);
            if (!d) return err(c, "not a number: " + in_quotes(trace_text::trim(fields[c])));
            if (!std::isfinite(*d))
                return err(c, "not a finite number: " + in_quotes(trace_text::trim(fields[c])));
            v[c] = *d;
        }
        glm::dquat q(v[kQw], v[kQx], v[kQy], v[kQz]);
        double norm = std::sqrt(glm::dot(q, q));
        if (!(norm >= kMinNorm && norm <= kMaxNorm)) {
            std::string cols = "columns ";
            for (int c = kQw; c <= kQz; ++c)
                cols += std::to_string(header->field[c] + 1) + (c < kQz ? "," : " ");
            char buf[64];
            std::snprintf(buf, sizeof buf, "%.6g", norm);
            return make_error(where(source, line.number) + cols +
                              "(qw,qx,qy,qz): quaternion norm " + buf + " is outside [0.9, 1.1]" +
                              (norm == 0.0 ? " (a zero quaternion is no rotation)" : ""));
        }
        if (std::abs(norm - 1.0) > kNormTolerance) q /= norm;
        if (!trace.samples.empty()) q = same_hemisphere(q, trace.samples.back().orientation);
        s.orientation = q;
        if (header->has(kPx)) s.position = glm::dvec3(v[kPx], v[kPy], v[kPz]);
        if (header->has(kGx)) s.gyro = glm::dvec3(v[kGx], v[kGy], v[kGz]);
        if (header->has(kAx)) s.accel = glm::dvec3(v[kAx], v[kAy], v[kAz]);
        if (header->has(kEx)) {
            TraceGaze g{glm::dvec3(v[kEx], v[kEy], v[kEz]), v[kEc]};
            if (!(g.confidence >= 0.0 && g.confidence <= 1.0))
                return err(kEc, "gaze confidence " + in_quotes(trace_text::trim(fields[kEc])) +
                                    " is outside [0, 1]");
            // A gaze with confidence 0 is no gaze: its direction is kept as written, unused.
            const double gn = glm::length(g.direction);
            if (g.valid() && !(gn >= kMinNorm && gn <= kMaxNorm)) {
                char buf[64];
                std::snprintf(buf, sizeof buf, "%.6g", gn);
                return make_error(where(source, line.number) + "columns " +
                                  std::to_string(header->field[kEx] + 1) + "," +
                                  std::to_string(header->field[kEy] + 1) + "," +
                                  std::to_string(header->field[kEz] + 1) +
                                  " (gaze_x,gaze_y,gaze_z): gaze direction norm " + buf +
                                  " is outside [0.9, 1.1] (a valid gaze is a unit vector)");
            }
            if (g.valid() && std::abs(gn - 1.0) > kNormTolerance) g.direction /= gn;
            s.gaze = g;
        }
        trace.samples.push_back(s);
        prev_line = line.number;
    }
    if (!header) return make_error(source + ": no header line (expected " + known_columns() + ")");
    if (trace.samples.empty())
        return make_error(source + ":" + std::to_string(header_line) +
                          ": no samples after the header (an empty trace)");
    return trace;
}

Result<Trace> read_trace_csv(const std::filesystem::path& path) {
    Result<std::string> text = read_file(path);
    if (!text.ok()) return text.error();
    return parse_trace_csv(*text, path.string());
}

Result<std::string> format_trace_csv(const Trace& trace) {
    if (trace.samples.empty()) return make_error("trace has no samples");
    const TraceSample& first = trace.samples.front();
    const bool has_p = first.position.has_value();
    const bool has_g = first.gyro.has_value();
    const bool has_a = first.accel.has_value();
    const bool has_e = first.gaze.has_value();

    std::string out;
    out.reserve(64 + trace.samples.size() * (has_e ? 200 : 120));
    out += "# ";
    out += has_e ? kVersion2Comment : kVersionComment;
    out += '\n';
    for (const std::string& c : trace.comments) {
        if (c.find_first_of("\r\n") != std::string::npos)
            return make_error("trace comment " + in_quotes(c) + " contains a line break");
        if (trace_text::trim(c) == kVersionComment || trace_text::trim(c) == kVersion2Comment)
            continue;
        out += "# ";
        out += c;
        out += '\n';
    }
    out += "time_ns,qw,qx,qy,qz";
    if (has_p) out += ",px,py,pz";
    if (has_g) out += ",gx,gy,gz";
    if (has_a) out += ",ax,ay,az";
    if (has_e) out += ",gaze_x,gaze_y,gaze_z,gaze_conf";
    out += '\n';

    auto put3 = [&](const glm::dvec3& v) {
        for (int i = 0; i < 3; ++i) {
            out += ',';
            trace_text::append_double(out, v[i]);
        }
    };
    auto finite3 = [](const glm::dvec3& v) {
        return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
    };
    for (size_t i = 0; i < trace.samples.size(); ++i) {
        const TraceSample& s = trace.samples[i];
        const std::string at =
            "sample " + std::to_string(i) + " (time_ns " + std::to_string(s.time_ns) + "): ";
        if (i > 0 && s.time_ns <= trace.samples[i - 1].time_ns)
            return make_error(at + "time is not after the previous sample's " +
                              std::to_string(trace.samples[i - 1].time_ns));
        if (s.position.has_value() != has_p || s.gyro.has_value() != has_g ||
            s.accel.has_value() != has_a || s.gaze.has_value() != has_e)
            return make_error(at + "has a different set of position/gyro/accel/gaze than sample 0");
        const glm::dquat& q = s.orientation;
        double norm = std::sqrt(glm::dot(q, q));
        if (!(norm >= kMinNorm && norm <= kMaxNorm))
            return make_error(at + "quaternion norm outside [0.9, 1.1] (or not finite)");
        if ((has_p && !finite3(*s.position)) || (has_g && !finite3(*s.gyro)) ||
            (has_a && !finite3(*s.accel)))
            return make_error(at + "a value is not finite");
        if (has_e) {
            const TraceGaze& g = *s.gaze;
            if (!finite3(g.direction) || !(g.confidence >= 0.0 && g.confidence <= 1.0))
                return make_error(at + "gaze not finite or confidence outside [0, 1]");
            const double gn = glm::length(g.direction);
            if (g.valid() && !(gn >= kMinNorm && gn <= kMaxNorm))
                return make_error(at + "valid gaze direction norm outside [0.9, 1.1]");
        }
        trace_text::append_int64(out, s.time_ns);
        for (double c : {q.w, q.x, q.y, q.z}) {
            out += ',';
            trace_text::append_double(out, c);
        }
        if (has_p) put3(*s.position);
        if (has_g) put3(*s.gyro);
        if (has_a) put3(*s.accel);
        if (has_e) {
            put3(s.gaze->direction);
            out += ',';
            trace_text::append_double(out, s.gaze->confidence);
        }
        out += '\n';
    }
    return out;
}

Status write_trace_csv(const Trace& trace, const std::filesystem::path& path) {
    Result<std::string> text = format_trace_csv(trace);
    if (!text.ok()) return make_error(path.string() + ": " + text.error().message);
    return write_file_atomically(path, *text);
}

Pose Trace::pose_at(int64_t t_ns) const {
    assert(!samples.empty());
    Pose pose;
    pose.time_ns = t_ns;
    if (samples.empty()) return pose;
    const bool has_p = samples.front().position.has_value();

    auto held = [&](const TraceSample& s) {
        pose.orientation = s.orientation;
        if (s.position) pose.position = *s.position;
        pose.angular_velocity = glm::dvec3(0.0);
        if (has_p) pose.linear_velocity = glm::dvec3(0.0);
        return pose;
    };
    if (t_ns < samples.front().time_ns || samples.size() == 1) return held(samples.front());
    if (t_ns > samples.back().time_ns) return held(samples.back());

    // Segment [i, i+1] with s_i.time <= t <= s_{i+1}.time.
    auto ub = std::upper_bound(samples.begin(), samples.end(), t_ns,
                               [](int64_t t, const TraceSample& s) { return t < s.time_ns; });
    size_t i = size_t(ub - samples.begin()) - 1;
    if (i + 1 == samples.size()) --i;  // t == end: the last segment
    const TraceSample& a = samples[i];
    const TraceSample& b = samples[i + 1];
    const double dt_s = ns_to_s(b.time_ns - a.time_ns);
    const double f = double(t_ns - a.time_ns) / double(b.time_ns - a.time_ns);

    // note: at a sample's own time the sample itself comes back, bit for bit.
    if (t_ns == a.time_ns) {
        pose.orientation = a.orientation;
        if (a.position) pose.position = *a.position;
    } else if (t_ns == b.time_ns) {
        pose.orientation = b.orientation;
        if (b.position) pose.position = *b.position;
    } else {
        pose.orientation = slerp_shortest(a.orientation, b.orientation, f);
        if (a.position && b.position) pose.position = glm::mix(*a.position, *b.position, f);
    }
    if (a.gyro && b.gyro)
        pose.angular_velocity = pose.orientation * glm::mix(*a.gyro, *b.gyro, f);
    else
        pose.angular_velocity = angular_velocity(a.orientation, b.orientation, dt_s);
    if (a.position && b.position) pose.linear_velocity = (*b.position - *a.position) / dt_s;
    return pose;
}

TraceStats compute_trace_stats(const Trace& trace) {
    TraceStats st;
    st.samples = trace.samples.size();
    if (trace.samples.empty()) return st;
    st.duration_ns = trace.end_ns() - trace.start_ns();
    st.has_position = trace.samples.front().position.has_value();
    st.has_imu = trace.samples.front().gyro.has_value() || trace.samples.front().accel.has_value();
    st.has_gaze = trace.samples.front().gaze.has_value();
    if (st.has_gaze) {
        std::vector<double> ecc;
        for (const TraceSample& s : trace.samples)
            if (s.gaze && s.gaze->valid())
                ecc.push_back(rad_to_deg(std::acos(
                    std::clamp(glm::dot(glm::normalize(s.gaze->direction), glm::dvec3(0, 0, -1)),
                               -1.0, 1.0))));
        st.gaze_valid_fraction = double(ecc.size()) / double(trace.samples.size());
        if (!ecc.empty()) {
            std::sort(ecc.begin(), ecc.end());
            st.gaze_eccentricity_p50_deg = percentile_sorted(ecc, 0.5);
            st.gaze_eccentricity_p90_deg = percentile_sorted(ecc, 0.9);
            st.gaze_within_20deg_fraction =
                double(std::upper_bound(ecc.begin(), ecc.end(), 20.0) - ecc.begin()) /
                double(ecc.size());
        }
    }
    if (trace.samples.size() < 2) return st;
    std::vector<int64_t> intervals;
    intervals.reserve(trace.samples.size() - 1);
    for (size_t i = 1; i < trace.samples.size(); ++i) {
        const TraceSample& a = trace.samples[i - 1];
        const TraceSample& b = trace.samples[i];
        int64_t dt = b.time_ns - a.time_ns;
        intervals.push_back(dt);
        if (dt > st.longest_gap_ns) {
            st.longest_gap_ns = dt;
            st.longest_gap_start_ns = a.time_ns;
        }
        if (dt > 100 * kNsPerMs) ++st.gaps_over_100ms;
        if (dt > 0) {
            double speed = angle_between_deg(a.orientation, b.orientation) / ns_to_s(dt);
            if (speed > st.max_angular_speed_deg_s) {
                st.max_angular_speed_deg_s = speed;
                st.max_angular_speed_at_ns = a.time_ns;
            }
        }
    }
    st.median_interval_ns = percentile_in_place(intervals.begin(), intervals.end(), 0.5);
    if (st.median_interval_ns > 0) st.median_rate_hz = 1.0 / ns_to_s(st.median_interval_ns);
    return st;
}

}  // namespace hmdnode
