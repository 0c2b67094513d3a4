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

// The usual time units of a foreign log, as the option that selects each and its length in ns:
// what the plausibility checks try when a column's unit gives no head tracker's rate.
struct TimeUnitChoice {
    const char* option;
    long double ns_per_unit;
};
constexpr TimeUnitChoice kTimeUnitChoices[] = {
    {"--time-unit s", 1e9L},
    {"--time-unit ms", 1e6L},
    {"--time-unit us", 1e3L},
    {"--time-unit ns", 1.0L},
    {"--time-scale 1e-7 (100 ns ticks: .NET DateTime/TimeSpan, Windows FILETIME)", 100.0L},
    {"--time-scale 2.0833333e-8 (48 MHz ticks)", 1e9L / 48e6L}};

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

using trace_text::where;

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

// The importer's state from one step to the next: the table's layout (step 1), the columns and
// options (step 2), and what the rows so far leave for the next one and the account (step 3).
class TableImporter {
  public:
    TableImporter(const std::vector<Line>& lines, bool last_unterminated, const std::string& source,
                  const TraceImportOptions& options, TraceImportReport& rep)
        : lines_(lines),
          last_unterminated_(last_unterminated),
          source_(source),
          options_(options),
          rep_(rep) {}

    Result<Trace> run() {
        if (Status s = find_table(); !s.ok()) return s.error();
        if (Status s = choose_columns(); !s.ok()) return s.error();
        Trace trace;
        if (Status s = read_rows(trace); !s.ok()) return s.error();
        add_account_notes();
        if (Status s = check_time_plausible(trace); !s.ok()) return s.error();
        add_trace_comments(trace);
        return trace;
    }

  private:
    enum class Step { keep, drop };

    // 1. Lines to skip, separator, first data row, column names.
    Status find_table() {
        size_t from = 0;
        if (options_.header_lines >= 0)
            while (from < lines_.size() && lines_[from].number <= size_t(options_.header_lines))
                ++from;
        Result<Separator> sep_r = choose_separator(lines_, from, options_.separator, source_);
        if (!sep_r.ok()) return sep_r.error();
        sep_ = *sep_r;
        rep_.separator = sep_.name;
        rep_.notes.push_back("separator: " + sep_.name);

        std::optional<size_t> names_at;  // index into lines
        data_at_ = lines_.size();
        if (options_.header_lines >= 0) {
            size_t i = from;
            while (i < lines_.size() && trace_text::is_blank(lines_[i].text)) ++i;
            if (i < lines_.size()) {
                split_fields(lines_[i].text, sep_, fields_);
                if (trace_text::is_comment(lines_[i].text) || !all_numeric(fields_)) names_at = i++;
            }
            while (i < lines_.size() &&
                   (trace_text::is_blank(lines_[i].text) || trace_text::is_comment(lines_[i].text)))
                ++i;
            data_at_ = i;
        } else {
            std::optional<size_t> first = first_numeric_row(lines_, 0, sep_);
            if (!first) return make_error(source_ + ": no row of numbers found");
            data_at_ = *first;
            // The names: the last line before the data with as many fields as the rows ('#'
            // removed).
            split_fields(lines_[data_at_].text, sep_, fields_);
            const size_t n = fields_.size();
            std::optional<size_t> last_nonblank;
            for (size_t i = data_at_; i-- > 0;) {
                if (trace_text::is_blank(lines_[i].text)) continue;
                if (!last_nonblank) last_nonblank = i;
                split_names(lines_[i].text, n);
                if (fields_.size() == n) {
                    names_at = i;
                    break;
                }
            }
            if (!names_at) names_at = last_nonblank;  // named in the note below
        }
        if (data_at_ >= lines_.size()) return make_error(source_ + ": no data rows");
        for (size_t i = 0; i < data_at_; ++i)
            if (!trace_text::is_blank(lines_[i].text)) ++rep_.header_lines_skipped;
        read_column_names(names_at);
        return {};
    }

    // Splits a header line ('#' removed) into fields_: by the rows' separator, or, when that does
    // not give `n` fields, by another separator that does (a header separated by spaces over
    // comma-separated rows); the other separator's name, "" when the rows' own served.
    std::string split_names(std::string_view line, size_t n) {
        split_fields(strip_hash(line), sep_, fields_);
        if (fields_.size() == n) return {};
        for (const Separator& s : kAutoSeparators) {
            if (s.c == sep_.c && s.whitespace == sep_.whitespace) continue;
            split_fields(strip_hash(line), s, fields_);
            if (fields_.size() == n && !all_numeric(fields_)) return s.name;
        }
        split_fields(strip_hash(line), sep_, fields_);
        return {};
    }

