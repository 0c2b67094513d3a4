// Tracker traces: the project's CSV format (docs/trace-format.md) and the importer that maps other
// tables onto it. Reading, writing and importing are pure functions of their input (no globals);
// any thread may call them. Times are int64 ns on the trace's own timeline.
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

// An eye tracker's gaze at a sample (optional group of the trace format, v2): the cyclopean gaze
// direction in the head frame (unit; (0,0,-1) is the lens centre, head forward) and a confidence in
// [0, 1], 0 meaning no gaze (a blink, track lost: the direction is then not used).
struct TraceGaze {
    glm::dvec3 direction{0, 0, -1};
    double confidence = 1.0;
    bool valid() const { return confidence > 0.0; }
};

struct TraceSample {
    int64_t time_ns = 0;                 // strictly increasing within a trace
    glm::dquat orientation{1, 0, 0, 0};  // unit, head-to-world, same hemisphere as previous
    std::optional<glm::dvec3> position;  // metres
    std::optional<glm::dvec3> gyro;      // rad/s, head frame
    std::optional<glm::dvec3> accel;     // m/s^2, head frame
    std::optional<TraceGaze> gaze;       // eye tracker, head frame
};

struct Trace {
    std::vector<TraceSample> samples;
    std::vector<std::string> comments;  // '#' lines (without '#'), kept in order

    int64_t start_ns() const { return samples.empty() ? 0 : samples.front().time_ns; }
    int64_t end_ns() const { return samples.empty() ? 0 : samples.back().time_ns; }
    // The true pose at t_ns: slerp between the neighbouring samples (binary search), position
    // lerped when present (else 0), clamped to the end samples outside [start_ns, end_ns].
    // Velocities: inside the trace, angular from the gyro when both neighbours have one (rotated to
    // world) else from the two neighbouring orientations, linear from the neighbouring positions
    // (none without positions); outside it, zero (the pose is held). Requires a non-empty trace.
    Pose pose_at(int64_t t_ns) const;
};

// Reads the project's trace CSV. Errors name the file, line and column.
Result<Trace> read_trace_csv(const std::filesystem::path& path);
// Parses trace CSV text; `source` names it in errors.
Result<Trace> parse_trace_csv(const std::string& text, const std::string& source);
// The trace CSV text write_trace_csv writes; an error when the trace could not be read back
// (no samples, time not strictly increasing, a non-finite value, a quaternion norm outside
// [0.9, 1.1], an optional group present in some samples only, a comment with a line break).
Result<std::string> format_trace_csv(const Trace& trace);
// Writes the project's trace CSV atomically (temporary file, then rename).
Status write_trace_csv(const Trace& trace, const std::filesystem::path& path);

// Figures of a trace for people (`hmdnode trace info`, the import summary).
struct TraceStats {
    size_t samples = 0;
    int64_t duration_ns = 0;           // end - start
    int64_t median_interval_ns = 0;    // median time between consecutive samples
    double median_rate_hz = 0.0;       // 1 / median interval
    int64_t longest_gap_ns = 0;        // longest time between consecutive samples
    int64_t longest_gap_start_ns = 0;  // time of the sample before it
    size_t gaps_over_100ms = 0;
    double max_angular_speed_deg_s = 0.0;  // over consecutive samples (angle / dt)
    int64_t max_angular_speed_at_ns = 0;   // time of the first sample of that pair
    bool has_position = false;
    bool has_imu = false;  // gyro and/or accel present
    // Gaze (traces with the gaze group): the share of samples with a valid gaze, and the
    // percentiles of the valid gazes' eccentricity (angle from the head forward, -Z), degrees.
    bool has_gaze = false;
    double gaze_valid_fraction = 0.0;
    double gaze_eccentricity_p50_deg = 0.0;
    double gaze_eccentricity_p90_deg = 0.0;
    double gaze_within_20deg_fraction = 0.0;  // of the valid gazes
};
TraceStats compute_trace_stats(const Trace& trace);

