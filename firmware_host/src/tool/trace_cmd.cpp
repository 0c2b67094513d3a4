// `hmdnode trace import` (foreign table -> trace CSV, saying every repair), `hmdnode trace info`
// (figures of a trace) and `hmdnode trace add-gaze` (synthetic gaze columns from a documented
// model, core/src/synthetic_gaze.cpp). Formats: docs/trace-format.md.
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "hmdnode/core/synthetic_gaze.hpp"
#include "hmdnode/core/time.hpp"
#include "hmdnode/core/trace.hpp"
#include "tool/cli_errors.hpp"
#include "tool/commands.hpp"

namespace hmdnode::tool {
namespace {

const CliErrors import_errors{"trace import"};
const CliErrors info_errors{"trace info"};
const CliErrors add_gaze_errors{"trace add-gaze"};

struct ImportArgs {
    std::string from;
    std::string to;
    TraceImportOptions options;
    bool keep_time = false;
    bool euler_radians = false;
};

void print_row(const char* label, const std::string& value) {
    std::printf("  %-24s %s\n", label, value.c_str());
}

std::string fmt(const char* format, double v) {
    char buf[64];
    std::snprintf(buf, sizeof buf, format, v);
    return buf;
}

// The gaze figures of a trace (`info`, `add-gaze`).
void print_gaze_rows(const TraceStats& st) {
    if (!st.has_gaze) return print_row("gaze", "no");
    print_row("gaze valid", fmt("%.1f %% of samples", 100.0 * st.gaze_valid_fraction));
    print_row("gaze eccentricity",
              fmt("p50 %.1f deg", st.gaze_eccentricity_p50_deg) +
                  fmt(", p90 %.1f deg", st.gaze_eccentricity_p90_deg) +
                  fmt(", %.1f %% within 20 deg", 100.0 * st.gaze_within_20deg_fraction));
}

void run_import(const ImportArgs& args) {
    if (!import_errors.check_outputs({{"--to", args.to}})) return;
    TraceImportOptions options = args.options;
    options.rebase_time = !args.keep_time;
    options.euler_degrees = !args.euler_radians;
    TraceImportReport report;
    Result<Trace> trace = import_trace_table(args.from, options, &report);
    if (!trace.ok()) {
        import_errors.fail(trace.error().message);
        return import_errors.fail("nothing written to " + args.to);
    }
    Status written = write_trace_csv(*trace, args.to);
    if (!written.ok()) return import_errors.fail(written.error().message);
    for (const std::string& w : report.warnings) import_errors.warning(w);
    const TraceStats st = compute_trace_stats(*trace);
    std::printf("imported %s -> %s\n", args.from.c_str(), args.to.c_str());
    print_row("rows read", std::to_string(report.rows_read));
    print_row("samples written", std::to_string(report.samples_written));
    print_row("header lines skipped", std::to_string(report.header_lines_skipped));
    print_row("sign flips fixed", std::to_string(report.sign_flips_fixed));
    print_row("repeated times dropped", std::to_string(report.duplicate_times_dropped) + " (" +
                                            std::to_string(report.duplicate_times_conflicting) +
                                            " with a different pose)");
    print_row("quaternions normalised", std::to_string(report.non_unit_normalized));
    print_row("fast rotations", std::to_string(report.fast_rotations) + " (" +
                                    std::to_string(report.fast_rotations_dropped) +
                                    " dropped; fastest step kept " +
                                    fmt("%.0f", report.max_angular_speed_deg_s) + " deg/s)");
    print_row("gaps over 100 ms (kept)", std::to_string(report.gaps_over_100ms) + " (longest " +
                                             fmt("%.1f", ns_to_ms(report.longest_gap_ns)) + " ms)");
    print_row("repeated orientations", std::to_string(report.repeated_orientations) + " (kept)");
    if (report.comment_lines_skipped)
        print_row("comment lines skipped", std::to_string(report.comment_lines_skipped));
    if (report.truncated_last_row_dropped) print_row("truncated last row", "dropped");
    print_row("duration", fmt("%.3f s", ns_to_s(st.duration_ns)));
    print_row("median rate", fmt("%.2f Hz", st.median_rate_hz));
    std::printf("notes:\n");
    for (const std::string& n : report.notes) std::printf("  %s\n", n.c_str());
}

void run_info(const std::string& file) {
    Result<Trace> trace = read_trace_csv(file);
    if (!trace.ok()) return info_errors.fail(trace.error().message);
    const TraceStats st = compute_trace_stats(*trace);
    const double t0_s = ns_to_s(trace->start_ns());
    std::printf("%s\n", file.c_str());
    print_row("samples", std::to_string(st.samples));
    print_row("duration", fmt("%.3f s", ns_to_s(st.duration_ns)));
    print_row("median rate", fmt("%.2f Hz", st.median_rate_hz) +
                                 fmt(" (interval %.3f ms)", ns_to_ms(st.median_interval_ns)));
    print_row("longest gap", fmt("%.1f ms", ns_to_ms(st.longest_gap_ns)) +
                                 fmt(" at %.3f s", ns_to_s(st.longest_gap_start_ns) - t0_s));
    print_row("gaps over 100 ms", std::to_string(st.gaps_over_100ms));
    print_row("max angular speed",
              fmt("%.1f deg/s", st.max_angular_speed_deg_s) +
                  fmt(" at %.3f s", ns_to_s(st.max_angular_speed_at_ns) - t0_s));
    print_row("position", st.has_position ? "yes" : "no");
    print_row("gyro/accel", st.has_imu ? "yes" : "no");
    print_gaze_rows(st);
    for (const std::string& c : trace->comments) std::printf("  # %s\n", c.c_str());
}

struct AddGazeArgs {
    std::string in, out;
    SyntheticGazeParams params;
};

void run_add_gaze(const AddGazeArgs& args) {
    if (!add_gaze_errors.check_outputs({{"--out", args.out}})) return;
    Result<Trace> head = read_trace_csv(args.in);
    if (!head.ok()) return add_gaze_errors.fail(head.error().message);
    Result<SyntheticGaze> g = synthesize_gaze(*head, args.params);
    if (!g.ok()) return add_gaze_errors.fail(args.in + ": " + g.error().message);
    g->trace.comments.insert(g->trace.comments.end() - 1,
                             "gaze added to " + std::filesystem::path(args.in).filename().string() +
                                 " by hmdnode trace add-gaze");
    if (Status st = write_trace_csv(g->trace, args.out); !st.ok())
        return add_gaze_errors.fail(st.error().message);
    const TraceStats st = compute_trace_stats(g->trace);
    std::printf("wrote %s: %zu samples with SYNTHETIC gaze (seed %llu), %zu saccades, %zu blinks\n",
                args.out.c_str(), st.samples, static_cast<unsigned long long>(args.params.seed),
                g->saccades.size(), g->blinks);
    print_gaze_rows(st);
}

}  // namespace

void add_trace_command(CLI::App& app) {
    CLI::App* trace = app.add_subcommand("trace", "Import and inspect head-tracker traces");
    trace->require_subcommand(1);

    auto args = std::make_shared<ImportArgs>();
    CLI::App* imp = trace->add_subcommand(
        "import", "Map a foreign table (CSV, TSV, whitespace) onto the hmdnode trace format");
    imp->add_option("--from", args->from, "Input table")->required();
    imp->add_option("--to", args->to, "Output trace CSV (written only on success)")->required();
    imp->add_option("--separator", args->options.separator,
                    "auto, comma, tab, semicolon, whitespace or one character")
        ->capture_default_str();
    imp->add_option("--time-column", args->options.time_column, "Name or 0-based index, or auto")
        ->capture_default_str();
    imp->add_option("--time-unit", args->options.time_unit, "s, ms, us or ns")
        ->check(CLI::IsMember({"s", "ms", "us", "ns"}));
    imp->add_option("--time-scale", args->options.time_scale_to_s,
                    "Seconds per unit of the time column (e.g. 1e-7 for 100 ns ticks)");
    imp->add_option("--quat-columns", args->options.quat_columns,
                    "Four quaternion columns (names or indices) in --quat-order")
        ->delimiter(',');
    imp->add_option("--quat-order", args->options.quat_order, "wxyz or xyzw")
        ->check(CLI::IsMember({"wxyz", "xyzw"}))
        ->capture_default_str();
    imp->add_option("--source-frame", args->options.source_frame,
                    "Axes of the source: hmdnode (+Y up, -Z forward), z-up-x-forward "
                    "(+Z up, +X forward, +Y left; the Corbillon 2018 traces) or unity "
                    "(left-handed +Y up, +Z forward, +X right: Unity, HoloLens, Quest)")
        ->check(CLI::IsMember({"hmdnode", "z-up-x-forward", "unity"}))
        ->capture_default_str();
    imp->add_option("--quat-norm-tolerance", args->options.quat_norm_tolerance,
                    "A quaternion norm off 1 by more than this is an error")
        ->capture_default_str();
    imp->add_option("--max-angular-speed", args->options.max_angular_speed_deg_s,
                    "Steps turning faster than this (deg/s) are reported, dropped or refused")
        ->capture_default_str();
    imp->add_option("--on-fast-rotation", args->options.on_fast_rotation,
                    "What a step above --max-angular-speed does: report, drop or refuse")
        ->check(CLI::IsMember({"report", "drop", "refuse"}))
        ->capture_default_str();
    imp->add_option("--euler-columns", args->options.euler_columns,
                    "Yaw, pitch, roll columns: q = Ry(yaw) Rx(pitch) Rz(roll), degrees")
        ->delimiter(',');
    imp->add_flag("--euler-radians", args->euler_radians, "Euler angles are in radians");
    imp->add_option("--position-columns", args->options.position_columns,
                    "Three position columns (metres)")
        ->delimiter(',');
    imp->add_option("--header-lines", args->options.header_lines,
                    "Lines before the column-name line (default: detect)");
    imp->add_flag("--keep-time", args->keep_time,
                  "Keep the source's time origin instead of starting at 0 ns");
    imp->callback([args] { run_import(*args); });

    auto file = std::make_shared<std::string>();
    CLI::App* info = trace->add_subcommand("info", "Print the figures of a trace CSV");
    info->add_option("file", *file, "Trace CSV")->required();
    info->callback([file] { run_info(*file); });

    auto gaze = std::make_shared<AddGazeArgs>();
    CLI::App* add = trace->add_subcommand(
        "add-gaze",
        "Add SYNTHETIC gaze columns to a head trace (fixations, main-sequence saccades, the eye "
        "leading the head, blinks; docs/trace-format.md): for testing, not a measurement");
    add->add_option("--in", gaze->in, "Head trace CSV")->required();
    add->add_option("--out", gaze->out, "Output trace CSV (written only on success)")->required();
    add->add_option("--seed", gaze->params.seed, "Seed (the same seed gives the same gaze)")
        ->capture_default_str();
    add->add_option("--rate", gaze->params.rate_hz,
                    "Resample the head trace at this rate (Hz, at most 4000; 0: its own samples; "
                    "gyro/accel are dropped when resampling)")
        ->check(CLI::Range(0.0, 4000.0))
        ->capture_default_str();
    add->callback([gaze] { run_add_gaze(*gaze); });
}

}  // namespace hmdnode::tool