    void read_column_names(std::optional<size_t> names_at) {
        split_fields(lines_[data_at_].text, sep_, fields_);
        n_fields_ = fields_.size();
        if (names_at) {
            const std::string other = split_names(lines_[*names_at].text, n_fields_);
            if (fields_.size() == n_fields_) {
                for (std::string_view f : fields_) names_.push_back(make_name(f));
                rep_.notes.push_back(
                    "column names from line " + std::to_string(lines_[*names_at].number) +
                    (other.empty()
                         ? ""
                         : " (separated by " + other + ", the rows by " + sep_.name + ")") +
                    "; data from line " + std::to_string(lines_[data_at_].number));
            } else {
                rep_.notes.push_back("line " + std::to_string(lines_[*names_at].number) + " has " +
                                     std::to_string(fields_.size()) + " fields but rows have " +
                                     std::to_string(n_fields_) +
                                     ": no column names, columns are addressed by 0-based index");
            }
        } else {
            rep_.notes.push_back("no header line: columns are addressed by 0-based index");
        }
    }

    // 2. Columns.
    Status choose_columns() {
        if (Status s = choose_time_column(); !s.ok()) return s;
        if (Status s = choose_frame(); !s.ok()) return s;
        if (Status s = check_row_options(); !s.ok()) return s;
        if (Status s = choose_orientation_columns(); !s.ok()) return s;
        if (Status s = choose_position_columns(); !s.ok()) return s;
        return claim_columns();
    }

