// The frame budget's targets on this machine: 60 s of the bundled real head trace (Corbillon et
// al. 2018, user 1, from 20 s) resampled to a 1 kHz tracker, the demo room at 90 Hz, this
// machine's renderer (lavapipe without a GPU), real clock: the node as it runs (prediction, late
// warp, the fused lens pass, the pixel-cost ladder and the chosen render rate) at 360x400 and
// 540x600 per eye, beside the same at 360x400 with the ladder off and every frame aimed at every
// vsync (the node before them), and on the simulated clock with the cost model calibrated on this
// renderer. Prints a markdown table beside the targets; `--write-docs` also writes it to
// docs/results/latency-bench.md.
//
// Usage: bench_latency_bench [seconds=60] [--write-docs]
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "doc_table.hpp"
#include "hmdnode/firmware_host/replay.hpp"

using namespace hmdnode;

namespace {

struct Run {
    std::string name;
    ReplayResult result;
};

std::string fmt(const char* f, double v) {
    char b[64];
    std::snprintf(b, sizeof b, f, v);
    return b;
}

}  // namespace

int main(int argc, char** argv) {
    const bool write_docs = bench::wants_docs(argc, argv);
    const double seconds =
        argc > 1 && std::string(argv[1]) != "--write-docs" ? std::atof(argv[1]) : 60.0;
    ReplayOptions base;
    base.scene = HMDNODE_BINARY_DIR "/data/demo_room.glb";
    base.trace = HMDNODE_SOURCE_DIR "/data/traces/corbillon2018_user1.csv";
    base.start_s = 20.0;
    base.duration_s = seconds;
    base.display.eye_width = 360;
    base.display.eye_height = 400;
    base.tracker.resample_hz = 1000.0;

    struct Mode {
        const char* name;
        bool sim;
        int w, h;
        bool ladder;
        int max_divisor;
    };
    const Mode modes[] = {{"real clock, 360x400", false, 360, 400, true, 3},
                          {"real clock, 540x600", false, 540, 600, true, 3},
                          {"real clock, 360x400, no ladder, rate 1/1", false, 360, 400, false, 1},
                          {"sim clock (calibrated), 360x400", true, 360, 400, true, 3}};
    std::vector<Run> runs;
    std::optional<FrameCostModel> model;
    for (const Mode& m : modes) {
        ReplayOptions o = base;
        o.simulated_clock = m.sim;
        o.display.eye_width = m.w;
        o.display.eye_height = m.h;
        o.node.pixel_ladder = m.ladder;
        o.node.pacing.max_divisor = m.max_divisor;
        if (m.sim && model) o.frame_cost = model;  // one calibration for both simulated runs
        std::fprintf(stderr, "latency bench: %s, %.0f s...\n", m.name, seconds);
        Result<ReplayResult> r = run_replay(o);
        if (!r.ok()) {
            std::fprintf(stderr, "latency bench: %s\n", r.error().message.c_str());
            return 1;
        }
        if (m.sim && !model) model = r->summary.frame_cost_model;
        runs.push_back(Run{m.name, std::move(*r)});
    }

    std::ostringstream t;
    const ReplayResult& ref = runs[0].result;
    t << "Measured by `build/release/bench/bench_latency_bench " << seconds
      << " --write-docs` (renderer " << ref.device_name << ", generic headset profile, "
      << std::thread::hardware_concurrency() << " cores):\n\n";
    t << "| figure | target | ";
    for (const Run& r : runs) t << r.name << " | ";
    t << "\n|---|---|";
    for (size_t i = 0; i < runs.size(); ++i) t << "---|";
    t << "\n";
    auto row = [&](const char* label, const char* target, auto value) {
        t << "| " << label << " | " << target << " | ";
        for (const Run& r : runs) t << value(r.result.summary) << " | ";
        t << "\n";
    };
    row("vsyncs on time (new or re-warped)", ">= 99 %",
        [](const ReplaySummary& s) { return fmt("%.1f %%", 100.0 * s.on_time_rate); });
    row("missed vsyncs / vsyncs", "", [](const ReplaySummary& s) {
        return std::to_string(s.missed_vsyncs) + " / " + std::to_string(s.vsyncs);
    });
    row("longest run of missed vsyncs", "<= 2",
        [](const ReplaySummary& s) { return std::to_string(s.longest_late_run); });
    row("new frames per vsync, re-warps", "", [](const ReplaySummary& s) {
        return fmt("%.2f", s.new_frames_per_vsync) + ", " + std::to_string(s.rewarps);
    });
    row("late frames", "", [](const ReplaySummary& s) { return std::to_string(s.late_frames); });
    row("MTP p50 / p99 (ms)", "p99 <= floor + 2", [](const ReplaySummary& s) {
        return fmt("%.2f", s.latency_ms.p50) + " / " + fmt("%.2f", s.latency_ms.p99);
    });
    row("MTP floor (ms): photon offset + latch + pass p99 + tracker latency", "",
        [](const ReplaySummary& s) { return fmt("%.2f", s.mtp_floor_ms); });
    row("registration error p50 / p99 (deg)", "p99 <= 0.5", [](const ReplaySummary& s) {
        return fmt("%.3f", s.registration_error_deg.p50) + " / " +
               fmt("%.3f", s.registration_error_deg.p99);
    });
    row("render p50 / p99 (ms, measured)", "", [](const ReplaySummary& s) {
        return fmt("%.2f", s.render_ms.p50) + " / " + fmt("%.2f", s.render_ms.p99);
    });
    row("lens pass p50 / p99 (ms, measured)", "", [](const ReplaySummary& s) {
        return fmt("%.2f", s.warp_ms.p50) + " / " + fmt("%.2f", s.warp_ms.p99);
    });
    row("lens pass: fused / mesh / floor at start-up (ms)", "", [](const ReplaySummary& s) {
        return s.lens_pass + ": " + fmt("%.2f", s.pass_times.fused_ms) + " / " +
               fmt("%.2f", s.pass_times.mesh_ms) + " / " + fmt("%.2f", s.pass_times.floor_ms);
    });
    row("presents at full resolution / at rate 1/1", "", [](const ReplaySummary& s) {
        const double n = double(std::max<size_t>(1, s.frames));
        return fmt("%.1f %%", s.ladder.empty() ? 0.0 : 100.0 * double(s.ladder[0].presents) / n) +
               " / " +
               fmt("%.1f %%", s.presents_by_divisor.empty()
                                  ? 0.0
                                  : 100.0 * double(s.presents_by_divisor[0]) / n);
    });
    row("ladder steps used (share of presents)", "", [](const ReplaySummary& s) {
        std::string out;
        const double n = double(std::max<size_t>(1, s.frames));
        for (const ReplaySummary::LadderShare& l : s.ladder)
            if (l.presents > 0)
                out += (out.empty() ? "" : ", ") + l.name + " " +
                       fmt("%.0f %%", 100.0 * double(l.presents) / n);
        return out;
    });
    if (model) {
        // The simulated clock's render cost at the real run's mean triangles against the real
        // run's measured median (the calibration's check: within 20 %).
        const ReplaySummary& real = runs[0].result.summary;
        const double modelled = ns_to_ms(model->render_ns(uint64_t(real.triangles_mean)));
        t << "\nSimulated clock's model, calibrated on the renderer at start-up: render "
          << fmt("%.2f", ns_to_ms(model->base_ns)) << " ms + "
          << fmt("%.3f", model->per_triangle_ns * 1e-3) << " ms per 1k triangles, warp "
          << fmt("%.2f", ns_to_ms(model->warp_ns)) << " ms. At the real run's "
          << fmt("%.0f", real.triangles_mean) << " triangles per frame it charges "
          << fmt("%.2f", modelled) << " ms per render against " << fmt("%.2f", real.render_ms.p50)
          << " ms measured (p50), "
          << fmt("%+.0f %%", 100.0 * (modelled / real.render_ms.p50 - 1.0)) << "; warp "
          << fmt("%.2f", ns_to_ms(model->warp_ns)) << " ms against "
          << fmt("%.2f", real.warp_ms.p50) << " ms.\n";
    }
    const std::string table = t.str();
    std::fputs(table.c_str(), stdout);

    if (write_docs) {
        if (!bench::write_result("latency-bench",
                                 "Frames on time, motion-to-photon and registration error",
                                 bench::command_line(argc, argv), table, ref.device_name))
            return 1;
        std::fprintf(stderr, "latency bench: wrote docs/results/latency-bench.md\n");
    }
    return 0;
}
