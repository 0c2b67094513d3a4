// Reading a Vive/Index device's JSON configuration over HID feature reports (0x10 start, 0x11
// chunks, zlib), live or from a capture that recorded the read, and its sensor model:
// lighthouse_config.hpp. Cost: one round trip per 62 compressed bytes, O(size).
#include "hmdnode/hal/codec/lighthouse_config.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <deque>
#include <map>
#include <set>
#include <vector>

#include <glm/gtc/quaternion.hpp>
#include <nlohmann/json.hpp>

#include "codec/config_pose.hpp"
#include "transport/gunzip.hpp"

namespace hmdnode {

Result<std::string> read_lighthouse_config(Transport& t) {
    using namespace lighthouse_config;
    auto start = t.get_feature(kStartReportId, kReportSize);
    if (!start)
        return make_error("configuration read: feature report 0x10: " + start.error().message);
    if (start->size() < 3 || (*start)[0] != kStartReportId)
        return make_error("configuration read: feature report 0x10 answered " +
                          std::to_string(start->size()) + " bytes starting with report id " +
                          std::to_string(start->empty() ? -1 : int((*start)[0])));
    const size_t expected = size_t((*start)[1]) << 8 | (*start)[2];
    std::vector<uint8_t> compressed;
    for (size_t chunk = 0;; ++chunk) {
        if (chunk == kMaxChunks)
            return make_error("configuration read: more than " + std::to_string(kMaxChunks) +
                              " chunks (feature report 0x11) without the closing empty one");
        auto r = t.get_feature(kChunkReportId, kReportSize);
        if (!r)
            return make_error("configuration read: feature report 0x11 (chunk " +
                              std::to_string(chunk) + "): " + r.error().message);
        if (r->size() < 2 || (*r)[0] != kChunkReportId)
            return make_error("configuration read: chunk " + std::to_string(chunk) +
                              ": a reply of " + std::to_string(r->size()) +
                              " bytes that is not feature report 0x11");
        const size_t n = (*r)[1];
        if (n == 0) break;
        if (n > r->size() - 2)
            return make_error("configuration read: chunk " + std::to_string(chunk) +
                              ": byte 1 gives length " + std::to_string(n) + " in a report of " +
                              std::to_string(r->size()) + " bytes");
        compressed.insert(compressed.end(), r->begin() + 2, r->begin() + 2 + long(n));
    }
    if (compressed.size() < expected)
        return make_error("configuration read: " + std::to_string(compressed.size()) +
                          " compressed bytes, fewer than the " + std::to_string(expected) +
                          " feature report 0x10 announced");
    bool truncated = false;
    auto json = gunzip(compressed, &truncated);
    if (!json) return make_error("configuration read: " + json.error().message);
    if (truncated)
        return make_error("configuration read: the zlib stream of " +
                          std::to_string(compressed.size()) + " bytes is cut short");
    return std::string(json->begin(), json->end());
}

namespace {

// A device's recorded feature-report replies, answered in capture order per report id.
class RecordedFeatures final : public Transport {
  public:
    std::map<uint8_t, std::deque<std::vector<uint8_t>>> replies;
    DeviceId id() const override { return {}; }
    Result<std::optional<InputReport>> read_input(int) override {
        return std::optional<InputReport>();
    }
    Result<std::vector<uint8_t>> get_feature(uint8_t report_id, size_t) override {
        auto it = replies.find(report_id);
        if (it == replies.end() || it->second.empty())
            return make_error("the capture holds no further reply to GET_REPORT " +
                              std::to_string(report_id));
        std::vector<uint8_t> r = std::move(it->second.front());
        it->second.pop_front();
        return r;
    }
    Status set_feature(std::span<const uint8_t>) override { return {}; }
    Status write_output(std::span<const uint8_t>) override { return {}; }
};

}  // namespace

Result<std::string> capture_lighthouse_config(const UsbCapture& capture, uint16_t bus,
                                              uint8_t address) {
    using namespace lighthouse_config;
    RecordedFeatures t;
    std::map<uint64_t, uint8_t> asked;  // urb id -> report id of a GET_REPORT(feature) submit
    for (const UsbPacket& u : capture.packets) {
        if (u.bus != bus || u.device_address != address || u.transfer_type != 2) continue;
        // GET_REPORT: bmRequestType 0xA1, bRequest 0x01, wValue = 0x03 (feature) << 8 | id.
        if (u.event == 'S' && u.setup_present && u.setup[0] == 0xa1 && u.setup[1] == 0x01 &&
            u.setup[3] == 0x03 && (u.setup[2] == kStartReportId || u.setup[2] == kChunkReportId))
            asked[u.urb_id] = u.setup[2];
        if (u.event == 'C' && u.status == 0 && !u.data.empty()) {
            auto it = asked.find(u.urb_id);
            if (it == asked.end()) continue;
            t.replies[it->second].push_back(u.data);
            asked.erase(it);
        }
    }
    if (t.replies[kStartReportId].empty())
        return make_error("the capture holds no configuration read (GET_REPORT 0x10) of device " +
                          std::to_string(bus) + "-" + std::to_string(address));
    return read_lighthouse_config(t);
}

namespace {
// The sensor model of a lighthouse_config object (`w` names it in errors).
Status read_model(const nlohmann::json& lc, const std::string& w, LighthouseSensors* out) {
    LighthouseSensors& s = *out;
    if (!lc.is_object()) return make_error(w + ": not an object");
    auto points = [&](const char* key, std::vector<glm::dvec3>* out) -> Status {
        if (!lc.contains(key)) return make_error(w + "." + key + ": missing");
        const nlohmann::json& a = lc[key];
        if (!a.is_array()) return make_error(w + "." + key + ": not an array");
        for (size_t i = 0; i < a.size(); ++i) {
            const nlohmann::json& v = a[i];
            if (!v.is_array() || v.size() != 3 || !v[0].is_number() || !v[1].is_number() ||
                !v[2].is_number())
                return make_error(w + "." + key + "[" + std::to_string(i) +
                                  "]: not an array of 3 numbers");
            glm::dvec3 p(v[0].get<double>(), v[1].get<double>(), v[2].get<double>());
            if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
                return make_error(w + "." + key + "[" + std::to_string(i) + "]: not finite");
            out->push_back(p);
        }
        return {};
    };
    if (Status st = points("modelPoints", &s.points); !st) return st.error();
    if (Status st = points("modelNormals", &s.normals); !st) return st.error();
    if (s.normals.size() != s.points.size())
        return make_error(w + ": " + std::to_string(s.points.size()) + " modelPoints but " +
                          std::to_string(s.normals.size()) + " modelNormals");
    if (lc.contains("channelMap")) {
        const nlohmann::json& a = lc["channelMap"];
        if (!a.is_array() || a.size() != s.points.size())
            return make_error(w + ".channelMap: not an array of " +
                              std::to_string(s.points.size()) + " channels");
        std::set<int> seen;
        for (size_t i = 0; i < a.size(); ++i) {
            if (!a[i].is_number_integer() || a[i].get<int64_t>() < 0 || a[i].get<int64_t>() > 255 ||
                !seen.insert(a[i].get<int>()).second)
                return make_error(w + ".channelMap[" + std::to_string(i) +
                                  "]: not a distinct channel 0..255");
            s.channel_map.push_back(a[i].get<int>());
        }
    }
    return {};
}
}  // namespace

Result<LighthouseSensors> parse_lighthouse_sensors(const std::string& text,
                                                   const std::string& source) {
    nlohmann::json j = nlohmann::json::parse(text, nullptr, false);
    if (j.is_discarded() || !j.is_object()) return make_error(source + ": not a JSON object");
    LighthouseSensors s;
    if (j.contains("lighthouse_config")) {
        if (Status st = read_model(j["lighthouse_config"], source + ": lighthouse_config", &s); !st)
            return st.error();
    }
    // The head frame: {plus_x, plus_z, position}, else trackref_from_head [qx qy qz qw x y z].
    auto vec = [](const nlohmann::json& a, glm::dvec3* v) {
        if (!a.is_array() || a.size() != 3 || !a[0].is_number() || !a[1].is_number() ||
            !a[2].is_number())
            return false;
        *v = glm::dvec3(a[0].get<double>(), a[1].get<double>(), a[2].get<double>());
        return std::isfinite(v->x) && std::isfinite(v->y) && std::isfinite(v->z);
    };
    if (j.contains("head") && j["head"].is_object() && j["head"].contains("plus_x")) {
        const nlohmann::json& h = j["head"];
        glm::dvec3 x, z(0, 0, 1), p(0.0);
        if (!vec(h["plus_x"], &x) || (h.contains("plus_z") && !vec(h["plus_z"], &z)) ||
            (h.contains("position") && !vec(h["position"], &p)))
            return make_error(source + ": head: plus_x, plus_z, position: not arrays of 3 numbers");
        if (std::abs(glm::length(x) - 1) > 0.01 || std::abs(glm::length(z) - 1) > 0.01 ||
            std::abs(glm::dot(x, z)) > 0.01)
            return make_error(source + ": head: plus_x and plus_z are not perpendicular unit axes");
        x = glm::normalize(x);
        z = glm::normalize(z - glm::dot(z, x) * x);
        s.model_from_head = glm::dmat3(x, glm::cross(z, x), z);
        s.head_origin = p;
    } else if (j.contains("trackref_from_head")) {
        auto pose = detail::config_pose7(j["trackref_from_head"], source + ": trackref_from_head");
        if (!pose) return pose.error();
        s.model_from_head = pose->first;
        s.head_origin = pose->second;
    }
    return s;
}

Result<LighthouseSensors> capture_sensor_model(const Result<std::string>& json,
                                               const std::string& file, const std::string& vid_pid,
                                               const std::string& purpose) {
    const std::string what = file + ": device " + vid_pid;
    if (!json)
        return make_error(what + ": no configuration read in the capture, so no sensor model " +
                          purpose + " (" + json.error().message + ")");
    auto sensors = parse_lighthouse_sensors(*json, file + ": the configuration");
    if (!sensors) return sensors.error();
    if (sensors->empty())
        return make_error(what + ": its configuration has no lighthouse_config (sensor model)");
    return sensors;
}

LighthouseModel lighthouse_model(const std::string& model_number) {
    std::string m = model_number;
    std::transform(m.begin(), m.end(), m.begin(),
                   [](unsigned char c) { return char(std::tolower(c)); });
    if (m.empty()) return LighthouseModel::Unknown;
    if (m.find("utah") != std::string::npos || m.find("index") != std::string::npos)
        return LighthouseModel::Index;
    if (m.find("vive_pro") != std::string::npos || m.find("vive pro") != std::string::npos)
        return LighthouseModel::VivePro;
    return LighthouseModel::Other;
}

}  // namespace hmdnode
