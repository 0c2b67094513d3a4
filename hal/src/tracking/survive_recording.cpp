// libsurvive recording reader and replay backend (survive_recording.hpp). The layout read is what
// libsurvive's recorder (src/survive_recording.c, its SWEEP/SYNC/SWEEP_ANGLE formats in
// survive_recording.h, https://github.com/cntools/libsurvive) writes, learnt from its test
// corpus; the IMU samples are replayed as the Index's own report 0x20 so the codec, the factory
// calibration, the clock tracking and the fusion are those of a live device. Cost: O(file) time and
// memory; the JSON parse of one CONFIG line.
#include "hmdnode/hal/tracking/survive_recording.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <optional>
#include <string_view>

#include <nlohmann/json.hpp>

#include "codec/config_pose.hpp"
#include "hmdnode/hal/codec/vive_imu.hpp"
#include "transport/gunzip.hpp"

namespace hmdnode {
namespace {

// Whitespace-separated tokens of one line (spaces, tabs, a CRLF's '\r').
std::vector<std::string_view> tokens(std::string_view line, size_t max_tokens) {
    std::vector<std::string_view> out;
    size_t i = 0;
    auto space = [](char c) { return c == ' ' || c == '\t' || c == '\r'; };
    while (i < line.size() && out.size() < max_tokens) {
        while (i < line.size() && space(line[i])) ++i;
        if (i >= line.size()) break;
        size_t j = i;
        while (j < line.size() && !space(line[j])) ++j;
        out.push_back(line.substr(i, j - i));
        i = j;
    }
    return out;
}

bool to_double(std::string_view s, double* v) {
    if (!s.empty() && s[0] == '+') s.remove_prefix(1);
    auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), *v);
    return ec == std::errc() && p == s.data() + s.size() && std::isfinite(*v);
}

// A whole number within [lo, hi] (the recorder prints counts as "-7166.000000").
bool to_whole(std::string_view s, double lo, double hi, double* v) {
    return to_double(s, v) && *v == std::floor(*v) && *v >= lo && *v <= hi;
}

// A whole number field within [lo, hi], named in the error.
std::string whole_field(std::string_view tok, const char* name, double lo, double hi, double* v) {
    if (to_whole(tok, lo, hi, v)) return {};
    char range[64];
    std::snprintf(range, sizeof range, "%.0f..%.0f", lo, hi);
    return std::string(name) + " \"" + std::string(tok) + "\" is not a whole number in " + range;
}

// The light lines (W B Y C A): fields after TIME DEV KIND.
std::string parse_light_line(const std::vector<std::string_view>& t, int64_t time_ns,
                             uint32_t line_no, SurviveRecording* rec) {
    using K = SurviveLightLine::Kind;
    struct Shape {
        char kind;
        K k;
        size_t fields;
        const char* layout;
    };
    static const Shape kShapes[] = {
        {'W', K::sweep, 7, "TIME DEV W CHANNEL SENSOR TIMECODE FLAG"},
        {'B', K::angle, 8, "TIME DEV B CHANNEL SENSOR TIMECODE PLANE ANGLE"},
        {'Y', K::sync, 7, "TIME DEV Y CHANNEL TIMECODE OOTX GEN"},
        {'C', K::pulse, 6, "TIME DEV C SENSOR TIMECODE LENGTH"},
        {'A', K::lh1_angle, 9, "TIME DEV A SENSOR ACODE TIMECODE LENGTH_S ANGLE LH"},
    };
    const Shape* sh = nullptr;
    for (const Shape& x : kShapes)
        if (t[2].size() == 1 && t[2][0] == x.kind) sh = &x;
    if (t.size() != sh->fields)
        return std::string("a ") + sh->kind + " line has " + std::to_string(sh->fields) +
               " fields (" + sh->layout + "), this one " + std::to_string(t.size());
    SurviveLightLine l;
    l.kind = sh->k;
    l.line = line_no;
    l.host_time_ns = time_ns;
    double v = 0;
    std::string e;
    auto field = [&](size_t i, const char* name, double lo, double hi) {
        if (e.empty()) e = whole_field(t[i], name, lo, hi, &v);
        return e.empty();
    };
    auto angle = [&](size_t i, const char* name, double* out) {
        if (!e.empty()) return false;
        if (!to_double(t[i], out) || std::abs(*out) > 10.0)
            e = std::string(name) + " \"" + std::string(t[i]) + "\" is not an angle in radians";
        return e.empty();
    };
    constexpr double kU32 = 4294967295.0;
    switch (sh->k) {
        case K::sweep:
        case K::angle:
            if (field(3, "CHANNEL", 0, 15)) l.channel = uint8_t(v);
            if (field(4, "SENSOR", 0, 255)) l.sensor = uint8_t(v);
            if (field(5, "TIMECODE", 0, kU32)) l.timecode = uint32_t(v);
            if (field(6, sh->k == K::sweep ? "FLAG" : "PLANE", 0, 1)) l.flag = uint8_t(v);
            if (sh->k == K::angle) angle(7, "ANGLE", &l.angle);
            break;
        case K::sync:
            if (field(3, "CHANNEL", 0, 15)) l.channel = uint8_t(v);
            if (field(4, "TIMECODE", 0, kU32)) l.timecode = uint32_t(v);
            if (field(5, "OOTX", 0, 1)) l.flag = uint8_t(v);
            if (field(6, "GEN", 0, 1)) l.gen = uint8_t(v);
            break;
        case K::pulse:
            if (field(3, "SENSOR", 0, 255)) l.sensor = uint8_t(v);
            if (field(4, "TIMECODE", 0, kU32)) l.timecode = uint32_t(v);
            if (field(5, "LENGTH", 0, kU32)) l.length = uint32_t(v);
            break;
        case K::lh1_angle:
            if (field(3, "SENSOR", 0, 255)) l.sensor = uint8_t(v);
            if (field(4, "ACODE", 0, 255)) l.flag = uint8_t(v);
            if (field(5, "TIMECODE", 0, kU32)) l.timecode = uint32_t(v);
            if (e.empty() && (!to_double(t[6], &l.length_s) || l.length_s < 0 || l.length_s > 1))
                e = "LENGTH_S \"" + std::string(t[6]) + "\" is not a pulse length in seconds";
            angle(7, "ANGLE", &l.angle);
            if (field(8, "LH", 0, 15)) l.channel = uint8_t(v);
            break;
    }
    if (!e.empty()) return e;
    rec->light.push_back(l);
    return {};
}

