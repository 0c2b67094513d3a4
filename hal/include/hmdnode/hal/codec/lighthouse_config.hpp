// The JSON configuration a Vive/Index-family device (HMD, controller, tracker) keeps in flash: its
// factory IMU calibration (`imu`), axes, model name, lighthouse sensor positions. Read over HID
// feature reports: GET_FEATURE 0x10 starts a read and answers the compressed size (bytes 1-2, big
// endian); GET_FEATURE 0x11 then answers one chunk at a time (byte 1: its length, up to 62; bytes
// 2..: the data) until a chunk of length 0; the concatenation is a zlib stream of the JSON. This
// is the exchange libsurvive (driver_vive.config.h) and Monado (vive_config.c) perform.
// The sensor model (lighthouse_config) is read from the same JSON. Cost: one feature-report round
// trip per 62 compressed bytes (~30 for an Index's ~1.8 kB), O(inflated size) memory.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "hmdnode/core/result.hpp"
#include "hmdnode/hal/transport.hpp"
#include "hmdnode/hal/transport/usbmon_capture.hpp"

namespace hmdnode {

namespace lighthouse_config {
constexpr uint8_t kStartReportId = 0x10;
constexpr uint8_t kChunkReportId = 0x11;
constexpr size_t kReportSize = 64;
constexpr size_t kMaxChunks = 4096;  // 248 kB compressed: far beyond any device's config
}  // namespace lighthouse_config

// The inflated JSON text. Errors name the report and byte: a transport error, a reply of another
// report id, a chunk length beyond its report, more than kMaxChunks chunks, fewer bytes than the
// start report announced, a stream zlib cannot inflate or that is cut short.
Result<std::string> read_lighthouse_config(Transport& transport);

// The same read from a capture that recorded it: device BUS-ADDRESS's feature-report replies
// (GET_REPORT 0x10, then the 0x11 chunks in capture order), as the capture backend cannot replay
// them (it answers each id with its first reply). An error when the capture holds no such read.
Result<std::string> capture_lighthouse_config(const UsbCapture& capture, uint16_t bus,
                                              uint8_t address);

// The photodiodes of a configuration's `lighthouse_config`: positions and normals in the device's
// tracking-reference frame (metres), and channelMap (model sensor i is raw channel
// channel_map[i]); and where the device's head frame (the frame libsurvive's poses are of) lies in
// it: p_model = model_from_head * p_head + head_origin, from the `head` object (plus_x, plus_z,
// position) or `trackref_from_head` ([qx, qy, qz, qw, x, y, z], a Vive HMD's), as libsurvive's
// solve_vive_pose and vive_json_pose_to_survive_pose read them; identity without either.
struct LighthouseSensors {
    std::vector<glm::dvec3> points;
    std::vector<glm::dvec3> normals;
    std::vector<int> channel_map;
    glm::dmat3 model_from_head{1.0};
    glm::dvec3 head_origin{0.0};
    bool empty() const { return points.empty(); }
    // A model point in the head frame.
    glm::dvec3 in_head(const glm::dvec3& p) const {
        return glm::transpose(model_from_head) * (p - head_origin);
    }
};
// Absent lighthouse_config: empty. A malformed one (not arrays of 3 numbers, counts that differ,
// a channel outside 0..255 or repeated, a head frame whose axes are not perpendicular unit
// vectors) is an error naming the field; `source` names the text.
Result<LighthouseSensors> parse_lighthouse_sensors(const std::string& json,
                                                   const std::string& source);

// The sensor model of device VID_PID in capture FILE from the configuration read the capture
// recorded (`json`, capture_lighthouse_config's result). Errors name the file and the device:
// no configuration read ("so no sensor model " + purpose, e.g. "to solve its light with"), a
// malformed lighthouse_config, or none.
Result<LighthouseSensors> capture_sensor_model(const Result<std::string>& json,
                                               const std::string& file, const std::string& vid_pid,
                                               const std::string& purpose);

// Which device a configuration describes, for the IMU axes (28de:2300 is an Index's and also a
// Vive Pro's): from `model_number` (e.g. "Utah MP" on an Index, "VIVE_Pro MV" on a Vive Pro).
enum class LighthouseModel { Index, VivePro, Other, Unknown };
LighthouseModel lighthouse_model(const std::string& model_number);

}  // namespace hmdnode
