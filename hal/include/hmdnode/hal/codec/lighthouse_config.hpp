// The JSON configuration a Vive/Index-family device (HMD, controller, tracker) keeps in flash: its
// factory IMU calibration (`imu`), axes, model name, lighthouse sensor positions. Read over HID
// feature reports: GET_FEATURE 0x10 starts a read and answers the compressed size (bytes 1-2, big
// endian); GET_FEATURE 0x11 then answers one chunk at a time (byte 1: its length, up to 62; bytes
// 2..: the data) until a chunk of length 0; the concatenation is a zlib stream of the JSON. This
// is the exchange libsurvive (driver_vive.config.h) and Monado (vive_config.c) perform.
// Cost: one feature-report round trip per 62 compressed bytes (~30 for an Index's ~1.8 kB),
// O(inflated size) memory.
#pragma once

#include <cstdint>
#include <string>

#include "hmdnode/core/result.hpp"
#include "hmdnode/hal/transport.hpp"

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

// Which device a configuration describes, for the IMU axes (28de:2300 is an Index's and also a
// Vive Pro's): from `model_number` (e.g. "Utah MP" on an Index, "VIVE_Pro MV" on a Vive Pro).
enum class LighthouseModel { Index, VivePro, Other, Unknown };
LighthouseModel lighthouse_model(const std::string& model_number);

}  // namespace hmdnode