// An LH_POSE line (any device field: the base station's number), with or without its id.
// Fields 3..9 of a POSE or LH_POSE line (x y z qw qx qy qz): the position and the unit quaternion;
// an error naming KIND and the field, or "".
std::string parse_pose_fields(const std::vector<std::string_view>& t, std::string_view kind,
                              glm::dvec3* position, glm::dquat* rotation) {
    double v[7];
    for (size_t k = 0; k < 7; ++k)
        if (!to_double(t[3 + k], &v[k]))
            return std::string(kind) + " value " + std::to_string(k + 1) + " \"" +
                   std::string(t[3 + k]) + "\" is not a number";
    const glm::dquat q(v[3], v[4], v[5], v[6]);
    const double norm = glm::length(q);
    if (std::abs(norm - 1.0) > 0.01)
        return std::string(kind) + " quaternion (qw qx qy qz) has norm " + std::to_string(norm) +
               ", not 1";
    *position = glm::dvec3(v[0], v[1], v[2]);
    *rotation = q / norm;
    return {};
}

std::string parse_lh_pose(const std::vector<std::string_view>& t, int64_t time_ns,
                          SurviveRecording* rec) {
    if (t.size() != 10 && t.size() != 11)
        return "an LH_POSE line has 10 or 11 fields (TIME N LH_POSE x y z qw qx qy qz [ID]), "
               "this one " +
               std::to_string(t.size());
    double n = 0;
    if (!to_whole(t[1], 0, 255, &n))
        return "LH_POSE base station \"" + std::string(t[1]) + "\" is not a number 0..255";
    glm::dvec3 position;
    glm::dquat rotation;
    if (std::string e = parse_pose_fields(t, "LH_POSE", &position, &rotation); !e.empty()) return e;
    SurviveBaseStationPose p{time_ns, int(n), position, rotation, {}};
    if (t.size() == 11) {
        double id = 0;
        if (!to_whole(t[10], 0, 4294967295.0, &id))
            return "LH_POSE ID \"" + std::string(t[10]) + "\" is not a 32-bit id";
        p.id = uint32_t(id);
    }
    rec->base_station_poses.push_back(p);
    return {};
}

