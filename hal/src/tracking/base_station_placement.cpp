// Base-station placement from a still device (base_station_placement.hpp), as libsurvive's
// calibration places its base stations relative to the first device solve (poser_mpfit.c's
// run_mpfit_find_cameras; its world is the device's frame, later levelled by the accelerometer);
// the angles are the still window's medians; per base station the orthogonal-iteration PnP seed
// on the ideal directions of the sensors' world points (lighthouse_pnp.cpp), then
// Levenberg-Marquardt on the calibrated residuals (lighthouse_lsq.cpp) over station_from_world.
// The state file is nlohmann-json, written atomically. Cost: O(events log events) to gather,
// then one small fit per base station.
#include "hmdnode/hal/tracking/base_station_placement.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <optional>
#include <set>

#include <nlohmann/json.hpp>

#include "hmdnode/core/atomic_file.hpp"
#include "hmdnode/core/str_cat.hpp"
#include "hmdnode/hal/tracking/survive_recording.hpp"
#include "tracking/lighthouse_fit.hpp"

namespace hmdnode::lighthouse {
namespace {

using detail::FitAngle;

RigidPose inverse(const RigidPose& p) {
    const glm::dquat r = glm::conjugate(p.orientation);
    return {-(r * p.position), r};
}

std::string station_name(Generation g, int n) {
    return cat(generation_name(g), g == Generation::lh2 ? " channel " : " base station ", n);
}

const BaseStationState* find_known(std::span<const BaseStationState> known, Generation g, int n) {
    for (const BaseStationState& s : known)
        if (s.generation == g && s.base_station == n) return &s;
    return nullptr;
}

// The shortest rotation taking unit a onto unit b.
glm::dquat shortest_arc(glm::dvec3 a, glm::dvec3 b) {
    a = glm::normalize(a);
    b = glm::normalize(b);
    const double c = glm::dot(a, b);
    if (c < -1 + 1e-12) {  // opposite: half a turn about any perpendicular
        glm::dvec3 axis = glm::cross(a, glm::dvec3(1, 0, 0));
        if (glm::length(axis) < 1e-6) axis = glm::cross(a, glm::dvec3(0, 0, 1));
        return glm::angleAxis(M_PI, glm::normalize(axis));
    }
    const glm::dvec3 v = glm::cross(a, b);
    return glm::normalize(glm::dquat(1 + c, v.x, v.y, v.z));
}

// One base station from its angles, the device at `wd`; nullopt with `why` when it cannot.
std::optional<BaseStationPlacement> place_one(const SensorLayout& layout, const RigidPose& wd,
                                              std::span<const AngleSample> mine,
                                              const BaseStationState* known,
                                              const PlacementOptions& o, std::string& why) {
    const Generation g = mine.front().generation;
    std::vector<FitAngle> fit;
    std::map<int, std::array<std::optional<double>, 2>> both;
    for (const AngleSample& a : mine) {
        if (a.sensor >= layout.points.size()) continue;
        FitAngle f;
        f.point = wd.position + wd.orientation * layout.points[a.sensor];
        if (!layout.normals.empty()) f.normal = wd.orientation * layout.normals[a.sensor];
        if (known && known->calibration) f.cal = known->calibration->plane[a.plane & 1];
        f.generation = g;
        f.plane = a.plane & 1;
        f.angle = a.angle;
        f.sensor = a.sensor;
        f.device_time_ns = a.device_time_ns;
        fit.push_back(f);
        both[a.sensor][a.plane & 1] = a.angle;
    }
    if (fit.size() < o.min_angles_per_station) {
        why = cat(fit.size(), " angles (need ", o.min_angles_per_station, ")");
        return std::nullopt;
    }
    std::vector<glm::dvec3> points, rays, normals;
    for (const FitAngle& f : fit) {
        auto& pl = both[f.sensor];
        if (f.plane != 0 || !pl[0] || !pl[1]) continue;
        points.push_back(f.point);
        rays.push_back(g == Generation::lh2 ? lh2_ideal_direction(*pl[0], *pl[1])
                                            : lh1_ideal_direction(*pl[0], *pl[1]));
        if (!layout.normals.empty()) normals.push_back(f.normal);
    }
    if (points.size() < o.solver.min_seed_sensors) {
        why = cat(points.size(), " sensors seen on both planes (need ", o.solver.min_seed_sensors,
                  ")");
        return std::nullopt;
    }
    auto seed = detail::pnp_orthogonal_iteration(points, rays, normals, o.solver.max_incidence_rad);
    if (!seed) {
        why = "the perspective-n-point seed found no pose";
        return std::nullopt;
    }
    SolverOptions so = o.solver;
    so.min_angles = std::max(so.min_angles, o.min_angles_per_station);
    const detail::FitResult r = detail::fit_pose(fit, *seed, so);
    if (!r.enough) {
        why = r.why;
        return std::nullopt;
    }
    if (!(r.rms <= so.max_residual_rad)) {
        why = cat("the fit's residual ", r.rms * 1e3, " mrad RMS exceeds ",
                  so.max_residual_rad * 1e3, " mrad");
        return std::nullopt;
    }
    BaseStationPlacement p;
    p.generation = g;
    p.base_station = mine.front().base_station;
    if (known && known->calibration) {
        p.id = known->calibration->id;
        p.calibration = stored_calibration(*known->calibration);
    }
    p.world_from_station = inverse(r.pose);
    p.residual_rms_rad = r.rms;
    p.used = r.used;
    p.rejected = r.outliers;
    std::vector<int64_t> t;
    for (const FitAngle& f : fit)
        if (f.state == FitAngle::State::used) t.push_back(f.device_time_ns);
    std::nth_element(t.begin(), t.begin() + long(t.size() / 2), t.end());
    p.device_time_ns = t[t.size() / 2];
    return p;
}

}  // namespace

PlacementResult place_base_stations(const SensorLayout& layout,
                                    std::span<const LightEvent> still_window,
                                    std::span<const BaseStationState> known,
                                    const RigidPose& world_from_device,
                                    const std::optional<glm::dvec3>& up_in_device,
                                    const PlacementOptions& o) {
    PlacementResult out;
    out.world_from_device = world_from_device;
    if (up_in_device && glm::length(*up_in_device) > 0) {
        const glm::dvec3 up_world = world_from_device.orientation * *up_in_device;
        out.world_from_device.orientation = glm::normalize(
            shortest_arc(up_world, glm::dvec3(0, 1, 0)) * world_from_device.orientation);
    }
    const std::vector<AngleSample> angles = median_angles(still_window, o.min_events_per_angle);
    std::map<std::pair<int, int>, std::vector<AngleSample>> per;
    std::map<std::pair<int, int>, size_t> events;
    for (const LightEvent& e : still_window) ++events[{int(e.generation), e.base_station}];
    for (const AngleSample& a : angles) per[{int(a.generation), a.base_station}].push_back(a);
    for (const auto& [k, n] : events)
        if (!per.count(k))
            out.not_placed.push_back(cat(station_name(Generation(k.first), k.second), ": ", n,
                                         " events, no sensor and plane seen ",
                                         o.min_events_per_angle, " times"));
    for (const auto& [k, mine] : per) {
        const Generation g = Generation(k.first);
        std::string why;
        auto p =
            place_one(layout, out.world_from_device, mine, find_known(known, g, k.second), o, why);
        if (p)
            out.placed.push_back(*p);
        else
            out.not_placed.push_back(station_name(g, k.second) + ": " + why);
    }
    return out;
}

const char* calibration_source_name(CalibrationSource s) {
    switch (s) {
        case CalibrationSource::stored:
            return "stored";
        case CalibrationSource::decoded:
            return "decoded";
        default:
            return "none";
    }
}

std::vector<PlacedBaseStation> placed_stations(std::span<const BaseStationPlacement> setup,
                                               std::span<const BaseStationState> known,
                                               std::vector<CalibrationSource>* sources) {
    std::vector<PlacedBaseStation> out;
    if (sources) sources->clear();
    for (const BaseStationPlacement& p : setup) {
        const BaseStationState* k = find_known(known, p.generation, p.base_station);
        PlacedBaseStation s{p.generation, p.base_station, p.world_from_station, std::nullopt};
        CalibrationSource src = CalibrationSource::none;
        if (k && k->calibration) {
            const std::optional<uint32_t> want = p.id ? p.id
                                                 : p.calibration
                                                     ? std::optional<uint32_t>(p.calibration->id)
                                                     : std::nullopt;
            if (want && *want != k->calibration->id) continue;  // another base station now
            s.calibration = k->calibration;
            src = CalibrationSource::decoded;
        } else if (p.calibration && p.calibration->generation == p.generation) {
            s.calibration = p.calibration;  // the live frame has not arrived (yet)
            src = CalibrationSource::stored;
        }
        out.push_back(s);
        if (sources) sources->push_back(src);
    }
    return out;
}

// ---- The state file -----------------------------------------------------------------------------

constexpr const char* kFormat = "hmdnode base stations";

namespace placement_detail {

std::string hex_id(uint32_t id) {
    char s[16];
    std::snprintf(s, sizeof s, "0x%08x", id);
    return s;
}

// The calibration's fields the angle model uses (ootx.hpp's PlaneCalibration), by name.
constexpr std::array<std::pair<const char*, double PlaneCalibration::*>, 7> kPlaneFields{{
    {"phase", &PlaneCalibration::phase},
    {"tilt", &PlaneCalibration::tilt},
    {"curve", &PlaneCalibration::curve},
    {"gibbous_phase", &PlaneCalibration::gibbous_phase},
    {"gibbous_mag", &PlaneCalibration::gibbous_mag},
    {"ogee_phase", &PlaneCalibration::ogee_phase},
    {"ogee_mag", &PlaneCalibration::ogee_mag},
}};

nlohmann::json calibration_json(const BaseStationCalibration& c) {
    nlohmann::json j;
    j["id"] = hex_id(c.id);
    j["firmware_version"] = c.firmware_version;
    nlohmann::json planes = nlohmann::json::array();
    for (const PlaneCalibration& pl : c.plane) {
        nlohmann::json x;
        for (const auto& [name, field] : kPlaneFields) x[name] = pl.*field;
        planes.push_back(x);
    }
    j["planes"] = planes;
    return j;
}

// "0x" and up to 8 hex digits, or nullopt.
std::optional<uint32_t> parse_hex_id(const nlohmann::json& id) {
    const std::string s = id.is_string() ? id.get<std::string>() : "";
    if (s.size() < 3 || s.rfind("0x", 0) != 0) return std::nullopt;
    char* end = nullptr;
    const unsigned long x = std::strtoul(s.c_str() + 2, &end, 16);
    if (*end != '\0' || x > 0xffffffffUL || s[2] == '-' || s[2] == '+') return std::nullopt;
    return uint32_t(x);
}

// A base_stations[] entry's "calibration" (`w` names it); an error naming the field, or "".
std::string parse_calibration(const nlohmann::json& j, const std::string& w, Generation g,
                              BaseStationCalibration* c) {
    if (!j.is_object()) return w + ": an object expected";
    c->generation = g;
    if (!j.contains("id")) return w + ".id: missing";
    const std::optional<uint32_t> id = parse_hex_id(j["id"]);
    if (!id) return w + ".id: a 32-bit id as \"0x\" and hex digits expected";
    c->id = *id;
    if (j.contains("firmware_version")) {
        const nlohmann::json& f = j["firmware_version"];
        if (!f.is_number_integer() || f.get<int64_t>() < 0 || f.get<int64_t>() > 0xffff)
            return w + ".firmware_version: a whole number in 0..65535 expected";
        c->firmware_version = uint16_t(f.get<int64_t>());
    }
    if (!j.contains("planes") || !j["planes"].is_array() || j["planes"].size() != 2)
        return w + ".planes: an array of 2 planes expected";
    for (size_t i = 0; i < 2; ++i) {
        const nlohmann::json& pl = j["planes"][i];
        const std::string pw = cat(w, ".planes[", i, "]");
        if (!pl.is_object()) return pw + ": an object expected";
        for (const auto& [name, field] : kPlaneFields) {
            if (!pl.contains(name)) return cat(pw, ".", name, ": missing");
            const nlohmann::json& x = pl[name];
            if (!x.is_number() || !std::isfinite(x.get<double>()))
                return cat(pw, ".", name, ": a finite number expected");
            c->plane[i].*field = x.get<double>();
        }
    }
    return {};
}

}  // namespace placement_detail

BaseStationCalibration stored_calibration(const BaseStationCalibration& c) {
    BaseStationCalibration out;
    out.generation = c.generation;
    out.firmware_version = c.firmware_version;
    out.id = c.id;
    out.plane = c.plane;
    return out;
}

std::string base_station_setup_json(std::span<const BaseStationPlacement> setup) {
    using placement_detail::calibration_json;
    nlohmann::json list = nlohmann::json::array();
    for (const BaseStationPlacement& p : setup) {
        nlohmann::json j;
        j["system"] = int(p.generation);
        j["base_station"] = p.base_station;
        if (p.id) {
            char id[16];
            std::snprintf(id, sizeof id, "0x%08x", *p.id);
            j["id"] = id;
        }
        const glm::dvec3& t = p.world_from_station.position;
        const glm::dquat& q = p.world_from_station.orientation;
        j["position"] = {t.x, t.y, t.z};
        j["orientation"] = {q.w, q.x, q.y, q.z};
        j["residual_rad"] = p.residual_rms_rad;
        j["angles"] = p.used;
        j["rejected"] = p.rejected;
        j["solved_unix_s"] = p.solved_unix_s;
        if (p.calibration) j["calibration"] = calibration_json(*p.calibration);
        list.push_back(j);
    }
    nlohmann::json doc;
    doc["format"] = kFormat;
    doc["version"] = 1;
    doc["base_stations"] = list;
    return doc.dump(2) + "\n";
}

Status save_base_station_setup(const std::filesystem::path& path,
                               std::span<const BaseStationPlacement> setup) {
    return write_file_atomically(path, base_station_setup_json(setup));
}

namespace {

// One base_stations[] entry; an error message naming the field (without the file), or "".
std::string parse_station(const nlohmann::json& j, const std::string& w, BaseStationPlacement* p) {
    if (!j.is_object()) return w + ": not an object";
    auto whole = [&](const char* key, int64_t lo, int64_t hi, int64_t* v) -> std::string {
        if (!j.contains(key)) return w + "." + key + ": missing";
        const nlohmann::json& x = j[key];
        if (!x.is_number_integer() || x.get<int64_t>() < lo || x.get<int64_t>() > hi)
            return cat(w, ".", key, ": a whole number in ", lo, "..", hi, " expected");
        *v = x.get<int64_t>();
        return {};
    };
    auto numbers = [&](const char* key, size_t n, double* v, const char* what) -> std::string {
        const std::string e = cat(w, ".", key, ": ", n, " numbers (", what, ") expected");
        if (!j.contains(key) || !j[key].is_array() || j[key].size() != n) return e;
        for (size_t i = 0; i < n; ++i) {
            if (!j[key][i].is_number()) return e;
            v[i] = j[key][i].get<double>();
            if (!std::isfinite(v[i])) return e;
        }
        return {};
    };
    int64_t v = 0;
    if (auto e = whole("system", 1, 2, &v); !e.empty()) return e;
    p->generation = Generation(v);
    if (auto e = whole("base_station", 0, p->generation == Generation::lh2 ? 15 : 1, &v);
        !e.empty())
        return e;
    p->base_station = uint8_t(v);
    if (j.contains("id")) {
        const nlohmann::json& id = j["id"];
        char* end = nullptr;
        const std::string s = id.is_string() ? id.get<std::string>() : "";
        const unsigned long x = s.empty() ? 0 : std::strtoul(s.c_str(), &end, 16);
        if (s.empty() || s.rfind("0x", 0) != 0 || *end != '\0' || x > 0xffffffffUL)
            return w + ".id: a 32-bit id as \"0x\" and hex digits expected";
        p->id = uint32_t(x);
    }
    double t[3], q[4];
    if (auto e = numbers("position", 3, t, "x, y, z in metres"); !e.empty()) return e;
    const std::string qe = numbers("orientation", 4, q, "w, x, y, z");
    const double norm = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    if (!qe.empty() || std::abs(norm - 1) > 1e-3)
        return w + ".orientation: 4 numbers (w, x, y, z) of a unit quaternion expected";
    p->world_from_station = {{t[0], t[1], t[2]}, glm::dquat(q[0], q[1], q[2], q[3]) / norm};
    if (j.contains("calibration")) {
        BaseStationCalibration c;
        if (auto e = placement_detail::parse_calibration(j["calibration"], w + ".calibration",
                                                         p->generation, &c);
            !e.empty())
            return e;
        if (p->id && *p->id != c.id)
            return cat(w, ".calibration.id: ", placement_detail::hex_id(c.id),
                       " differs from the base station's id ", placement_detail::hex_id(*p->id));
        p->id = c.id;
        p->calibration = c;
    }
    if (j.contains("residual_rad")) {
        if (!j["residual_rad"].is_number() || !(j["residual_rad"].get<double>() >= 0))
            return w + ".residual_rad: a non-negative number expected";
        p->residual_rms_rad = j["residual_rad"].get<double>();
    }
    for (auto [key, out] : {std::pair{"angles", &p->used}, std::pair{"rejected", &p->rejected}})
        if (j.contains(key)) {
            if (auto e = whole(key, 0, 1 << 20, &v); !e.empty()) return e;
            *out = size_t(v);
        }
    if (j.contains("solved_unix_s")) {
        if (auto e = whole("solved_unix_s", 0, INT64_MAX, &v); !e.empty()) return e;
        p->solved_unix_s = v;
    }
    return {};
}

}  // namespace

Result<std::vector<BaseStationPlacement>> parse_base_station_setup(const std::string& text,
                                                                   const std::string& source) {
    nlohmann::json doc = nlohmann::json::parse(text, nullptr, false);
    if (doc.is_discarded()) return make_error(source + ": not JSON");
    if (!doc.is_object() || !doc.contains("format") || doc["format"] != kFormat)
        return make_error(cat(source, ": format: \"", kFormat, "\" expected"));
    if (!doc.contains("version") || doc["version"] != 1)
        return make_error(source + ": version: 1 expected (the only version this build reads)");
    if (!doc.contains("base_stations") || !doc["base_stations"].is_array())
        return make_error(source + ": base_stations: an array expected");
    std::vector<BaseStationPlacement> out;
    std::set<std::pair<int, int>> seen;
    const nlohmann::json& list = doc["base_stations"];
    for (size_t i = 0; i < list.size(); ++i) {
        const std::string w = cat("base_stations[", i, "]");
        BaseStationPlacement p;
        if (std::string e = parse_station(list[i], w, &p); !e.empty())
            return make_error(source + ": " + e);
        if (!seen.insert({int(p.generation), p.base_station}).second)
            return make_error(cat(source, ": ", w, ": ", station_name(p.generation, p.base_station),
                                  " is listed twice"));
        out.push_back(p);
    }
    return out;
}

Result<std::vector<BaseStationPlacement>> load_base_station_setup(
    const std::filesystem::path& path) {
    auto text = read_file(path);
    if (!text) return text.error();
    return parse_base_station_setup(*text, path.string());
}

Result<std::vector<BaseStationPlacement>> recording_base_station_setup(
    const SurviveRecording& rec, std::span<const BaseStationState> known, bool allow_look_ahead) {
    using K = SurviveLightLine::Kind;
    int64_t first_light = INT64_MAX;
    bool lh2 = false;
    std::vector<int> channel_order;  // lighthouse-2 channels by their first sync
    for (const SurviveLightLine& l : rec.light) {
        first_light = std::min(first_light, l.host_time_ns);
        if (l.kind == K::sweep || l.kind == K::sync || l.kind == K::angle) lh2 = true;
        if (l.kind == K::sync &&
            std::find(channel_order.begin(), channel_order.end(), l.channel) == channel_order.end())
            channel_order.push_back(l.channel);
    }
    const Generation g = lh2 ? Generation::lh2 : Generation::lh1;
    std::map<int, BaseStationPlacement> last;
    for (const SurviveBaseStationPose& p : rec.base_station_poses) {
        if (p.host_time_ns > first_light && !allow_look_ahead)
            return make_error(cat(rec.device, ": LH_POSE of base station ", p.number, " at ",
                                  double(p.host_time_ns) * 1e-9,
                                  " s comes after the first light line (",
                                  double(first_light) * 1e-9,
                                  " s): solved during the recording (look-ahead), not a stored "
                                  "setup"));
        int number = p.number;
        const BaseStationState* by_id = nullptr;
        if (p.id)
            for (const BaseStationState& s : known)
                if (s.generation == g && s.calibration && s.calibration->id == *p.id) by_id = &s;
        if (by_id)
            number = by_id->base_station;
        else if (g == Generation::lh2 && !p.id) {
            if (size_t(p.number) >= channel_order.size())
                return make_error(cat(rec.device, ": LH_POSE base station ", p.number,
                                      " has no id, and the recording syncs only ",
                                      channel_order.size(), " channels"));
            number = channel_order[size_t(p.number)];
        }
        if (number > (g == Generation::lh2 ? 15 : 1))
            return make_error(cat(rec.device, ": LH_POSE base station ", p.number, " is not a ",
                                  generation_name(g), " base station"));
        BaseStationPlacement b;
        b.generation = g;
        b.base_station = uint8_t(number);
        b.id = p.id;
        b.world_from_station = {p.position, glm::normalize(p.orientation)};
        b.device_time_ns = 0;
        last[number] = b;
    }
    if (last.empty()) return make_error(rec.device + ": the recording holds no LH_POSE line");
    std::vector<BaseStationPlacement> out;
    for (auto& [n, b] : last) out.push_back(b);
    return out;
}

}  // namespace hmdnode::lighthouse
