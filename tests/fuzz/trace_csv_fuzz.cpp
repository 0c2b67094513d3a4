// libFuzzer harness: core's trace readers on untrusted bytes -- the project's trace CSV
// (parse_trace_csv) and the foreign-table importer (import_trace_text) with the options chosen
// by the first byte (separator, quaternion order, Euler angles, source frame, fast-rotation
// policy). Invariants for an accepted trace: at least one sample, time strictly increasing,
// finite unit orientations; the trace writes back (format_trace_csv) and reads again to the same
// number of samples.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "hmdnode/core/trace.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    using namespace hmdnode;
    if (size == 0) return 0;
    const uint8_t mode = data[0];
    const std::string text(reinterpret_cast<const char*>(data) + 1, size - 1);
    Result<Trace> t = make_error("");
    if ((mode & 1) == 0) {
        t = parse_trace_csv(text, "fuzz");
    } else {
        TraceImportOptions o;
        static const char* const kSeparators[] = {"auto", ",", "\t", ";", " "};
        o.separator = kSeparators[(mode >> 1) % 5];
        if (mode & 0x10) o.quat_order = "xyzw";
        if (mode & 0x20) {
            o.euler_columns = {"yaw", "pitch", "roll"};
            o.euler_degrees = (mode & 0x40) == 0;
        }
        if (mode & 0x40) o.source_frame = "z-up-x-forward";
        if (mode & 0x80) o.on_fast_rotation = (mode & 0x08) ? "drop" : "refuse";
        if ((mode & 0x0e) == 0x0e) o.rebase_time = false;
        TraceImportReport report;
        t = import_trace_text(text, "fuzz", o, &report);
    }
    if (!t.ok()) return 0;
    if (t->samples.empty()) abort();
    for (size_t i = 0; i < t->samples.size(); ++i) {
        const TraceSample& s = t->samples[i];
        if (i > 0 && s.time_ns <= t->samples[i - 1].time_ns) abort();
        const double n =
            std::sqrt(s.orientation.w * s.orientation.w + s.orientation.x * s.orientation.x +
                      s.orientation.y * s.orientation.y + s.orientation.z * s.orientation.z);
        if (!(std::fabs(n - 1.0) < 0.1)) abort();
    }
    Result<std::string> back = format_trace_csv(*t);
    if (!back.ok()) abort();
    Result<Trace> again = parse_trace_csv(*back, "fuzz (written back)");
    if (!again.ok() || again->samples.size() != t->samples.size()) abort();
    (void)compute_trace_stats(*t);
    return 0;
}