// IMU_SCALES GYRO ACC (libsurvive's survive_default_set_imu_scale_modes: gyro 250, 500, 1000, 2000
// deg/s, accel 2, 4, 8, 16 g; a mode above 3 leaves that range as it was, as libsurvive does).
std::string parse_imu_scales(const std::vector<std::string_view>& t, const std::string& source,
                             uint32_t line_no, SurviveRecording* rec) {
    if (t.size() != 5)
        return "an IMU_SCALES line has 5 fields (TIME DEV IMU_SCALES GYRO ACC), this one " +
               std::to_string(t.size());
    double g = 0, a = 0;
    if (std::string e = whole_field(t[3], "IMU_SCALES GYRO", 0, 255, &g); !e.empty()) return e;
    if (std::string e = whole_field(t[4], "IMU_SCALES ACC", 0, 255, &a); !e.empty()) return e;
    const std::string where = source + ":" + std::to_string(line_no) + ": ";
    if (g > 3 || a > 3) {
        rec->warnings.push_back(where + "IMU_SCALES " + std::string(t[3]) + " " +
                                std::string(t[4]) +
                                ": a mode above 3 is not a range libsurvive knows; the ranges "
                                "stay as they were");
        return {};
    }
    rec->imu_scales = std::array<uint8_t, 2>{uint8_t(g), uint8_t(a)};
    char b[160];
    std::snprintf(b, sizeof b, "IMU_SCALES %d %d: gyro range %d deg/s, accelerometer range %d g",
                  int(g), int(a), 250 << int(g), 2 << int(a));
    rec->notes.push_back(where + b);
    return {};
}

bool is_light_kind(std::string_view k) {
    return k == "W" || k == "B" || k == "Y" || k == "C" || k == "A";
}

// The factory IMU calibration a configuration holds: an `imu` object, or a Vive HMD's (lighthouse
// 1) top-level acc_bias ... with its IMU's pose as trackref_from_imu.
bool has_imu_object(const nlohmann::json& j) {
    return j.contains("imu") && j["imu"].is_object();
}
bool has_vive_hmd_calibration(const nlohmann::json& j) {
    return !has_imu_object(j) && j.contains("acc_bias") && j.contains("gyro_bias") &&
           j.contains("trackref_from_imu");
}

// Parses one line of a kind read into rec; an error message (without the location) when it is
// malformed.
std::string parse_line(const std::vector<std::string_view>& t, std::string_view line,
                       const std::string& source, uint32_t line_no, SurviveRecording* rec) {
    double time_s = 0;
    if (!to_double(t[0], &time_s) || time_s < 0)
        return "TIME \"" + std::string(t[0]) + "\" is not a non-negative number";
    const int64_t time_ns = std::llround(time_s * 1e9);
    const std::string_view kind = t[2];
    if (kind == "LH_POSE") return parse_lh_pose(t, time_ns, rec);
    if (is_light_kind(kind)) return parse_light_line(t, time_ns, line_no, rec);
    if (kind == "i") {
        // 15 fields; 12 from older recorders without the magnetometer (libsurvive's playback
        // reads both).
        if (t.size() != 15 && t.size() != 12)
            return "an IMU line (i) has 15 fields (TIME DEV i MASK TICK ax ay az gx gy gz mx my mz "
                   "SEQ) or 12 (without mx my mz), this one " +
                   std::to_string(t.size());
        SurviveImuLine s;
        s.host_time_ns = time_ns;
        double v = 0;
        if (!to_whole(t[4], 0, 4294967295.0, &v))
            return "TICK \"" + std::string(t[4]) + "\" is not a 32-bit count";
        s.ticks = uint32_t(v);
        static const char* kAxes[] = {"ax", "ay", "az", "gx", "gy", "gz"};
        for (int k = 0; k < 6; ++k) {
            if (!to_whole(t[5 + size_t(k)], -32768, 32767, &v))
                return std::string(kAxes[k]) + " \"" + std::string(t[5 + size_t(k)]) +
                       "\" is not a 16-bit raw count";
            (k < 3 ? s.accel[size_t(k)] : s.gyro[size_t(k - 3)]) = int16_t(v);
        }
        if (!to_whole(t.back(), 0, 255, &v))
            return "SEQ \"" + std::string(t.back()) + "\" is not an 8-bit sequence number";
        s.sequence = uint8_t(v);
        rec->imu.push_back(s);
        return {};
    }
    if (kind == "IMU_SCALES") return parse_imu_scales(t, source, line_no, rec);
    if (kind == "EXTERNAL_POSE") {
        if (t.size() != 10)
            return "an EXTERNAL_POSE line has 10 fields (TIME NAME EXTERNAL_POSE x y z qw qx qy "
                   "qz), this one " +
                   std::to_string(t.size());
        glm::dvec3 position;
        glm::dquat rotation;
        if (std::string e = parse_pose_fields(t, "EXTERNAL_POSE", &position, &rotation); !e.empty())
            return e;
        auto it = std::find_if(rec->external_poses.begin(), rec->external_poses.end(),
                               [&](const SurviveNamedPoses& n) { return n.name == t[1]; });
        if (it == rec->external_poses.end())
            it = rec->external_poses.insert(rec->external_poses.end(),
                                            SurviveNamedPoses{std::string(t[1]), {}});
        it->poses.push_back({time_ns, position, rotation});
        return {};
    }
    if (kind == "POSE") {
        if (t.size() != 10)
            return "a POSE line has 10 fields (TIME DEV POSE x y z qw qx qy qz), this one " +
                   std::to_string(t.size());
        glm::dvec3 position;
        glm::dquat rotation;
        if (std::string e = parse_pose_fields(t, "POSE", &position, &rotation); !e.empty())
            return e;
        rec->poses.push_back({time_ns, position, rotation});
        return {};
    }
    // CONFIG: the rest of the line after the kind is the device's JSON.
    const size_t at = size_t(kind.data() + kind.size() - line.data());
    const std::string json(line.substr(at));
    auto j = nlohmann::json::parse(json, nullptr, false);
    if (j.is_discarded() || !j.is_object()) return "CONFIG: not a JSON object";
    auto sensors = parse_lighthouse_sensors(json, "CONFIG");
    if (!sensors) return sensors.error().message;
    rec->sensors = std::move(*sensors);
    // The factory calibration: an `imu` object, or a Vive HMD's top-level acc_bias ... with its
    // trackref_from_imu (parse_imu_calibration_json).
    if (j.contains("imu") || has_vive_hmd_calibration(j)) {
        auto cal = parse_imu_calibration_json(json, "CONFIG");
        if (!cal) return cal.error().message;
        rec->has_config = true;
        rec->calibration = *cal;
    } else {
        rec->warnings.push_back(source + ":" + std::to_string(line_no) +
                                ": CONFIG has no \"imu\" object nor a Vive HMD's top-level "
                                "calibration (the factory IMU calibration); the IMU is decoded "
                                "without one (its light model is read)");
    }
    if (j.is_object() && j.contains("model_number") && j["model_number"].is_string())
        rec->model = j["model_number"].get<std::string>();
    if (j.is_object() && j.contains("device_class") && j["device_class"].is_string())
        rec->device_class = j["device_class"].get<std::string>();
    return {};
}

