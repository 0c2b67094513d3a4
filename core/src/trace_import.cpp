// Importer of foreign head-tracker tables onto the trace format (docs/trace-format.md, section 2).
// One pass to find the separator and the first data row, one pass over the rows; O(rows) time, the
// samples as the only large memory. Every repair it makes is counted in TraceImportReport.
#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <optional>
#include <string_view>

#include "hmdnode/core/atomic_file.hpp"
#include "hmdnode/core/time.hpp"
#include "hmdnode/core/trace.hpp"
#include "trace_text.hpp"

namespace hmdnode {
namespace {

using trace_text::in_quotes;
using trace_text::Line;
using trace_text::trim;

constexpr int64_t kGapReportNs = 100 * kNsPerMs;
// Quaternions whose norm is off by more than this are counted as normalised.
constexpr double kNormCountTolerance = 1e-6;
// Plausible time for a head tracker: median interval within [10 us, 10 s], at most a day long.
constexpr int64_t kMinMedianIntervalNs = 10 * kNsPerUs;
constexpr int64_t kMaxMedianIntervalNs = 10 * kNsPerSecond;
constexpr int64_t kMaxDurationNs = 24 * 3600 * kNsPerSecond;
// Duplicate rows whose orientation differs by more than this (radians) count as conflicting.
constexpr double kConflictAngleRad = 1e-9;

std::string fmt(const char* format, double v) {
    char buf[64];
    std::snprintf(buf, sizeof buf, format, v);
    return buf;
}

std::string lower(std::string_view s) {
    std::string out(s);
    for (char& c : out) c = char(std::tolower(static_cast<unsigned char>(c)));
    return out;
}

std::string where(const std::string& source, size_t line) {
    return source + ":" + std::to_string(line) + ": ";
}

// --- Separators and fields ---------------------------------------------------------------------

struct Separator {
    char c = ',';
    bool whitespace = false;  // runs of spaces and tabs
    std::string name;
};

const std::array<Separator, 4> kAutoSeparators = {{{',', false, "comma"},
                                                   {'\t', false, "tab"},
                                                   {';', false, "semicolon"},
                                                   {' ', true, "whitespace"}}};

std::string_view unquote(std::string_view f) {
    f = trim(f);
    if (f.size() >= 2 && f.front() == '"' && f.back() == '"') f = trim(f.substr(1, f.size() - 2));
    return f;
}

void split_fields(std::string_view line, const Separator& sep, std::vector<std::string_view>& out) {
    out.clear();
    if (sep.whitespace) {
        size_t i = 0;
        while (true) {
            i = line.find_first_not_of(" \t", i);
            if (i == std::string_view::npos) break;
            size_t e = line.find_first_of(" \t", i);
            out.push_back(unquote(line.substr(i, e == std::string_view::npos ? e : e - i)));
            if (e == std::string_view::npos) break;
            i = e;
        }
        return;
    }
    while (true) {
        size_t e = line.find(sep.c);
        out.push_back(unquote(line.substr(0, e)));
        if (e == std::string_view::npos) break;
        line.remove_prefix(e + 1);
    }
}

// A header line without its leading '#', if any ("#timestamp,qw,..." names columns too).
std::string_view strip_hash(std::string_view line) {
    line = trim(line);
    if (!line.empty() && line.front() == '#') line.remove_prefix(1);
    return line;
}

bool all_numeric(const std::vector<std::string_view>& fields) {
    for (std::string_view f : fields)
        if (!trace_text::parse_double(f)) return false;
    return true;
}

// Index (into lines) of the first row at or after `from` with >= 2 fields, all numeric; blank and
// '#' lines are passed over.
std::optional<size_t> first_numeric_row(const std::vector<Line>& lines, size_t from,
                                        const Separator& sep) {
    std::vector<std::string_view> f;
    for (size_t i = from; i < lines.size(); ++i) {
        if (trace_text::is_blank(lines[i].text) || trace_text::is_comment(lines[i].text)) continue;
        split_fields(lines[i].text, sep, f);
        if (f.size() >= 2 && all_numeric(f)) return i;
    }
    return std::nullopt;
}

// How well `sep` splits the table from `from` on: the number of the (up to 20) content lines after
// the first numeric row that have its field count and are numeric; -1 without a numeric row.
int separator_score(const std::vector<Line>& lines, size_t from, const Separator& sep) {
    std::optional<size_t> first = first_numeric_row(lines, from, sep);
    if (!first) return -1;
    std::vector<std::string_view> f;
    split_fields(lines[*first].text, sep, f);
    const size_t n = f.size();
    int score = 0, seen = 0;
    for (size_t i = *first + 1; i < lines.size() && seen < 20; ++i) {
        if (trace_text::is_blank(lines[i].text) || trace_text::is_comment(lines[i].text)) continue;
        ++seen;
        split_fields(lines[i].text, sep, f);
        if (f.size() == n && all_numeric(f)) ++score;
    }
    return score;
}

Result<Separator> choose_separator(const std::vector<Line>& lines, size_t from,
                                   const std::string& option, const std::string& source) {
    std::string o = lower(option);
    if (o == "auto" || o.empty()) {
        int best_score = -1;
        Separator best;
        for (const Separator& s : kAutoSeparators) {
            int score = separator_score(lines, from, s);
            if (score > best_score) {
                best_score = score;
                best = s;
            }
        }
        if (best_score < 0)
            return make_error(source +
                              ": no row of numbers found with any separator (comma, tab, "
                              "semicolon, whitespace); is this a table?");
        best.name += " (detected)";
        return best;
    }
    if (o == "comma" || o == ",") return Separator{',', false, "comma"};
    if (o == "tab" || o == "\t" || o == "\\t") return Separator{'\t', false, "tab"};
    if (o == "semicolon" || o == ";") return Separator{';', false, "semicolon"};
    if (o == "whitespace" || o == "space" || o == " ") return Separator{' ', true, "whitespace"};
    if (option.size() == 1) return Separator{option[0], false, in_quotes(option)};
    return make_error(
        "separator " + in_quotes(option) +
        " is not one of auto, comma, tab, semicolon, whitespace or a single character");
}

// --- Column names ------------------------------------------------------------------------------

struct ColumnName {
    std::string raw;   // as written
    std::string key;   // lower case, without a trailing "[unit]" or "(unit)"
    std::string unit;  // the bracketed unit, lower case ("" when none)
};

ColumnName make_name(std::string_view raw) {
    ColumnName n{std::string(trim(raw)), lower(trim(raw)), ""};
    if (!n.key.empty() && (n.key.back() == ']' || n.key.back() == ')')) {
        char open = n.key.back() == ']' ? '[' : '(';
        size_t b = n.key.rfind(open);
        if (b != std::string::npos) {
            n.unit = std::string(trim(std::string_view(n.key).substr(b + 1, n.key.size() - b - 2)));
            n.key = std::string(trim(std::string_view(n.key).substr(0, b)));
        }
    }
    return n;
}

// Nanoseconds per unit for a unit name; nullopt when unknown.
std::optional<long double> ns_per_unit(std::string_view unit) {
    if (unit == "s" || unit == "sec" || unit == "seconds") return 1e9L;
    if (unit == "ms") return 1e6L;
    if (unit == "us" || unit == "\xC2\xB5s" || unit == "\xCE\xBCs") return 1e3L;
    if (unit == "ns") return 1.0L;
    return std::nullopt;
}

struct Column {
    size_t index = 0;
    std::string label;  // "column 3 'w'" for messages
};

std::string column_label(size_t index, const std::vector<ColumnName>& names) {
    std::string s = "column " + std::to_string(index + 1);
    if (index < names.size()) s += " '" + names[index].raw + "'";
    return s;
}

std::string list_names(const std::vector<ColumnName>& names) {
    std::string s;
    for (const ColumnName& n : names) trace_text::append_item(s, n.raw, ", ");
    return s;
}

// A column by name (case-insensitive, unit brackets ignored) or by 0-based index.
Result<Column> resolve_column(const std::string& ref, const std::vector<ColumnName>& names,
                              size_t n_fields, const std::string& what, const std::string& source) {
    std::string key = make_name(ref).key;
    for (size_t i = 0; i < names.size(); ++i)
        if (names[i].key == key || lower(names[i].raw) == lower(trim(ref)))
            return Column{i, column_label(i, names)};
    std::string_view r = trim(ref);
    if (!r.empty() &&
        std::all_of(r.begin(), r.end(), [](char c) { return c >= '0' && c <= '9'; })) {
        std::optional<int64_t> idx = trace_text::parse_int64(r);
        if (idx && *idx >= 0 && size_t(*idx) < n_fields)
            return Column{size_t(*idx), column_label(size_t(*idx), names)};
        return make_error(source + ": " + what + ": column index " + std::string(r) +
                          " is out of range (rows have " + std::to_string(n_fields) +
                          " fields, indices 0.." + std::to_string(n_fields - 1) + ")");
    }
    return make_error(source + ": " + what + ": no column named " + in_quotes(ref) +
                      (names.empty() ? " (the table has no header line; use 0-based indices)"
                                     : " (columns: " + list_names(names) + ")"));
}

Result<std::vector<Column>> resolve_columns(const std::vector<std::string>& refs, size_t count,
                                            const std::vector<ColumnName>& names, size_t n_fields,
                                            const std::string& what, const std::string& source) {
    if (refs.size() != count)
        return make_error(source + ": " + what + ": expected " + std::to_string(count) +
                          " columns, got " + std::to_string(refs.size()));
    std::vector<Column> out;
    for (const std::string& r : refs) {
        Result<Column> c = resolve_column(r, names, n_fields, what, source);
        if (!c.ok()) return c.error();
        out.push_back(*c);
    }
    return out;
}

// Columns whose keys are exactly `keys`, in that order; empty when any is missing.
std::vector<Column> find_named(const std::vector<ColumnName>& names,
                               std::initializer_list<std::string_view> keys) {
    std::vector<Column> out;
    for (std::string_view k : keys) {
        auto it = std::find_if(names.begin(), names.end(),
                               [&](const ColumnName& n) { return n.key == k; });
        if (it == names.end()) return {};
        size_t i = size_t(it - names.begin());
        out.push_back({i, column_label(i, names)});
    }
    return out;
}

std::string labels(const std::vector<Column>& cols) {
    std::string s;
    for (const Column& c : cols) trace_text::append_item(s, c.label, ", ");
    return s;
}

// The time column chosen by "auto": the first column named time/timestamp/t/ts, optionally with a
// unit suffix (_s, _ms, _us, _ns). The unit (ns per unit) comes from the suffix or a bracket.
struct TimeGuess {
    Column column;
    std::optional<long double> ns_per_unit;
};

std::optional<TimeGuess> guess_time_column(const std::vector<ColumnName>& names) {
    for (size_t i = 0; i < names.size(); ++i) {
        const std::string& k = names[i].key;
        std::string base = k, suffix;
        size_t us = k.rfind('_');
        if (us != std::string::npos && ns_per_unit(k.substr(us + 1))) {
            base = k.substr(0, us);
            suffix = k.substr(us + 1);
        }
        if (base != "time" && base != "timestamp" && base != "t" && base != "ts") continue;
        TimeGuess g{{i, column_label(i, names)}, std::nullopt};
        if (!suffix.empty())
            g.ns_per_unit = ns_per_unit(suffix);
        else if (!names[i].unit.empty())
            g.ns_per_unit = ns_per_unit(names[i].unit);
        return g;
    }
    return std::nullopt;
}

std::optional<long double> unit_of_column(const ColumnName& n) {
    size_t us = n.key.rfind('_');
    if (us != std::string::npos)
        if (auto u = ns_per_unit(n.key.substr(us + 1))) return u;
    if (!n.unit.empty()) return ns_per_unit(n.unit);
    return std::nullopt;
}

std::string unit_name(long double ns_per) {
    if (ns_per == 1e9L) return "s";
    if (ns_per == 1e6L) return "ms";
    if (ns_per == 1e3L) return "us";
    if (ns_per == 1.0L) return "ns";
    return fmt("%.9g s per unit", double(ns_per * 1e-9L));
}

// q = Ry(yaw) * Rx(pitch) * Rz(roll): intrinsic yaw about +Y, then pitch about the new +X, then
// roll about the new +Z (docs/trace-format.md#euler-angles).
glm::dquat quat_from_yaw_pitch_roll(double yaw, double pitch, double roll) {
    return glm::angleAxis(yaw, glm::dvec3(0, 1, 0)) * glm::angleAxis(pitch, glm::dvec3(1, 0, 0)) *
           glm::angleAxis(roll, glm::dvec3(0, 0, 1));
}

}  // namespace

Result<Trace> import_trace_text(const std::string& text, const std::string& source,
                                const TraceImportOptions& options, TraceImportReport* out_report) {
    TraceImportReport local;
    TraceImportReport& rep = out_report ? *out_report : local;
    rep = TraceImportReport{};
    const std::vector<Line> lines = trace_text::split_lines(text);

    // 1. Lines to skip, separator, first data row, column names.
    size_t from = 0;
    if (options.header_lines >= 0)
        while (from < lines.size() && lines[from].number <= size_t(options.header_lines)) ++from;
    Result<Separator> sep_r = choose_separator(lines, from, options.separator, source);
    if (!sep_r.ok()) return sep_r.error();
    const Separator sep = *sep_r;
    rep.separator = sep.name;
    rep.notes.push_back("separator: " + sep.name);

    std::vector<std::string_view> fields;
    std::optional<size_t> names_at;  // index into lines
    size_t data_at = lines.size();
    if (options.header_lines >= 0) {
        size_t i = from;
        while (i < lines.size() && trace_text::is_blank(lines[i].text)) ++i;
        if (i < lines.size()) {
            split_fields(lines[i].text, sep, fields);
            if (trace_text::is_comment(lines[i].text) || !all_numeric(fields)) names_at = i++;
        }
        while (i < lines.size() &&
               (trace_text::is_blank(lines[i].text) || trace_text::is_comment(lines[i].text)))
            ++i;
        data_at = i;
    } else {
        std::optional<size_t> first = first_numeric_row(lines, 0, sep);
        if (!first) return make_error(source + ": no row of numbers found");
        data_at = *first;
        // The names: the last line before the data with as many fields as the rows ('#' removed).
        split_fields(lines[data_at].text, sep, fields);
        const size_t n = fields.size();
        std::optional<size_t> last_nonblank;
        for (size_t i = data_at; i-- > 0;) {
            if (trace_text::is_blank(lines[i].text)) continue;
            if (!last_nonblank) last_nonblank = i;
            split_fields(strip_hash(lines[i].text), sep, fields);
            if (fields.size() == n) {
                names_at = i;
                break;
            }
        }
        if (!names_at) names_at = last_nonblank;  // named in the note below
    }
    if (data_at >= lines.size()) return make_error(source + ": no data rows");
    for (size_t i = 0; i < data_at; ++i)
        if (!trace_text::is_blank(lines[i].text)) ++rep.header_lines_skipped;

    split_fields(lines[data_at].text, sep, fields);
    const size_t n_fields = fields.size();
    std::vector<ColumnName> names;
    if (names_at) {
        split_fields(strip_hash(lines[*names_at].text), sep, fields);
        if (fields.size() == n_fields) {
            for (std::string_view f : fields) names.push_back(make_name(f));
            rep.notes.push_back("column names from line " +
                                std::to_string(lines[*names_at].number) + "; data from line " +
                                std::to_string(lines[data_at].number));
        } else {
            rep.notes.push_back("line " + std::to_string(lines[*names_at].number) + " has " +
                                std::to_string(fields.size()) + " fields but rows have " +
                                std::to_string(n_fields) +
                                ": no column names, columns are addressed by 0-based index");
        }
    } else {
        rep.notes.push_back("no header line: columns are addressed by 0-based index");
    }

    // 2. Columns.
    std::optional<Column> time_col;
    std::optional<long double> ns_per;
    std::string unit_how;
    if (lower(options.time_column) == "auto" || options.time_column.empty()) {
        std::optional<TimeGuess> g = guess_time_column(names);
        if (!g)
            return make_error(source +
                              ": no time column found (looked for time, timestamp, t, ts, with an "
                              "optional _s/_ms/_us/_ns suffix); name it with --time-column" +
                              (names.empty() ? "" : " (columns: " + list_names(names) + ")"));
        time_col = g->column;
        ns_per = g->ns_per_unit;
        if (ns_per) unit_how = "from the column name";
    } else {
        Result<Column> c = resolve_column(options.time_column, names, n_fields, "time", source);
        if (!c.ok()) return c.error();
        time_col = *c;
        if (c->index < names.size()) {
            ns_per = unit_of_column(names[c->index]);
            if (ns_per) unit_how = "from the column name";
        }
    }
    if (!options.time_unit.empty()) {
        ns_per = ns_per_unit(lower(options.time_unit));
        if (!ns_per)
            return make_error("time unit " + in_quotes(options.time_unit) +
                              " is not one of s, ms, us, ns");
        unit_how = "as given";
    } else if (options.time_scale_to_s != 0.0) {
        if (!(options.time_scale_to_s > 0.0) || !std::isfinite(options.time_scale_to_s))
            return make_error("time scale " + fmt("%g", options.time_scale_to_s) +
                              " is not a positive number of seconds per unit");
        long double s = (long double)options.time_scale_to_s * 1e9L;
        // note: 1e-7 as a double is not exactly 1e-7; snap near-integers so 100 ns ticks stay
        // exact.
        long double r = std::round(s);
        if (r >= 1.0L && std::abs(s - r) <= r * 1e-12L) s = r;
        ns_per = s;
        unit_how = "as given";
    } else if (!ns_per) {
        ns_per = 1e9L;
        unit_how = "assumed: the column name gives no unit";
    }
    rep.notes.push_back("time: " + time_col->label + ", " + unit_name(*ns_per) + " (" + unit_how +
                        ")");

    // Source axes -> hmdnode axes (+Y up, -Z forward, +X right).
    std::optional<glm::dquat> frame_change;
    bool mirror_z = false;  // a left-handed source: the reflection z -> -z
    const std::string frame = lower(options.source_frame);
    if (frame == "unity" || frame == "left-handed-y-up-z-forward") {
        // Unity, HoloLens, Quest (OpenXR via Unity): left-handed, +Y up, +Z forward, +X right.
        // The reflection M = diag(1, 1, -1) takes its axes to ours: p' = M p and R' = M R M, which
        // for a quaternion (w, x, y, z) is (w, -x, -y, z) (a reflection flips the axis' sign
        // except along the mirror's normal).
        mirror_z = true;
        rep.notes.push_back(
            "axes: source left-handed +Y up, +Z forward, +X right (Unity) mirrored to +Y up, "
            "-Z forward, +X right");
    } else if (frame == "z-up-x-forward") {
        glm::dmat3 m(0.0);  // columns: where the source's x (forward), y (left), z (up) go
        m[0] = glm::dvec3(0, 0, -1);
        m[1] = glm::dvec3(-1, 0, 0);
        m[2] = glm::dvec3(0, 1, 0);
        frame_change = glm::quat_cast(m);
        rep.notes.push_back(
            "axes: source +Z up, +X forward, +Y left converted to +Y up, -Z forward, +X right");
    } else if (frame != "hmdnode") {
        return make_error("source frame " + in_quotes(options.source_frame) +
                          " is not one of: hmdnode, z-up-x-forward, unity");
    }
    const std::string on_fast = lower(options.on_fast_rotation);
    if (on_fast != "report" && on_fast != "drop" && on_fast != "refuse")
        return make_error("on fast rotation " + in_quotes(options.on_fast_rotation) +
                          " is not one of: report, drop, refuse");
    if (!(options.max_angular_speed_deg_s > 0.0))
        return make_error("the angular speed limit must be positive (deg/s)");
    if (!(options.quat_norm_tolerance > 0.0 && options.quat_norm_tolerance < 1.0))
        return make_error("the quaternion norm tolerance must be within (0, 1)");
    {}
    std::vector<Column> quat_cols, euler_cols, pos_cols;
    std::string order = lower(options.quat_order);
    if (order != "wxyz" && order != "xyzw")
        return make_error("quaternion order " + in_quotes(options.quat_order) +
                          " is not wxyz or xyzw");
    bool euler_degrees = options.euler_degrees;
    if (!options.quat_columns.empty() && !options.euler_columns.empty())
        return make_error("give quaternion columns or Euler columns, not both");
    if (!options.quat_columns.empty()) {
        auto r = resolve_columns(options.quat_columns, 4, names, n_fields, "quaternion", source);
        if (!r.ok()) return r.error();
        quat_cols = *r;
        // Stored as w, x, y, z.
        if (order == "xyzw") std::rotate(quat_cols.begin(), quat_cols.begin() + 3, quat_cols.end());
    } else if (!options.euler_columns.empty()) {
        auto r = resolve_columns(options.euler_columns, 3, names, n_fields, "Euler angles", source);
        if (!r.ok()) return r.error();
        euler_cols = *r;
    } else {
        for (auto keys :
             {std::initializer_list<std::string_view>{"qw", "qx", "qy", "qz"},
              std::initializer_list<std::string_view>{"w", "x", "y", "z"},
              std::initializer_list<std::string_view>{"quat_w", "quat_x", "quat_y", "quat_z"}}) {
            quat_cols = find_named(names, keys);
            if (!quat_cols.empty()) break;
        }
        if (quat_cols.empty()) euler_cols = find_named(names, {"yaw", "pitch", "roll"});
        if (quat_cols.empty() && euler_cols.empty())
            return make_error(source +
                              ": no orientation columns found (looked for qw,qx,qy,qz / w,x,y,z / "
                              "yaw,pitch,roll); name them with --quat-columns or --euler-columns" +
                              (names.empty() ? "" : " (columns: " + list_names(names) + ")"));
    }
    if (!quat_cols.empty())
        rep.notes.push_back("orientation: quaternion w,x,y,z from " + labels(quat_cols));
    else
        rep.notes.push_back("orientation: Euler yaw, pitch, roll in " +
                            std::string(euler_degrees ? "degrees" : "radians") + " from " +
                            labels(euler_cols) + " (q = Ry(yaw) * Rx(pitch) * Rz(roll))");

    if (!options.position_columns.empty()) {
        auto r = resolve_columns(options.position_columns, 3, names, n_fields, "position", source);
        if (!r.ok()) return r.error();
        pos_cols = *r;
    } else {
        for (auto keys :
             {std::initializer_list<std::string_view>{"px", "py", "pz"},
              std::initializer_list<std::string_view>{"pos_x", "pos_y", "pos_z"},
              std::initializer_list<std::string_view>{"position_x", "position_y", "position_z"},
              std::initializer_list<std::string_view>{"tx", "ty", "tz"},
              std::initializer_list<std::string_view>{"x", "y", "z"}}) {
            pos_cols = find_named(names, keys);
            if (pos_cols.empty()) continue;
            // note: x,y,z are a position only when the quaternion does not use them.
            bool taken = std::any_of(pos_cols.begin(), pos_cols.end(), [&](const Column& p) {
                return std::any_of(quat_cols.begin(), quat_cols.end(),
                                   [&](const Column& q) { return q.index == p.index; });
            });
            if (!taken) break;
            pos_cols.clear();
        }
    }
    if (!pos_cols.empty()) rep.notes.push_back("position (metres): " + labels(pos_cols));

    std::vector<bool> used(n_fields, false);
    auto use = [&](const Column& c) -> Status {
        if (used[c.index])
            return make_error(source + ": " + c.label + " is given for two different quantities");
        used[c.index] = true;
        return {};
    };
    for (const std::vector<Column>* group : {&quat_cols, &euler_cols, &pos_cols})
        for (const Column& c : *group)
            if (Status s = use(c); !s.ok()) return s.error();
    if (Status s = use(*time_col); !s.ok()) return s.error();
    {
        std::string ignored;
        for (size_t i = 0; i < n_fields; ++i)
            if (!used[i]) trace_text::append_item(ignored, column_label(i, names), ", ");
        if (!ignored.empty()) rep.notes.push_back("ignored: " + ignored);
    }

    // 3. Rows.
    size_t last_content = data_at;
    for (size_t i = data_at; i < lines.size(); ++i)
        if (!trace_text::is_blank(lines[i].text) && !trace_text::is_comment(lines[i].text))
            last_content = i;

    Trace trace;
    long double t0 = 0.0L;
    std::string t0_text;
    size_t prev_line = 0;
    std::string prev_time_text;
    double worst_norm = 1.0;
    for (size_t li = data_at; li < lines.size(); ++li) {
        const Line& line = lines[li];
        if (trace_text::is_blank(line.text)) continue;
        if (trace_text::is_comment(line.text)) {
            ++rep.comment_lines_skipped;
            continue;
        }
        split_fields(line.text, sep, fields);
        if (fields.size() != n_fields) {
            if (li == last_content && fields.size() < n_fields && li != data_at) {
                rep.truncated_last_row_dropped = true;
                rep.notes.push_back("the last row (line " + std::to_string(line.number) + ") has " +
                                    std::to_string(fields.size()) + " of " +
                                    std::to_string(n_fields) +
                                    " fields (a cut-off recording): dropped");
                continue;
            }
            return make_error(where(source, line.number) + "found " +
                              std::to_string(fields.size()) + " fields, expected " +
                              std::to_string(n_fields) + " (as in line " +
                              std::to_string(lines[data_at].number) + ", the first data row)");
        }
        ++rep.rows_read;
        auto field_error = [&](const Column& c, const std::string& what) {
            return make_error(where(source, line.number) + c.label + ": " + what + " " +
                              in_quotes(fields[c.index]));
        };
        auto number = [&](const Column& c) -> Result<double> {
            std::optional<double> v = trace_text::parse_double(fields[c.index]);
            if (!v) return field_error(c, "not a number:");
            if (!std::isfinite(*v)) return field_error(c, "not a finite number:");
            return *v;
        };

        // Time.
        std::optional<long double> t = trace_text::parse_long_double(fields[time_col->index]);
        if (!t) return field_error(*time_col, "not a number:");
        if (!std::isfinite(*t)) return field_error(*time_col, "not a finite number:");
        if (trace.samples.empty() && rep.rows_read == 1) {
            t0 = options.rebase_time ? *t : 0.0L;
            t0_text = std::string(fields[time_col->index]);
        }
        long double ns_ld = std::round((*t - t0) * *ns_per);
        if (!(std::abs(ns_ld) < 9.2e18L))
            return field_error(*time_col, "time out of range for int64 nanoseconds:");
        const int64_t t_ns = int64_t(ns_ld);

        // Orientation.
        glm::dquat q;
        std::optional<double> source_norm;  // set when counted as normalised
        if (!quat_cols.empty()) {
            double c[4];
            for (int k = 0; k < 4; ++k) {
                Result<double> v = number(quat_cols[size_t(k)]);
                if (!v.ok()) return v.error();
                c[k] = *v;
            }
            q = glm::dquat(c[0], c[1], c[2], c[3]);
            double norm = std::sqrt(glm::dot(q, q));
            if (!(std::abs(norm - 1.0) <= options.quat_norm_tolerance))
                return make_error(where(source, line.number) + labels(quat_cols) +
                                  ": quaternion norm " + fmt("%.6g", norm) +
                                  (norm == 0.0 ? " (a zero quaternion is no rotation)"
                                               : " is far from 1 (off by more than " +
                                                     fmt("%g", options.quat_norm_tolerance) +
                                                     "): are the quaternion columns and their "
                                                     "order right?"));
            if (std::abs(norm - 1.0) > kNormCountTolerance) source_norm = norm;
            // note: norms within 1e-12 of 1 keep the source's bits (as the trace reader does).
            if (std::abs(norm - 1.0) > 1e-12) q /= norm;
        } else {
            double a[3];
            for (int k = 0; k < 3; ++k) {
                Result<double> v = number(euler_cols[size_t(k)]);
                if (!v.ok()) return v.error();
                if (!euler_degrees && std::abs(*v) > 2.0 * kPi + 1e-9)
                    return field_error(euler_cols[size_t(k)],
                                       "an angle beyond 2 pi with --euler-radians (degrees? drop "
                                       "--euler-radians):");
                a[k] = euler_degrees ? deg_to_rad(*v) : *v;
            }
            q = quat_from_yaw_pitch_roll(a[0], a[1], a[2]);
        }
        std::optional<glm::dvec3> pos;
        if (!pos_cols.empty()) {
            double p[3];
            for (int k = 0; k < 3; ++k) {
                Result<double> v = number(pos_cols[size_t(k)]);
                if (!v.ok()) return v.error();
                p[k] = *v;
            }
            pos = glm::dvec3(p[0], p[1], p[2]);
        }
        if (frame_change) {
            // Same change of basis on the world and the head frame: q' = C q C^-1, p' = C p.
            q = glm::normalize(*frame_change * q * glm::conjugate(*frame_change));
            if (pos) *pos = *frame_change * *pos;
        }
        if (mirror_z) {
            q = glm::dquat(q.w, -q.x, -q.y, q.z);
            if (pos) pos->z = -pos->z;
        }

        // Repairs against the previous kept sample.
        if (!trace.samples.empty()) {
            const TraceSample& prev = trace.samples.back();
            const std::string time_text(fields[time_col->index]);
            if (t_ns < prev.time_ns)
                return make_error(where(source, line.number) + time_col->label +
                                  ": time goes backwards: " + time_text + " after " +
                                  prev_time_text + " (line " + std::to_string(prev_line) +
                                  "); the importer does not reorder rows");
            if (t_ns == prev.time_ns) {
                ++rep.duplicate_times_dropped;
                bool differs = angle_between_rad(q, prev.orientation) > kConflictAngleRad ||
                               (pos && prev.position && *pos != *prev.position);
                if (differs) ++rep.duplicate_times_conflicting;
                continue;
            }
            if (glm::dot(q, prev.orientation) < 0.0) {
                q = -q;
                ++rep.sign_flips_fixed;
            }
            // Angular speed of this step: a jump no head makes (a wrong order, a glitch).
            const double speed =
                rad_to_deg(angle_between_rad(q, prev.orientation)) / ns_to_s(t_ns - prev.time_ns);
            if (speed > options.max_angular_speed_deg_s) {
                ++rep.fast_rotations;
                if (on_fast == "refuse")
                    return make_error(where(source, line.number) + "the orientation turns " +
                                      fmt("%.0f", speed) + " deg/s since line " +
                                      std::to_string(prev_line) + ", above the limit of " +
                                      fmt("%g", options.max_angular_speed_deg_s) +
                                      " deg/s (a wrong quaternion order, or a tracking glitch)");
                if (on_fast == "drop") {
                    ++rep.fast_rotations_dropped;
                    continue;
                }
            }
            rep.max_angular_speed_deg_s = std::max(rep.max_angular_speed_deg_s, speed);
            if (q == prev.orientation) ++rep.repeated_orientations;
            int64_t gap = t_ns - prev.time_ns;
            if (gap > kGapReportNs) ++rep.gaps_over_100ms;
            rep.longest_gap_ns = std::max(rep.longest_gap_ns, gap);
        }
        if (source_norm) {
            ++rep.non_unit_normalized;
            if (std::abs(*source_norm - 1.0) > std::abs(worst_norm - 1.0))
                worst_norm = *source_norm;
        }
        TraceSample s;
        s.time_ns = t_ns;
        s.orientation = q;
        s.position = pos;
        trace.samples.push_back(s);
        prev_line = line.number;
        prev_time_text = std::string(fields[time_col->index]);
    }
    if (trace.samples.empty()) return make_error(source + ": no data rows");
    rep.samples_written = trace.samples.size();
    if (options.rebase_time) {
        long double off = std::round(t0 * *ns_per);
        rep.time_offset_ns = std::abs(off) < 9.2e18L ? int64_t(off) : 0;
    }

    // 4. The account.
    auto count = [](size_t n, const char* one, const char* many) {
        return std::to_string(n) + " " + (n == 1 ? one : many);
    };
    if (options.rebase_time)
        rep.notes.push_back("time rebased: the first row (source time " + t0_text + ") is at 0 ns");
    if (rep.sign_flips_fixed)
        rep.notes.push_back(count(rep.sign_flips_fixed, "sign flip", "sign flips") +
                            " made continuous (q -> -q, the same rotation)");
    if (rep.duplicate_times_dropped)
        rep.notes.push_back(count(rep.duplicate_times_dropped, "row", "rows") +
                            " with a repeated time dropped (the first row at each time is kept); " +
                            std::to_string(rep.duplicate_times_conflicting) +
                            " of them had a different pose");
    if (rep.non_unit_normalized)
        rep.notes.push_back(count(rep.non_unit_normalized, "quaternion", "quaternions") +
                            " normalised (norm off by more than 1e-6; furthest " +
                            fmt("%.6g", worst_norm) + ")");
    if (rep.gaps_over_100ms)
        rep.notes.push_back(
            count(rep.gaps_over_100ms, "gap", "gaps") + " over 100 ms kept (longest " +
            fmt("%.1f", ns_to_ms(rep.longest_gap_ns)) + " ms); replay interpolates across them");
    if (rep.repeated_orientations)
        rep.notes.push_back(count(rep.repeated_orientations, "sample repeats", "samples repeat") +
                            " the previous orientation at a new time (kept)");
    if (rep.comment_lines_skipped)
        rep.notes.push_back(count(rep.comment_lines_skipped, "comment line", "comment lines") +
                            " among the rows skipped");
    if (rep.fast_rotations)
        rep.notes.push_back(count(rep.fast_rotations, "step turns", "steps turn") +
                            " faster than " + fmt("%g", options.max_angular_speed_deg_s) +
                            " deg/s" +
                            (rep.fast_rotations_dropped ? ": dropped" : ": kept (reported)"));
    if (trace.samples.size() >= 2) {
        TraceStats st = compute_trace_stats(trace);
        const int64_t duration = trace.samples.back().time_ns - trace.samples.front().time_ns;
        if (st.median_interval_ns < kMinMedianIntervalNs ||
            st.median_interval_ns > kMaxMedianIntervalNs || duration > kMaxDurationNs) {
            // The unit under which the median interval would be that of a head tracker (~1 kHz
            // to ~10 Hz), among the usual ones.
            const long double median_units = (long double)(st.median_interval_ns) / *ns_per;
            std::string likely;
            for (const auto& [name, per] :
                 std::initializer_list<std::pair<const char*, long double>>{
                     {"--time-unit s", 1e9L},
                     {"--time-unit ms", 1e6L},
                     {"--time-unit us", 1e3L},
                     {"--time-unit ns", 1.0L},
                     {"--time-scale 1e-7 (100 ns ticks: .NET DateTime/TimeSpan, Windows FILETIME)",
                      100.0L},
                     {"--time-scale 2.0833333e-8 (48 MHz ticks)", 1e9L / 48e6L}}) {
                const long double m = median_units * per;
                if (per != *ns_per && m >= 5e5L && m <= 1e8L) {
                    likely = std::string("; with ") + name + " the median interval would be " +
                             fmt("%.3g", double(m) * 1e-6) + " ms";
                    break;
                }
            }
            return make_error(
                source + ": " + time_col->label + " read as " + unit_name(*ns_per) +
                " gives a median interval of " + fmt("%.6g", ns_to_s(st.median_interval_ns)) +
                " s over " + fmt("%.6g", ns_to_s(duration)) +
                " s, implausible for a head tracker (median 10 us to 10 s, at most a day)" +
                (likely.empty() ? std::string("; check the time unit") : likely));
        }
        if (st.median_interval_ns < 100 * kNsPerUs || st.median_interval_ns > kNsPerSecond)
            rep.notes.push_back("the median interval " +
                                fmt("%.6g", ns_to_s(st.median_interval_ns)) +
                                " s is implausible for a head tracker: check the time unit");
    }

    std::string src_name = std::filesystem::path(source).filename().string();
    trace.comments.push_back("imported from " + src_name + " by hmdnode trace import");
    trace.comments.push_back(
        "time: source " + time_col->label + " in " + unit_name(*ns_per) +
        (options.rebase_time ? ", rebased to 0 at source time " + t0_text : ""));
    trace.comments.push_back("fixes: " + std::to_string(rep.sign_flips_fixed) + " sign flips, " +
                             std::to_string(rep.duplicate_times_dropped) +
                             " repeated times dropped, " + std::to_string(rep.non_unit_normalized) +
                             " quaternions normalised, " + std::to_string(rep.gaps_over_100ms) +
                             " gaps over 100 ms kept");
    return trace;
}

Result<Trace> import_trace_table(const std::filesystem::path& path,
                                 const TraceImportOptions& options, TraceImportReport* out_report) {
    if (out_report) *out_report = TraceImportReport{};
    Result<std::string> text = read_file(path);
    if (!text.ok()) return text.error();
    return import_trace_text(*text, path.string(), options, out_report);
}

}  // namespace hmdnode
