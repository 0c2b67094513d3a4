// Where the base stations stand (docs/tracking.md §10): each base station's pose in the room,
// solved from a device's light data while the device lies still, with the device's frame at
// that time defining the world (as libsurvive does: its first device solve fixes the world and
// the base stations are placed relative to it; optionally levelled by the accelerometer's still
// mean), and the setup kept in a small JSON state file for the next start, or taken from a
// recording's stored base-station poses.
//
// Per base station: the median angle per (sensor, plane) over the still window, a PnP seed on
// the ideal directions (orthogonal iteration), Levenberg-Marquardt on the calibrated residuals
// with the pose solver's outlier rule (the same code as lighthouse_solver.hpp's).
// Pure functions but for save/load (file I/O on the calling thread). Cost: O(events) to gather
// the window, then as one pose solve per base station.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "hmdnode/core/result.hpp"
#include "hmdnode/hal/codec/light_codec.hpp"
#include "hmdnode/hal/tracking/lighthouse_solver.hpp"

namespace hmdnode {
struct SurviveRecording;
}

namespace hmdnode::lighthouse {

struct BaseStationPlacement {
    Generation generation = Generation::lh2;
    uint8_t base_station = 0;    // lighthouse-2 channel or lighthouse-1 number (LightEvent's)
    std::optional<uint32_t> id;  // its OOTX id, when its calibration was known
    // Its factory calibration (OOTX) as decoded when it was placed, kept with the setup so that
    // the next start uses it before the base station's frame arrives again (its id is `id`).
    // The angle model's fields only: generation, firmware_version, id and the two planes.
    std::optional<BaseStationCalibration> calibration;
    RigidPose world_from_station;
    double residual_rms_rad = 0;    // of the angles used (0: not known, e.g. a recording's pose)
    size_t used = 0, rejected = 0;  // angles in the fit, outliers left out
    int64_t device_time_ns = 0;     // median device time of the angles it was solved from
    int64_t solved_unix_s = 0;      // when solved (wall clock; set by the caller; 0: unknown)
};

struct PlacementOptions {
    SolverOptions solver;                // outlier rule, facing rule, iterations
    size_t min_angles_per_station = 10;  // libsurvive places a candidate from 10 measurements
    size_t min_events_per_angle = 3;     // events behind each median angle
};

struct PlacementResult {
    RigidPose world_from_device;  // the device's pose that defines the world (levelled if asked)
    std::vector<BaseStationPlacement> placed;
    std::vector<std::string> not_placed;  // "lighthouse 2 channel 5: <why>"
};

// Places every base station with angles in `still_window` (the device must not move in it),
// the device at `world_from_device` (default: its frame is the world). `up_in_device`: the
// accelerometer's still mean in the device's model frame (it reads "up"); when given, the world
// is levelled: its +Y is up, the rest of the device's orientation kept (the shortest rotation).
// `known`: the decoder's base stations, for their calibration and id (none: the ideal planes).
PlacementResult place_base_stations(const SensorLayout& layout,
                                    std::span<const LightEvent> still_window,
                                    std::span<const BaseStationState> known,
                                    const RigidPose& world_from_device = {},
                                    const std::optional<glm::dvec3>& up_in_device = std::nullopt,
                                    const PlacementOptions& options = {});

// The part of a decoded calibration a setup keeps (generation, firmware_version, id, planes).
BaseStationCalibration stored_calibration(const BaseStationCalibration& c);

// Which calibration a placed base station is solved with.
enum class CalibrationSource : uint8_t {
    none,     // the ideal planes (nothing decoded, nothing stored)
    stored,   // the setup's (decoded in an earlier session), until the live frame arrives
    decoded,  // the base station's own frame, decoded in this run
};
const char* calibration_source_name(CalibrationSource s);  // "none", "stored", "decoded"

// The solver's input from a setup: each placement with the calibration `known` has decoded for
// it, or else the one the setup stores (a known id that differs from the placement's: left out,
// as a base station that was swapped). `sources`, when given, gets each output's source.
std::vector<PlacedBaseStation> placed_stations(std::span<const BaseStationPlacement> setup,
                                               std::span<const BaseStationState> known,
                                               std::vector<CalibrationSource>* sources = nullptr);

// ---- The state file --------------------------------------------------------------------------
// {"format": "hmdnode base stations", "version": 1, "base_stations": [{"system": 2,
//  "base_station": 3, "id": "0x4096b5a0", "position": [x, y, z], "orientation": [w, x, y, z],
//  "residual_rad": r, "angles": n, "rejected": k, "solved_unix_s": s, "calibration": {"id":
//  "0x4096b5a0", "firmware_version": v, "planes": [{"phase": .., "tilt": .., "curve": ..,
//  "gibbous_phase": .., "gibbous_mag": .., "ogee_phase": .., "ogee_mag": ..}, {..}]}}, ...]}
// (docs/formats.md); "calibration" is optional (files written before it load without one).
std::string base_station_setup_json(std::span<const BaseStationPlacement> setup);
// Written atomically (core/atomic_file.hpp).
Status save_base_station_setup(const std::filesystem::path& path,
                               std::span<const BaseStationPlacement> setup);
// Errors name the file and the field, e.g. `setup.json: base_stations[1].orientation: 4 numbers
// (w, x, y, z) of a unit quaternion expected`.
Result<std::vector<BaseStationPlacement>> parse_base_station_setup(const std::string& text,
                                                                   const std::string& source);
Result<std::vector<BaseStationPlacement>> load_base_station_setup(
    const std::filesystem::path& path);

// A recording's stored setup: its LH_POSE lines (libsurvive's world) from before its first light
// line, as libsurvive writes them from its saved configuration. Poses solved later in the
// recording are look-ahead: an error naming the line and time unless `allow_look_ahead` (then
// the last pose of each base station; for tests that stand them in for a stored setup). A line's
// number is mapped to a base station by the id it carries, when `known` has that id; else it is
// the lighthouse-2 channel, or, for a recording whose LH_POSE lines carry no id, libsurvive's
// index of the channels in the order of their first sync (Y line); lighthouse 1: the number.
Result<std::vector<BaseStationPlacement>> recording_base_station_setup(
    const SurviveRecording& rec, std::span<const BaseStationState> known, bool allow_look_ahead);

}  // namespace hmdnode::lighthouse