Result<glm::dvec3> vec3(const nlohmann::json& o, const char* key, const std::string& where,
                        std::optional<glm::dvec3> fallback) {
    if (!o.contains(key)) {
        if (fallback) return *fallback;
        return make_error(where + "." + key + ": missing");
    }
    const nlohmann::json& a = o[key];
    if (!a.is_array() || a.size() != 3 || !a[0].is_number() || !a[1].is_number() ||
        !a[2].is_number())
        return make_error(where + "." + key + ": not an array of 3 numbers");
    glm::dvec3 v(a[0].get<double>(), a[1].get<double>(), a[2].get<double>());
    if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z))
        return make_error(where + "." + key + ": not finite");
    return v;
}

// The rotation whose columns are the frame's axes in the device frame, from its plus_x and
// plus_z (y = z x x), made exactly orthonormal.
Result<glm::dmat3> frame(const nlohmann::json& o, const std::string& where) {
    auto x = vec3(o, "plus_x", where, glm::dvec3(1, 0, 0));
    if (!x) return x.error();
    auto z = vec3(o, "plus_z", where, glm::dvec3(0, 0, 1));
    if (!z) return z.error();
    if (glm::length(*x) < 0.5 || glm::length(*z) < 0.5 ||
        std::abs(glm::dot(glm::normalize(*x), glm::normalize(*z))) > 0.01)
        return make_error(where + ": plus_x and plus_z are not perpendicular unit axes");
    const glm::dvec3 zn = glm::normalize(*z);
    const glm::dvec3 yn = glm::normalize(glm::cross(zn, *x));
    return glm::dmat3(glm::cross(yn, zn), yn, zn);
}

// IMU lines that carry no sequence number (every SEQ the same, e.g. 0: a controller's samples
// through its radio) are numbered in the order of their ticks: a new tick is the next sample, a
// repeated one a repeat. Without it the codec takes every line after the first for a repeat.
void number_imu_lines(const std::string& source, SurviveRecording* rec) {
    std::vector<SurviveImuLine>& imu = rec->imu;
    if (imu.size() < 2) return;
    for (const SurviveImuLine& s : imu)
        if (s.sequence != imu.front().sequence) return;
    const int carried = imu.front().sequence;
    uint8_t seq = 0;
    for (size_t k = 1; k < imu.size(); ++k) {
        if (imu[k].ticks != imu[k - 1].ticks) ++seq;
        imu[k].sequence = seq;
    }
    imu.front().sequence = 0;
    rec->imu_sequence_numbered = true;
    rec->notes.push_back(source + ": the " + std::to_string(imu.size()) + " IMU lines of " +
                         rec->device + " all carry sequence number " + std::to_string(carried) +
                         " (no sample counter): numbered in the order of their ticks, the time "
                         "from the tick");
}