    Status choose_time_column() {
        std::optional<long double> ns_per;
        std::string unit_how;
        if (lower(options_.time_column) == "auto" || options_.time_column.empty()) {
            std::optional<TimeGuess> g = guess_time_column(names_);
            if (!g)
                return make_error(
                    source_ +
                    ": no time column found (looked for time, timestamp, t, ts, with an "
                    "optional _s/_ms/_us/_ns suffix); name it with --time-column" +
                    (names_.empty() ? "" : " (columns: " + list_names(names_) + ")"));
            time_col_ = g->column;
            ns_per = g->ns_per_unit;
            if (ns_per) unit_how = "from the column name";
        } else {
            Result<Column> c =
                resolve_column(options_.time_column, names_, n_fields_, "time", source_);
            if (!c.ok()) return c.error();
            time_col_ = *c;
            if (c->index < names_.size()) {
                ns_per = unit_of_column(names_[c->index]);
                if (ns_per) unit_how = "from the column name";
            }
        }
        if (!options_.time_unit.empty()) {
            ns_per = ns_per_unit(lower(options_.time_unit));
            if (!ns_per)
                return make_error("time unit " + in_quotes(options_.time_unit) +
                                  " is not one of s, ms, us, ns");
            unit_how = "as given";
        } else if (options_.time_scale_to_s != 0.0) {
            if (!(options_.time_scale_to_s > 0.0) || !std::isfinite(options_.time_scale_to_s))
                return make_error("time scale " + fmt("%g", options_.time_scale_to_s) +
                                  " is not a positive number of seconds per unit");
            long double s = (long double)options_.time_scale_to_s * 1e9L;
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
        ns_per_ = *ns_per;
        unit_given_ = unit_how == "as given";
        rep_.notes.push_back("time: " + time_col_.label + ", " + unit_name(ns_per_) + " (" +
                             unit_how + ")");
        return {};
    }

    // Source axes -> hmdnode axes (+Y up, -Z forward, +X right).
    Status choose_frame() {
        const std::string frame = lower(options_.source_frame);
        if (frame == "unity" || frame == "left-handed-y-up-z-forward") {
            // Unity, HoloLens, Quest (OpenXR via Unity): left-handed, +Y up, +Z forward, +X
            // right. The reflection M = diag(1, 1, -1) takes its axes to ours: p' = M p and
            // R' = M R M, which for a quaternion (w, x, y, z) is (w, -x, -y, z) (a reflection
            // flips the axis' sign except along the mirror's normal).
            mirror_z_ = true;
            rep_.notes.push_back(
                "axes: source left-handed +Y up, +Z forward, +X right (Unity) mirrored to +Y up, "
                "-Z forward, +X right");
        } else if (frame == "z-up-x-forward") {
            glm::dmat3 m(0.0);  // columns: where the source's x (forward), y (left), z (up) go
            m[0] = glm::dvec3(0, 0, -1);
            m[1] = glm::dvec3(-1, 0, 0);
            m[2] = glm::dvec3(0, 1, 0);
            frame_change_ = glm::quat_cast(m);
            rep_.notes.push_back(
                "axes: source +Z up, +X forward, +Y left converted to +Y up, -Z forward, +X right");
        } else if (frame != "hmdnode") {
            return make_error("source frame " + in_quotes(options_.source_frame) +
                              " is not one of: hmdnode, z-up-x-forward, unity");
        }
        return {};
    }

    Status check_row_options() {
        on_fast_ = lower(options_.on_fast_rotation);
        if (on_fast_ != "report" && on_fast_ != "drop" && on_fast_ != "refuse")
            return make_error("on fast rotation " + in_quotes(options_.on_fast_rotation) +
                              " is not one of: report, drop, refuse");
        if (!(options_.max_angular_speed_deg_s > 0.0))
            return make_error("the angular speed limit must be positive (deg/s)");
        if (!(options_.quat_norm_tolerance > 0.0 && options_.quat_norm_tolerance < 1.0))
            return make_error("the quaternion norm tolerance must be within (0, 1)");
        return {};
    }

    Status choose_orientation_columns() {
        std::string order = lower(options_.quat_order);
        if (order != "wxyz" && order != "xyzw")
            return make_error("quaternion order " + in_quotes(options_.quat_order) +
                              " is not wxyz or xyzw");
        if (!options_.quat_columns.empty() && !options_.euler_columns.empty())
            return make_error("give quaternion columns or Euler columns, not both");
        if (!options_.quat_columns.empty()) {
            auto r =
                resolve_columns(options_.quat_columns, 4, names_, n_fields_, "quaternion", source_);
            if (!r.ok()) return r.error();
            quat_cols_ = *r;
            // Stored as w, x, y, z.
            if (order == "xyzw")
                std::rotate(quat_cols_.begin(), quat_cols_.begin() + 3, quat_cols_.end());
        } else if (!options_.euler_columns.empty()) {
            auto r = resolve_columns(options_.euler_columns, 3, names_, n_fields_, "Euler angles",
                                     source_);
            if (!r.ok()) return r.error();
            euler_cols_ = *r;
        } else {
            for (auto keys : {std::initializer_list<std::string_view>{"qw", "qx", "qy", "qz"},
                              std::initializer_list<std::string_view>{"w", "x", "y", "z"},
                              std::initializer_list<std::string_view>{"quat_w", "quat_x", "quat_y",
                                                                      "quat_z"}}) {
                quat_cols_ = find_named(names_, keys);
                if (!quat_cols_.empty()) break;
            }
            if (quat_cols_.empty()) euler_cols_ = find_named(names_, {"yaw", "pitch", "roll"});
            if (quat_cols_.empty() && euler_cols_.empty())
                return make_error(
                    source_ +
                    ": no orientation columns found (looked for qw,qx,qy,qz / w,x,y,z / "
                    "yaw,pitch,roll); name them with --quat-columns or --euler-columns" +
                    (names_.empty() ? "" : " (columns: " + list_names(names_) + ")"));
        }
        if (!quat_cols_.empty())
            rep_.notes.push_back("orientation: quaternion w,x,y,z from " + labels(quat_cols_));
        else
            rep_.notes.push_back("orientation: Euler yaw, pitch, roll in " +
                                 std::string(options_.euler_degrees ? "degrees" : "radians") +
                                 " from " + labels(euler_cols_) +
                                 " (q = Ry(yaw) * Rx(pitch) * Rz(roll))");
        return {};
    }

    Status choose_position_columns() {
        if (!options_.position_columns.empty()) {
            auto r = resolve_columns(options_.position_columns, 3, names_, n_fields_, "position",
                                     source_);
            if (!r.ok()) return r.error();
            pos_cols_ = *r;
        } else {
            for (auto keys :
                 {std::initializer_list<std::string_view>{"px", "py", "pz"},
                  std::initializer_list<std::string_view>{"pos_x", "pos_y", "pos_z"},
                  std::initializer_list<std::string_view>{"position_x", "position_y", "position_z"},
                  std::initializer_list<std::string_view>{"tx", "ty", "tz"},
                  std::initializer_list<std::string_view>{"x", "y", "z"}}) {
                pos_cols_ = find_named(names_, keys);
                if (pos_cols_.empty()) continue;
                // note: x,y,z are a position only when the quaternion does not use them.
                bool taken = std::any_of(pos_cols_.begin(), pos_cols_.end(), [&](const Column& p) {
                    return std::any_of(quat_cols_.begin(), quat_cols_.end(),
                                       [&](const Column& q) { return q.index == p.index; });
                });
                if (!taken) break;
                pos_cols_.clear();
            }
        }
        if (!pos_cols_.empty()) rep_.notes.push_back("position (metres): " + labels(pos_cols_));
        return {};
    }

    // Each column serves at most one quantity; the others are named as ignored.
    Status claim_columns() {
        std::vector<bool> used(n_fields_, false);
        auto use = [&](const Column& c) -> Status {
            if (used[c.index])
                return make_error(source_ + ": " + c.label +
                                  " is given for two different quantities");
            used[c.index] = true;
            return {};
        };
        for (const std::vector<Column>* group : {&quat_cols_, &euler_cols_, &pos_cols_})
            for (const Column& c : *group)
                if (Status s = use(c); !s.ok()) return s.error();
        if (Status s = use(time_col_); !s.ok()) return s.error();
        std::string ignored;
        for (size_t i = 0; i < n_fields_; ++i)
            if (!used[i]) trace_text::append_item(ignored, column_label(i, names_), ", ");
        if (!ignored.empty()) rep_.notes.push_back("ignored: " + ignored);
        return {};
    }

    // 3. Rows.
    Status read_rows(Trace& trace) {
        size_t last_content = data_at_;
        for (size_t i = data_at_; i < lines_.size(); ++i)
            if (!trace_text::is_blank(lines_[i].text) && !trace_text::is_comment(lines_[i].text))
                last_content = i;

        for (size_t li = data_at_; li < lines_.size(); ++li) {
            const Line& line = lines_[li];
            if (trace_text::is_blank(line.text)) continue;
            if (trace_text::is_comment(line.text)) {
                ++rep_.comment_lines_skipped;
                continue;
            }
            split_fields(line.text, sep_, fields_);
            const bool cut_candidate = li == last_content && li != data_at_;
            if (fields_.size() != n_fields_) {
                if (cut_candidate && fields_.size() < n_fields_) {
                    drop_cut_last_row(line, "it has " + std::to_string(fields_.size()) + " of " +
                                                std::to_string(n_fields_) + " fields");
                    continue;
                }
                return make_error(
                    where(source_, line.number) + "found " + std::to_string(fields_.size()) +
                    " fields, expected " + std::to_string(n_fields_) + " (as in line " +
                    std::to_string(lines_[data_at_].number) + ", the first data row)");
            }
            ++rep_.rows_read;
            if (Status s = read_row(line, trace); !s.ok()) {
                // A last row without a line ending that does not read: the recorder stopped in
                // the middle of one of its fields.
                if (!(cut_candidate && last_unterminated_)) return s;
                --rep_.rows_read;
                std::string why = s.error().message;
                const std::string at = where(source_, line.number);
                if (why.rfind(at, 0) == 0) why.erase(0, at.size());
                drop_cut_last_row(line, "it has no line ending and " + why);
            }
        }
        if (trace.samples.empty()) return make_error(source_ + ": no data rows");
        rep_.samples_written = trace.samples.size();
        if (options_.rebase_time) {
            long double off = std::round(t0_ * ns_per_);
            rep_.time_offset_ns = std::abs(off) < 9.2e18L ? int64_t(off) : 0;
        }
        return {};
    }

    void drop_cut_last_row(const Line& line, const std::string& why) {
        rep_.truncated_last_row_dropped = true;
        const std::string m = where(source_, line.number) +
                              "the last row is cut short (a recording stopped mid-row: " + why +
                              "); dropped";
        rep_.notes.push_back(m);
        rep_.warnings.push_back(m);
    }

    // One row of n_fields_ fields (in fields_): its sample, repaired, appended unless dropped.
    Status read_row(const Line& line, Trace& trace) {
        Result<int64_t> t_ns = read_time(line, trace);
        if (!t_ns.ok()) return t_ns.error();
        glm::dquat q;
        std::optional<double> source_norm;  // set when counted as normalised
        if (Status s = read_orientation(line, q, source_norm); !s.ok()) return s;
        std::optional<glm::dvec3> pos;
        if (Status s = read_position(line, pos); !s.ok()) return s;
        if (frame_change_) {
            // Same change of basis on the world and the head frame: q' = C q C^-1, p' = C p.
            q = glm::normalize(*frame_change_ * q * glm::conjugate(*frame_change_));
            if (pos) *pos = *frame_change_ * *pos;
        }
        if (mirror_z_) {
            q = glm::dquat(q.w, -q.x, -q.y, q.z);
            if (pos) pos->z = -pos->z;
        }

        if (!trace.samples.empty()) {
            Result<Step> step = repair_against_previous(line, trace.samples.back(), *t_ns, q, pos);
            if (!step.ok()) return step.error();
            if (*step == Step::drop) return {};
        }
        if (source_norm) {
            ++rep_.non_unit_normalized;
            if (std::abs(*source_norm - 1.0) > std::abs(worst_norm_ - 1.0))
                worst_norm_ = *source_norm;
        }
        TraceSample s;
        s.time_ns = *t_ns;
        s.orientation = q;
        s.position = pos;
        trace.samples.push_back(s);
        prev_line_ = line.number;
        prev_time_text_ = std::string(fields_[time_col_.index]);
        return {};
    }

    Error field_error(const Line& line, const Column& c, const std::string& what) const {
        return make_error(where(source_, line.number) + c.label + ": " + what + " " +
                          in_quotes(fields_[c.index]));
    }

    Result<double> number(const Line& line, const Column& c) const {
        std::optional<double> v = trace_text::parse_double(fields_[c.index]);
        if (!v) return field_error(line, c, "not a number:");
        if (!std::isfinite(*v)) return field_error(line, c, "not a finite number:");
        return *v;
    }

    // Time.
    Result<int64_t> read_time(const Line& line, const Trace& trace) {
        std::optional<long double> t = trace_text::parse_long_double(fields_[time_col_.index]);
        if (!t) return field_error(line, time_col_, "not a number:");
        if (!std::isfinite(*t)) return field_error(line, time_col_, "not a finite number:");
        if (trace.samples.empty() && rep_.rows_read == 1) {
            t0_ = options_.rebase_time ? *t : 0.0L;
            t0_text_ = std::string(fields_[time_col_.index]);
        }
        long double ns_ld = std::round((*t - t0_) * ns_per_);
        if (!(std::abs(ns_ld) < 9.2e18L))
            return field_error(line, time_col_, "time out of range for int64 nanoseconds:");
        return int64_t(ns_ld);
    }

    // Orientation.
    Status read_orientation(const Line& line, glm::dquat& q, std::optional<double>& source_norm) {
        if (!quat_cols_.empty()) {
            double c[4];
            for (int k = 0; k < 4; ++k) {
                Result<double> v = number(line, quat_cols_[size_t(k)]);
                if (!v.ok()) return v.error();
                c[k] = *v;
            }
            q = glm::dquat(c[0], c[1], c[2], c[3]);
            double norm = std::sqrt(glm::dot(q, q));
            if (!(std::abs(norm - 1.0) <= options_.quat_norm_tolerance))
                return make_error(where(source_, line.number) + labels(quat_cols_) +
                                  ": quaternion norm " + fmt("%.6g", norm) +
                                  (norm == 0.0 ? " (a zero quaternion is no rotation)"
                                               : " is far from 1 (off by more than " +
                                                     fmt("%g", options_.quat_norm_tolerance) +
                                                     "): are the quaternion columns and their "
                                                     "order right?"));
            if (std::abs(norm - 1.0) > kNormCountTolerance) source_norm = norm;
            // note: norms within 1e-12 of 1 keep the source's bits (as the trace reader does).
            if (std::abs(norm - 1.0) > 1e-12) q /= norm;
        } else {
            const bool euler_degrees = options_.euler_degrees;
            double a[3];
            for (int k = 0; k < 3; ++k) {
                Result<double> v = number(line, euler_cols_[size_t(k)]);
                if (!v.ok()) return v.error();
                if (!euler_degrees && std::abs(*v) > 2.0 * kPi + 1e-9)
                    return field_error(line, euler_cols_[size_t(k)],
                                       "an angle beyond 2 pi with --euler-radians (degrees? drop "
                                       "--euler-radians):");
                a[k] = euler_degrees ? deg_to_rad(*v) : *v;
            }
            q = quat_from_yaw_pitch_roll(a[0], a[1], a[2]);
        }
        return {};
    }

    Status read_position(const Line& line, std::optional<glm::dvec3>& pos) const {
        if (pos_cols_.empty()) return {};
        double p[3];
        for (int k = 0; k < 3; ++k) {
            Result<double> v = number(line, pos_cols_[size_t(k)]);
            if (!v.ok()) return v.error();
            p[k] = *v;
        }
        pos = glm::dvec3(p[0], p[1], p[2]);
        return {};
    }

    // Repairs against the previous kept sample.
    Result<Step> repair_against_previous(const Line& line, const TraceSample& prev, int64_t t_ns,
                                         glm::dquat& q, const std::optional<glm::dvec3>& pos) {
        const std::string time_text(fields_[time_col_.index]);
        if (t_ns < prev.time_ns)
            return make_error(where(source_, line.number) + time_col_.label +
                              ": time goes backwards: " + time_text + " after " + prev_time_text_ +
                              " (line " + std::to_string(prev_line_) +
                              "); the importer does not reorder rows");
        if (t_ns == prev.time_ns) {
            ++rep_.duplicate_times_dropped;
            bool differs = angle_between_rad(q, prev.orientation) > kConflictAngleRad ||
                           (pos && prev.position && *pos != *prev.position);
            if (differs) ++rep_.duplicate_times_conflicting;
            return Step::drop;
        }
        if (glm::dot(q, prev.orientation) < 0.0) {
            q = -q;
            ++rep_.sign_flips_fixed;
        }
        // Angular speed of this step: a jump no head makes (a wrong order, a glitch).
        const double speed =
            rad_to_deg(angle_between_rad(q, prev.orientation)) / ns_to_s(t_ns - prev.time_ns);
        max_speed_seen_ = std::max(max_speed_seen_, speed);
        if (speed > options_.max_angular_speed_deg_s) {
            ++rep_.fast_rotations;
            if (on_fast_ == "refuse")
                return make_error(where(source_, line.number) + "the orientation turns " +
                                  fmt("%.0f", speed) + " deg/s since line " +
                                  std::to_string(prev_line_) + ", above the limit of " +
                                  fmt("%g", options_.max_angular_speed_deg_s) +
                                  " deg/s (a wrong quaternion order, or a tracking glitch)");
            if (on_fast_ == "drop") {
                ++rep_.fast_rotations_dropped;
                return Step::drop;
            }
        }
        rep_.max_angular_speed_deg_s = std::max(rep_.max_angular_speed_deg_s, speed);
        if (q == prev.orientation) ++rep_.repeated_orientations;
        int64_t gap = t_ns - prev.time_ns;
        if (gap > kGapReportNs) ++rep_.gaps_over_100ms;
        rep_.longest_gap_ns = std::max(rep_.longest_gap_ns, gap);
        return Step::keep;
    }

    // 4. The account.
    void add_account_notes() {
        auto count = [](size_t n, const char* one, const char* many) {
            return std::to_string(n) + " " + (n == 1 ? one : many);
        };
        if (options_.rebase_time)
            rep_.notes.push_back("time rebased: the first row (source time " + t0_text_ +
                                 ") is at 0 ns");
        if (rep_.sign_flips_fixed)
            rep_.notes.push_back(count(rep_.sign_flips_fixed, "sign flip", "sign flips") +
                                 " made continuous (q -> -q, the same rotation)");
        if (rep_.duplicate_times_dropped)
            rep_.notes.push_back(
                count(rep_.duplicate_times_dropped, "row", "rows") +
                " with a repeated time dropped (the first row at each time is kept); " +
                std::to_string(rep_.duplicate_times_conflicting) + " of them had a different pose");
        if (rep_.non_unit_normalized)
            rep_.notes.push_back(count(rep_.non_unit_normalized, "quaternion", "quaternions") +
                                 " normalised (norm off by more than 1e-6; furthest " +
                                 fmt("%.6g", worst_norm_) + ")");
        if (rep_.gaps_over_100ms)
            rep_.notes.push_back(count(rep_.gaps_over_100ms, "gap", "gaps") +
                                 " over 100 ms kept (longest " +
                                 fmt("%.1f", ns_to_ms(rep_.longest_gap_ns)) +
                                 " ms); replay interpolates across them");
        if (rep_.repeated_orientations)
            rep_.notes.push_back(
                count(rep_.repeated_orientations, "sample repeats", "samples repeat") +
                " the previous orientation at a new time (kept)");
        if (rep_.comment_lines_skipped)
            rep_.notes.push_back(
                count(rep_.comment_lines_skipped, "comment line", "comment lines") +
                " among the rows skipped");
        if (rep_.fast_rotations)
            rep_.notes.push_back(count(rep_.fast_rotations, "step turns", "steps turn") +
                                 " faster than " + fmt("%g", options_.max_angular_speed_deg_s) +
                                 " deg/s" +
                                 (rep_.fast_rotations_dropped ? ": dropped" : ": kept (reported)"));
    }

    // A rate above 2 kHz (a head tracker logs at 1 kHz at most) with steps above the angular speed
    // limit: a wrong time unit, the result merely implausible (a 60 Hz log in 100 ns ticks read as
    // ns: 6 kHz and 100 times the speed). Refused, naming the units that give a plausible rate
    // (10 Hz..2 kHz) and speed; a warning instead when the unit was given (--time-unit,
    // --time-scale). A rate above 2 kHz alone is a warning.
    Status check_rate_and_speed(const TraceStats& st) {
        constexpr double kMaxRateHz = 2000.0, kMinRateHz = 10.0;
        const double rate = 1e9 / double(st.median_interval_ns);
        if (!(rate > kMaxRateHz)) return {};
        const double limit = options_.max_angular_speed_deg_s;
        const bool fast_turns = max_speed_seen_ > limit;
        std::string likely;
        for (const auto& [name, per] : kTimeUnitChoices) {
            const double f = double(per / ns_per_);
            if (per == ns_per_ || !(rate / f >= kMinRateHz && rate / f <= kMaxRateHz) ||
                !(max_speed_seen_ / f <= limit))
                continue;
            likely += std::string(likely.empty() ? "" : "; ") + "with " + name + ": " +
                      fmt("%.4g Hz", rate / f) + ", the fastest step " +
                      fmt("%.0f deg/s", max_speed_seen_ / f);
        }
        const std::string what = source_ + ": " + time_col_.label + " read as " +
                                 unit_name(ns_per_) + " gives a median rate of " +
                                 fmt("%.4g Hz", rate) + " (above the 2 kHz a head tracker logs at)";
        if (!fast_turns) {
            rep_.warnings.push_back(what + ": check the time unit" +
                                    (likely.empty() ? "" : " (" + likely + ")"));
            return {};
        }
        const std::string m =
            what + " and steps up to " + fmt("%.0f deg/s", max_speed_seen_) + " (" +
            std::to_string(rep_.fast_rotations) + " above " + fmt("%g", limit) +
            " deg/s): both implausible, the time unit is likely wrong" +
            (likely.empty() ? std::string("; check the time unit") : "; " + likely);
        if (unit_given_) {
            rep_.warnings.push_back(m + " (kept: the unit was given)");
            return {};
        }
        return make_error(m + "; give the unit with --time-unit or --time-scale");
    }

    // A median interval or a duration no head tracker has: an error naming the likely time unit.
    Status check_time_plausible(const Trace& trace) {
        if (trace.samples.size() < 2) return {};
        TraceStats st = compute_trace_stats(trace);
        const int64_t duration = trace.samples.back().time_ns - trace.samples.front().time_ns;
        if (st.median_interval_ns < kMinMedianIntervalNs ||
            st.median_interval_ns > kMaxMedianIntervalNs || duration > kMaxDurationNs) {
            // The unit under which the median interval would be that of a head tracker (~1 kHz
            // to ~10 Hz), among the usual ones.
            const long double median_units = (long double)(st.median_interval_ns) / ns_per_;
            std::string likely;
            for (const auto& [name, per] : kTimeUnitChoices) {
                const long double m = median_units * per;
                if (per != ns_per_ && m >= 5e5L && m <= 1e8L) {
                    likely = std::string("; with ") + name + " the median interval would be " +
                             fmt("%.3g", double(m) * 1e-6) + " ms";
                    break;
                }
            }
            return make_error(
                source_ + ": " + time_col_.label + " read as " + unit_name(ns_per_) +
                " gives a median interval of " + fmt("%.6g", ns_to_s(st.median_interval_ns)) +
                " s over " + fmt("%.6g", ns_to_s(duration)) +
                " s, implausible for a head tracker (median 10 us to 10 s, at most a day)" +
                (likely.empty() ? std::string("; check the time unit") : likely));
        }
        if (Status s = check_rate_and_speed(st); !s.ok()) return s;
        if (st.median_interval_ns < 100 * kNsPerUs || st.median_interval_ns > kNsPerSecond)
            rep_.notes.push_back("the median interval " +
                                 fmt("%.6g", ns_to_s(st.median_interval_ns)) +
                                 " s is implausible for a head tracker: check the time unit");
        return {};
    }

    void add_trace_comments(Trace& trace) const {
        std::string src_name = std::filesystem::path(source_).filename().string();
        trace.comments.push_back("imported from " + src_name + " by hmdnode trace import");
        trace.comments.push_back(
            "time: source " + time_col_.label + " in " + unit_name(ns_per_) +
            (options_.rebase_time ? ", rebased to 0 at source time " + t0_text_ : ""));
        // What time 0 is (docs/trace-format.md): `hmdnode tracking eval` refuses two traces
        // whose time bases differ.
        trace.comments.push_back(options_.rebase_time
                                     ? "time_base first_sample import " + src_name +
                                           " (0 = its first row)"
                                     : "time_base source " + src_name + " " + time_col_.label +
                                           " (" + unit_name(ns_per_) + ")");
        trace.comments.push_back(
            "fixes: " + std::to_string(rep_.sign_flips_fixed) + " sign flips, " +
            std::to_string(rep_.duplicate_times_dropped) + " repeated times dropped, " +
            std::to_string(rep_.non_unit_normalized) + " quaternions normalised, " +
            std::to_string(rep_.gaps_over_100ms) + " gaps over 100 ms kept");
    }

    const std::vector<Line>& lines_;
    bool last_unterminated_;  // the text does not end in a line ending
    const std::string& source_;
    const TraceImportOptions& options_;
    TraceImportReport& rep_;
    std::vector<std::string_view> fields_;  // of the line at hand

    // Step 1.
    Separator sep_;
    size_t data_at_ = 0;  // index into lines_ of the first data row
    size_t n_fields_ = 0;
    std::vector<ColumnName> names_;
    // Step 2.
    Column time_col_;
    long double ns_per_ = 1e9L;
    bool unit_given_ = false;  // --time-unit or --time-scale
    std::optional<glm::dquat> frame_change_;
    bool mirror_z_ = false;  // a left-handed source: the reflection z -> -z
    std::string on_fast_;
    std::vector<Column> quat_cols_, euler_cols_, pos_cols_;
    // Step 3.
    long double t0_ = 0.0L;
    std::string t0_text_;
    size_t prev_line_ = 0;
    std::string prev_time_text_;
    double worst_norm_ = 1.0;
    double max_speed_seen_ = 0.0;  // deg/s, the fastest step, kept or dropped
};

}  // namespace

Result<Trace> import_trace_text(const std::string& text, const std::string& source,
                                const TraceImportOptions& options, TraceImportReport* out_report) {
    TraceImportReport local;
    TraceImportReport& rep = out_report ? *out_report : local;
    rep = TraceImportReport{};
    const std::vector<Line> lines = trace_text::split_lines(text);
    const bool unterminated = !text.empty() && text.back() != '\n';
    return TableImporter(lines, unterminated, source, options, rep).run();
}

Result<Trace> import_trace_table(const std::filesystem::path& path,
                                 const TraceImportOptions& options, TraceImportReport* out_report) {
    if (out_report) *out_report = TraceImportReport{};
    Result<std::string> text = read_file(path);
    if (!text.ok()) return text.error();
    return import_trace_text(*text, path.string(), options, out_report);
}

}  // namespace hmdnode
