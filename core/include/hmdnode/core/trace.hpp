// Tracker traces: the project's CSV format (docs/formats.md#trace) and importers that map other
// tables onto it.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

#include "hmdnode/core/pose.hpp"
#include "hmdnode/core/result.hpp"

namespace hmdnode {

struct TraceSample {
    int64_t time_ns = 0;                      // strictly increasing within a trace
    glm::dquat orientation{1, 0, 0, 0};       // unit, head-to-world, same hemisphere as previous
    std::optional<glm::dvec3> position;       // metres
    std::optional<glm::dvec3> gyro;           // rad/s, head frame
    std::optional<glm::dvec3> accel;          // m/s^2, head frame
};

struct Trace {
    std::vector<TraceSample> samples;
    std::vector<std::string> comments;  // '#' lines (without '#'), kept in order

    int64_t start_ns() const { return samples.empty() ? 0 : samples.front().time_ns; }
    int64_t end_ns() const { return samples.empty() ? 0 : samples.back().time_ns; }
    // The true pose at t_ns: slerp between the neighbouring samples, clamped at the ends.
    Pose pose_at(int64_t t_ns) const;
};

// Reads the project's trace CSV. Errors name the file, line and column.
Result<Trace> read_trace_csv(const std::filesystem::path& path);
// Parses trace CSV text; `source` names it in errors.
Result<Trace> parse_trace_csv(const std::string& text, const std::string& source);
// Writes the project's trace CSV atomically (temporary file, then rename).
Status write_trace_csv(const Trace& trace, const std::filesystem::path& path);

// How to read a foreign table.
struct TraceImportOptions {
    std::string separator = "auto";      // "auto" (comma, tab, semicolon or whitespace), or the char
    std::string time_column = "auto";    // name or 0-based index; "auto" guesses (time, timestamp, t)
    double time_scale_to_s = 0.0;        // seconds per unit of the time column; 0 = guess from name
    std::string time_unit;               // "s", "ms", "us", "ns" (overrides time_scale_to_s)
    std::vector<std::string> quat_columns;   // 4 names/indices, in the order given by quat_order
    std::string quat_order = "wxyz";         // "wxyz" or "xyzw"
    std::vector<std::string> euler_columns;  // yaw, pitch, roll (instead of a quaternion)
    bool euler_degrees = true;
    std::vector<std::string> position_columns;  // 3 names/indices, optional
    int header_lines = -1;  // lines to skip before the column-name line; -1 = detect
};

// What the importer did to make the samples valid (each counted, for the tool to print).
struct TraceImportReport {
    size_t rows_read = 0;
    size_t samples_written = 0;
    size_t sign_flips_fixed = 0;      // q replaced by -q to stay in the previous hemisphere
    size_t duplicate_times_dropped = 0;
    size_t non_unit_normalized = 0;
    size_t gaps_over_100ms = 0;       // kept, reported
    int64_t longest_gap_ns = 0;
    size_t header_lines_skipped = 0;
    std::vector<std::string> notes;   // human-readable account of the above
};

Result<Trace> import_trace_table(const std::filesystem::path& path, const TraceImportOptions& options,
                                 TraceImportReport* out_report);

}  // namespace hmdnode