class SurviveTransport final : public Transport {
  public:
    SurviveTransport(std::shared_ptr<const SurviveRecording> rec, DeviceId id, bool with_light)
        : rec_(std::move(rec)), id_(std::move(id)), with_light_(with_light) {
        skip_reference_light();
    }
    DeviceId id() const override { return id_; }
    Result<std::optional<InputReport>> read_input(int) override {
        // With light: its lines interleaved by TIME (a light line first on a tie), each as the
        // device's own light report.
        if (with_light_ && light_cursor_ < rec_->light.size() &&
            (cursor_ >= rec_->imu.size() ||
             rec_->light[light_cursor_].host_time_ns <= rec_->imu[cursor_].host_time_ns)) {
            InputReport r{light_report(rec_->light[light_cursor_]),
                          rec_->light[light_cursor_].host_time_ns};
            ++light_cursor_;
            skip_reference_light();
            return std::optional<InputReport>(std::move(r));
        }
        if (cursor_ >= rec_->imu.size()) return std::optional<InputReport>();
        // As the device sends them: the newest sample and the two before it.
        std::array<vive::RawSlot, 3> slots;
        for (size_t k = 0; k < 3; ++k) {
            const SurviveImuLine& s = rec_->imu[cursor_ >= k ? cursor_ - k : 0];
            slots[k] = {s.accel, s.gyro, s.ticks, s.sequence};
        }
        const auto bytes = vive::encode_imu_report(slots);
        InputReport r{std::vector<uint8_t>(bytes.begin(), bytes.end()),
                      rec_->imu[cursor_].host_time_ns};
        ++cursor_;
        return std::optional<InputReport>(std::move(r));
    }
    // Feature report 0x01 (the IMU ranges): the recording's IMU_SCALES line, as the device
    // answered it to libsurvive; without one, libsurvive's defaults for the device
    // (survive_imu_scales: a controller's or tracker's 8 g, not the headset's 4 g).
    Result<std::vector<uint8_t>> get_feature(uint8_t report_id, size_t) override {
        if (report_id == vive::kRangeReportId) {
            const std::array<uint8_t, 2> m = survive_imu_scales(*rec_);
            return std::vector<uint8_t>{vive::kRangeReportId, m[0], m[1]};
        }
        return make_error("libsurvive recording: no feature report " + std::to_string(report_id));
    }
    Status set_feature(std::span<const uint8_t>) override { return {}; }
    Status write_output(std::span<const uint8_t>) override { return {}; }
    bool finished() const override {
        return cursor_ >= rec_->imu.size() && (!with_light_ || light_cursor_ >= rec_->light.size());
    }

  private:
    // B and A lines are libsurvive's angles, not input.
    void skip_reference_light() {
        using K = SurviveLightLine::Kind;
        while (light_cursor_ < rec_->light.size() &&
               (rec_->light[light_cursor_].kind == K::angle ||
                rec_->light[light_cursor_].kind == K::lh1_angle))
            ++light_cursor_;
    }
    // A W or Y line as a report 0x28 of one word (the sensor as its raw channel, the time's low 24
    // bits, as the device sends them); a C line as a report 0x25 of one pulse.
    std::vector<uint8_t> light_report(const SurviveLightLine& l) const {
        using K = SurviveLightLine::Kind;
        if (l.kind == K::pulse) {
            const lighthouse::Lh1Pulse p{l.sensor, l.timecode, l.length};
            return lighthouse::encode_lh1_report(std::span<const lighthouse::Lh1Pulse>(&p, 1));
        }
        lighthouse::Lh2Word w;
        w.sweep = l.kind == K::sweep;
        w.channel = l.channel;
        w.time24 = l.timecode & 0xffffffu;
        if (w.sweep) {
            const auto& map = rec_->sensors.channel_map;
            w.sensor = uint8_t(l.sensor < map.size() ? map[l.sensor] : l.sensor);
            w.half_clock = l.flag != 0;
        } else {
            w.ootx = l.flag != 0;
            w.gen = l.gen != 0;
        }
        return lighthouse::encode_lh2_report(std::span<const lighthouse::Lh2Word>(&w, 1));
    }

    std::shared_ptr<const SurviveRecording> rec_;
    DeviceId id_;
    bool with_light_ = false;
    size_t cursor_ = 0;
    size_t light_cursor_ = 0;
};

class SurviveBackend final : public TransportBackend {
  public:
    SurviveBackend(std::shared_ptr<const SurviveRecording> rec, bool with_light)
        : rec_(std::move(rec)), with_light_(with_light) {
        id_.vendor_id = vive::kVendorId;
        id_.product_id = vive::kIndexProductId;
        id_.path = "rec:" + rec_->device;
        id_.product = "Valve Index (libsurvive recording " + rec_->device + ")";
    }
    std::string name() const override { return "rec"; }
    Result<std::vector<DeviceId>> enumerate(const DeviceFilter& filter) override {
        if (!filter.matches(id_)) return std::vector<DeviceId>{};
        return std::vector<DeviceId>{id_};
    }
    Result<std::unique_ptr<Transport>> open(const DeviceId& id) override {
        if (id.path != id_.path) return make_error("libsurvive recording: no device " + id.path);
        return std::unique_ptr<Transport>(new SurviveTransport(rec_, id_, with_light_));
    }