// How to read a foreign table.
struct TraceImportOptions {
    std::string separator = "auto";    // "auto" (comma, tab, semicolon or whitespace), or the char
    std::string time_column = "auto";  // name or 0-based index; "auto" guesses (time, timestamp, t)
    double time_scale_to_s = 0.0;      // seconds per unit of the time column; 0 = guess from name
    std::string time_unit;             // "s", "ms", "us", "ns" (overrides time_scale_to_s)
    std::vector<std::string> quat_columns;   // 4 names/indices, in the order given by quat_order
    std::string quat_order = "wxyz";         // "wxyz" or "xyzw"
    std::vector<std::string> euler_columns;  // yaw, pitch, roll (instead of a quaternion)
    bool euler_degrees = true;
    std::vector<std::string> position_columns;  // 3 names/indices, optional
    int header_lines = -1;    // lines to skip before the column-name line; -1 = detect
    bool rebase_time = true;  // shift time so the first sample is at 0 ns (else keep the source's)
    // Axes of the source's world and head frames: "hmdnode" (+Y up, -Z forward, +X right) or
    // "z-up-x-forward" (+Z up, +X forward, +Y left: ROS REP-103, and the Corbillon 2018 360-degree
    // video traces). Orientations and positions are converted to hmdnode's axes.
    std::string source_frame = "hmdnode";
    // Rows whose quaternion norm is off 1 by more than this are an error (wrong columns or data);
    // within it they are normalised.
    double quat_norm_tolerance = 0.01;
    // Angular speed between consecutive samples above this (deg/s) is reported; with
    // on_fast_rotation "drop" such a sample is dropped, with "refuse" it is an error.
    double max_angular_speed_deg_s = 1500.0;
    std::string on_fast_rotation = "report";  // "report", "drop" or "refuse"
};

// What the importer did to make the samples valid (each counted, for the tool to print).
struct TraceImportReport {
    size_t rows_read = 0;
    size_t samples_written = 0;
    size_t sign_flips_fixed = 0;  // q replaced by -q to stay in the previous hemisphere
    size_t duplicate_times_dropped = 0;
    size_t non_unit_normalized = 0;
    size_t gaps_over_100ms = 0;  // kept, reported
    int64_t longest_gap_ns = 0;
    size_t header_lines_skipped = 0;
    std::vector<std::string> notes;  // human-readable account of the above
    // What may be wrong with the result (printed as warnings): a cut last row dropped, a time unit
    // given explicitly that gives an implausible rate and rotation speed, a rate above 2 kHz.
    std::vector<std::string> warnings;

    std::string separator;                   // the one used: "comma", "tab", "semicolon", ...
    size_t duplicate_times_conflicting = 0;  // of the dropped duplicates, those whose pose differed
    size_t repeated_orientations = 0;        // identical to the previous sample (kept: new time)
    size_t comment_lines_skipped = 0;        // '#' lines after the data began
    bool truncated_last_row_dropped = false;  // the last row was cut short (too few fields, or no
                                              // line ending and a field that does not read)
    int64_t time_offset_ns = 0;               // source time of the first sample (subtracted when
                                              // rebasing; 0 when not rebased)
    size_t fast_rotations = 0;          // steps above max_angular_speed_deg_s (reported or dropped)
    size_t fast_rotations_dropped = 0;  // of those, dropped (on_fast_rotation "drop")
    double max_angular_speed_deg_s = 0.0;  // the fastest step kept, deg/s
};

// Imports a foreign table (docs/trace-format.md, section 2). On failure no partial trace is
// returned and out_report (may be null) holds what was learnt before the error.
Result<Trace> import_trace_table(const std::filesystem::path& path,
                                 const TraceImportOptions& options, TraceImportReport* out_report);
// The same on text already in memory; `source` names it in errors.
Result<Trace> import_trace_text(const std::string& text, const std::string& source,
                                const TraceImportOptions& options, TraceImportReport* out_report);

}  // namespace hmdnode
