// Latency comparison across pacing modes (`hmdnode latency`, docs/latency.md): the side-by-side
// table, the JSON report (hmdnode-latency-report/1) and a hand-written SVG of MTP histograms and
// registration-error timelines, from each mode's per-vsync series (replay.hpp, vsync_series).
// Pure functions of their input, any thread. Cost: O(modes * vsyncs).
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "hmdnode/core/result.hpp"
#include "hmdnode/firmware_host/node.hpp"
#include "hmdnode/firmware_host/replay.hpp"

namespace hmdnode {

// One combination of prediction and late warp. Names: "none", "predict", "warp", "predict+warp".
struct LatencyMode {
    std::string name;
    bool predict = false;
    bool warp = false;
};
// The four modes, in the order none, predict, warp, predict+warp.
std::vector<LatencyMode> all_latency_modes();
// "all", or a comma-separated list of mode names (each once); an error naming a bad one.
Result<std::vector<LatencyMode>> parse_latency_modes(const std::string& list);

// One mode's run.
struct LatencyModeResult {
    LatencyMode mode;
    ReplaySummary summary;  // as run_replay summarised it
    std::vector<VsyncSample> series;
    size_t on_time_vsyncs = 0;  // vsyncs - missed
    int64_t period_ns = 0;
};

// Percentiles of a series' field (NaN values left out).
Percentiles series_latency_ms(const std::vector<VsyncSample>& series);
Percentiles series_registration_error_deg(const std::vector<VsyncSample>& series);

// The side-by-side table for people: one column per mode.
std::string latency_table(const std::vector<LatencyModeResult>& results);

// {"format": "hmdnode-latency-report/1", "options": options, "renderer": renderer,
//  "modes": [{name, prediction, warp, summary (the replay's fields + on_time_vsyncs),
//             series: {t_ms, latency_ms, registration_error_deg, shown, on_time}}]}
// (docs/latency.md). t_ms is from the first vsync of that mode's run.
nlohmann::json latency_report_json(const nlohmann::json& options, const std::string& renderer,
                                   const std::vector<LatencyModeResult>& results);

// One SVG document: per mode, a histogram of MTP per displayed vsync and a timeline of
// registration error (missed vsyncs marked), on axes shared by all modes; `title` and `subtitle`
// head it.
std::string latency_svg(const std::vector<LatencyModeResult>& results, const std::string& title,
                        const std::string& subtitle);

}  // namespace hmdnode