  private:
    std::shared_ptr<const SurviveRecording> rec_;
    bool with_light_ = false;
    DeviceId id_;
};

}  // namespace

namespace survive_detail {
// A headset: the CONFIG's device_class "hmd" when it has one (the Index, "Utah MP", is T20 in
// compare-test-index, so the codename alone would take it for a controller), else libsurvive's
// own test, the codename "HMD".
bool is_headset(const SurviveRecording& rec) {
    if (!rec.device_class.empty()) return rec.device_class == "hmd";
    return rec.device == "HMD";
}
}  // namespace survive_detail

std::array<uint8_t, 2> survive_imu_scales(const SurviveRecording& rec) {
    if (rec.imu_scales) return *rec.imu_scales;
    // libsurvive's handle_config: raw_acc_scale 1/8192 g (4 g full scale) and 500 deg/s for a
    // headset; 2/8192 g (8 g) and 2000 deg/s for every other device.
    if (survive_detail::is_headset(rec)) return {1, 1};
    return {3, 2};
}

std::string describe_survive_imu_scales(const SurviveRecording& rec) {
    const std::array<uint8_t, 2> m = survive_imu_scales(rec);
    std::string s = std::to_string(250 << m[0]) + " deg/s, " + std::to_string(2 << m[1]) + " g";
    if (rec.imu_scales) return "IMU_SCALES: " + s;
    const std::string by = rec.device_class.empty()
                               ? "codename " + rec.device
                               : "CONFIG device_class \"" + rec.device_class + "\"";
    return s + " (no IMU_SCALES line: libsurvive's default for " +
           (survive_detail::is_headset(rec) ? "a headset" : "a device that is not a headset") +
           ", by its " + by + ")";
}

Result<ImuCalibration> parse_imu_calibration_json(const std::string& text,
                                                  const std::string& source) {
    nlohmann::json j = nlohmann::json::parse(text, nullptr, false);
    if (j.is_discarded() || !j.is_object()) return make_error(source + ": not a JSON object");
    // A Vive HMD (lighthouse 1) keeps its calibration at the top level and its IMU's pose in the
    // tracking-reference frame as trackref_from_imu [qx, qy, qz, qw, x, y, z], as its head's
    // trackref_from_head (Monado's vive_config.c reads the Vive's the same way).
    const bool top_level = has_vive_hmd_calibration(j);
    if (!top_level && !has_imu_object(j))
        return make_error(source +
                          ": no \"imu\" object, nor a Vive HMD's top-level acc_bias, gyro_bias "
                          "and trackref_from_imu (the factory IMU calibration)");
    const nlohmann::json& imu = top_level ? j : j["imu"];
    const std::string w = top_level ? source : source + ": imu";
    ImuCalibration c;
    auto acc_bias = vec3(imu, "acc_bias", w, std::nullopt);
    if (!acc_bias) return acc_bias.error();
    auto acc_scale = vec3(imu, "acc_scale", w, glm::dvec3(1.0));
    if (!acc_scale) return acc_scale.error();
    auto gyro_bias = vec3(imu, "gyro_bias", w, std::nullopt);
    if (!gyro_bias) return gyro_bias.error();
    auto gyro_scale = vec3(imu, "gyro_scale", w, glm::dvec3(1.0));
    if (!gyro_scale) return gyro_scale.error();
    for (double s :
         {acc_scale->x, acc_scale->y, acc_scale->z, gyro_scale->x, gyro_scale->y, gyro_scale->z})
        if (s < 0.5 || s > 2.0)
            return make_error(w + ": a scale of " + std::to_string(s) + " (expected near 1)");
    c.acc_bias = *acc_bias;
    c.acc_scale = *acc_scale;
    c.gyro_bias = *gyro_bias;
    c.gyro_scale = *gyro_scale;
    Result<glm::dmat3> device_from_imu = glm::dmat3(1.0);
    Result<glm::dvec3> imu_origin = glm::dvec3(0.0);
    if (top_level) {
        auto pose = detail::config_pose7(j["trackref_from_imu"], source + ".trackref_from_imu");
        if (!pose) return pose.error();
        device_from_imu = pose->first;
        imu_origin = pose->second;
    } else {
        device_from_imu = frame(imu, w);
        if (!device_from_imu) return device_from_imu.error();
        imu_origin = vec3(imu, "position", w, glm::dvec3(0.0));
        if (!imu_origin) return imu_origin.error();
    }
    glm::dmat3 device_from_head(1.0);
    glm::dvec3 head_origin(0.0);
    if (top_level && j.contains("trackref_from_head")) {
        auto pose = detail::config_pose7(j["trackref_from_head"], source + ".trackref_from_head");
        if (!pose) return pose.error();
        device_from_head = pose->first;
        head_origin = pose->second;
    } else if (j.contains("head") && j["head"].is_object()) {
        auto h = frame(j["head"], source + ": head");
        if (!h) return h.error();
        device_from_head = *h;
        auto o = vec3(j["head"], "position", source + ": head", glm::dvec3(0.0));
        if (!o) return o.error();
        head_origin = *o;
    }
    c.head_from_imu = glm::transpose(device_from_head) * *device_from_imu;
    c.imu_position = glm::transpose(device_from_head) * (*imu_origin - head_origin);
    return c;
}

Result<SurviveRecording> parse_survive_recording(const std::string& text, const std::string& source,
                                                 const std::string& device) {
    SurviveRecording rec;
    rec.device = device;
    size_t pos = 0;
    uint64_t line_no = 0;
    while (pos < text.size()) {
        size_t end = text.find('\n', pos);
        const bool cut = end == std::string::npos;  // no newline: maybe a cut last line
        if (cut) end = text.size();
        const std::string_view line(text.data() + pos, end - pos);
        const size_t line_at = pos;
        pos = end + 1;
        ++line_no;
        ++rec.lines;
        const auto t = tokens(line, 16);
        // LH_POSE and EXTERNAL_POSE lines are read whatever their device field (a base station's
        // number, a pose's name).
        const bool lh_pose = t.size() >= 3 && (t[2] == "LH_POSE" || t[2] == "EXTERNAL_POSE");
        const bool read_kind =
            t.size() >= 3 && (t[2] == "i" || t[2] == "POSE" || t[2] == "CONFIG" ||
                              t[2] == "IMU_SCALES" || is_light_kind(t[2]));
        if (read_kind &&
            std::find(rec.devices.begin(), rec.devices.end(), t[1]) == rec.devices.end())
            rec.devices.emplace_back(t[1]);
        if (!lh_pose && (!read_kind || t[1] != device)) {
            ++rec.other_lines;
            continue;
        }
        std::string err = parse_line(t, line, source, uint32_t(line_no), &rec);
        if (err.empty()) continue;
        const std::string where = source + ":" + std::to_string(line_no) + ": ";
        if (cut) {
            rec.warnings.push_back(where + "the last line (at byte " + std::to_string(line_at) +
                                   ") is cut short (" + err + "); skipped");
            continue;
        }
        return make_error(where + err);
    }
    number_imu_lines(source, &rec);
    if (rec.imu.empty()) {
        std::string held;
        for (const std::string& d : rec.devices) held += (held.empty() ? "" : ", ") + d;
        return make_error(source + ": no IMU line (i) of device " + device +
                          " (devices: " + (held.empty() ? std::string("none") : held) + ")");
    }
    return rec;
}

Result<SurviveRecording> read_survive_recording(const std::filesystem::path& path,
                                                const std::string& device) {
    std::ifstream in(path, std::ios::binary);
    if (!in) return make_error(path.string() + ": cannot open");
    std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(in)),
                               std::istreambuf_iterator<char>());
    std::string text;
    std::vector<std::string> warnings;
    if (bytes.size() >= 2 && bytes[0] == 0x1f && bytes[1] == 0x8b) {
        bool truncated = false;
        auto r = gunzip(bytes, &truncated);
        if (!r) return make_error(path.string() + ": " + r.error().message);
        text.assign(r->begin(), r->end());
        if (truncated) {
            // Where it stopped: the last whole line's number and TIME.
            const size_t end = text.rfind('\n');
            const size_t lines = size_t(std::count(text.begin(), text.end(), '\n'));
            std::string at;
            if (end != std::string::npos && end > 0) {
                const size_t prev = text.rfind('\n', end - 1);
                const size_t begin = prev == std::string::npos ? 0 : prev + 1;
                const auto t = tokens(std::string_view(text).substr(begin, end - begin), 1);
                at = ", the last whole line is " + std::to_string(lines) +
                     (t.empty() ? std::string() : " (TIME " + std::string(t[0]) + ")");
            }
            warnings.push_back(path.string() + ": gzip: the stream is cut short; " +
                               std::to_string(text.size()) + " bytes inflated" + at +
                               "; the rest of the recording is lost");
        }
    } else {
        text.assign(bytes.begin(), bytes.end());
    }
    auto rec = parse_survive_recording(text, path.string(), device);
    if (!rec) return rec;
    rec->warnings.insert(rec->warnings.begin(), warnings.begin(), warnings.end());
    return rec;
}

lighthouse::SensorModel survive_sensor_model(const SurviveRecording& rec) {
    lighthouse::SensorModel m;
    if (!rec.sensors.empty()) {
        m.count = rec.sensors.points.size();
        m.channel_map = rec.sensors.channel_map;
    }
    return m;
}

Status replay_survive_light(const SurviveRecording& rec, lighthouse::LightDecoder& decoder) {
    using K = SurviveLightLine::Kind;
    for (const SurviveLightLine& l : rec.light) {
        Status st;
        if (l.kind == K::sweep)
            st = decoder.add_lh2_sweep(l.channel, l.sensor, l.timecode, l.flag != 0);
        else if (l.kind == K::sync)
            st = decoder.add_lh2_sync(l.channel, l.timecode, l.flag != 0, l.gen != 0);
        else if (l.kind == K::pulse)
            st = decoder.add_lh1_pulse(l.sensor, l.timecode, l.length);
        if (!st) return make_error("line " + std::to_string(l.line) + ": " + st.error().message);
    }
    decoder.finish();
    return {};
}

const std::vector<SurvivePose>* survive_device_poses(const SurviveRecording& rec,
                                                     std::string* what) {
    if (!rec.poses.empty()) {
        *what = "POSE lines of " + rec.device;
        return &rec.poses;
    }
    for (const std::string& name : {"replay_" + rec.device, rec.device})
        for (const SurviveNamedPoses& n : rec.external_poses)
            if (n.name == name) {
                *what = "EXTERNAL_POSE lines named " + name;
                return &n.poses;
            }
    std::string names;
    for (const SurviveNamedPoses& n : rec.external_poses)
        names += (names.empty() ? "" : ", ") + n.name + " (" + std::to_string(n.poses.size()) + ")";
    *what = "no POSE line of " + rec.device + " and no EXTERNAL_POSE line named replay_" +
            rec.device + " or " + rec.device +
            (names.empty() ? std::string(" (no EXTERNAL_POSE line at all)")
                           : " (EXTERNAL_POSE names: " + names + ")");
    return nullptr;
}

std::unique_ptr<TransportBackend> create_survive_backend(
    std::shared_ptr<const SurviveRecording> rec, bool with_light) {
    return std::make_unique<SurviveBackend>(std::move(rec), with_light);
}

Result<std::unique_ptr<DeviceTracker>> create_survive_tracker(
    std::shared_ptr<const SurviveRecording> rec, Clock& clock, int64_t first_report_host_ns,
    const ImuFusionConfig& fusion, std::shared_ptr<const LightTrackingConfig> light) {
    DeviceTrackerConfig cfg;
    cfg.fusion = fusion;
    cfg.first_report_host_ns = first_report_host_ns;
    const bool with_light =
        light && (!light->setup.empty() || light->place.enabled) && !rec->light.empty();
    if (with_light) {
        cfg.light = std::move(light);
        // The first IMU report at first_report_host_ns: a light report before it, as early.
        using K = SurviveLightLine::Kind;
        for (const SurviveLightLine& l : rec->light)
            if (l.kind != K::angle && l.kind != K::lh1_angle) {
                if (l.host_time_ns < rec->imu.front().host_time_ns)
                    cfg.first_report_host_ns =
                        first_report_host_ns - (rec->imu.front().host_time_ns - l.host_time_ns);
                break;
            }
    }
    cfg.filter.vendor_id = vive::kVendorId;
    cfg.filter.product_id = vive::kIndexProductId;
    cfg.name = "libsurvive recording " + rec->device;
    auto codec = make_vive_codec(vive::kIndexProductId);
    if (rec->has_config) codec->set_imu_calibration(rec->calibration);
    return create_device_tracker(create_survive_backend(std::move(rec), with_light),
                                 std::move(codec), clock, cfg);
}

Result<LightTrackingConfig> survive_light_tracking_config(
    const SurviveRecording& rec, std::vector<lighthouse::BaseStationPlacement> setup,
    const glm::dvec3& world_up) {
    if (rec.light.empty())
        return make_error(rec.device + ": the recording has no light line (W, Y or C) of it");
    if (rec.sensors.empty())
        return make_error(rec.device +
                          ": no sensor model (CONFIG lighthouse_config: modelPoints, "
                          "modelNormals) to solve its light with");
    LightTrackingConfig cfg;
    cfg.sensors = rec.sensors;
    cfg.setup = std::move(setup);
    cfg.filter.world_up = glm::normalize(world_up);
    cfg.filter.imu_position = rec.calibration.imu_position;
    return cfg;
}

}  // namespace hmdnode
