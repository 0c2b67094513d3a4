// Codec of the hmdnode reference tracker protocol 1.0 (our own design, docs/tracker-protocol.md;
// HID framing per the USB HID 1.11 specification, §6.2.2 report descriptor items, and the
// time-sync exchange after NTP, RFC 5905 §8 on-wire offset/delay formulas).
// Cost: O(report size) time per encode/decode, no memory beyond the returned report.
// Departures: the NTP exchange is carried by two feature-report transfers (set, then get) rather
// than one datagram each way, so the device's transmit stamp is taken when it answers the get.
#include "hmdnode/hal/codec/reference_protocol.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstring>
#include <limits>

namespace hmdnode::refproto {
namespace {

// Little-endian writers/readers over a byte vector / span (bounds are the caller's contract).
void put_u16(uint8_t* p, uint16_t v) {
    p[0] = uint8_t(v);
    p[1] = uint8_t(v >> 8);
}
void put_u32(uint8_t* p, uint32_t v) {
    for (int i = 0; i < 4; ++i) p[i] = uint8_t(v >> (8 * i));
}
void put_u64(uint8_t* p, uint64_t v) {
    for (int i = 0; i < 8; ++i) p[i] = uint8_t(v >> (8 * i));
}
uint16_t get_u16(const uint8_t* p) {
    return uint16_t(p[0] | (p[1] << 8));
}
uint32_t get_u32(const uint8_t* p) {
    uint32_t v = 0;
    for (int i = 0; i < 4; ++i) v |= uint32_t(p[i]) << (8 * i);
    return v;
}
uint64_t get_u64(const uint8_t* p) {
    uint64_t v = 0;
    for (int i = 0; i < 8; ++i) v |= uint64_t(p[i]) << (8 * i);
    return v;
}
int32_t get_i32(const uint8_t* p) {
    return int32_t(get_u32(p));
}

int32_t to_fixed32(double v, double unit) {
    const double x = std::round(v / unit);
    if (!(x == x)) return 0;  // NaN
    return int32_t(std::clamp(x, double(std::numeric_limits<int32_t>::min()),
                              double(std::numeric_limits<int32_t>::max())));
}

void put_vec3(uint8_t* p, const glm::dvec3& v, double unit) {
    for (int i = 0; i < 3; ++i) put_u32(p + 4 * i, uint32_t(to_fixed32(v[i], unit)));
}
glm::dvec3 get_vec3(const uint8_t* p, double unit) {
    return {get_i32(p) * unit, get_i32(p + 4) * unit, get_i32(p + 8) * unit};
}

std::string hex_id(uint8_t id) {
    static const char* d = "0123456789abcdef";
    return std::string("0x") + d[id >> 4] + d[id & 15];
}

// Common header checks: length, report id, major version. Returns an empty string when good.
std::string check_header(std::span<const uint8_t> b, uint8_t id, size_t size, const char* name) {
    const std::string what = std::string(name) + " report " + hex_id(id);
    if (b.empty()) return what + ": empty report";
    if (b[0] != id) return what + ": byte 0 (report id) is " + hex_id(b[0]);
    if (b.size() < 2) return what + ": " + std::to_string(b.size()) + " bytes, needs 2";
    if ((b[1] >> 4) != kVersionMajor)
        return what + ": byte 1 (version) has major version " + std::to_string(b[1] >> 4) +
               ", this decoder reads major " + std::to_string(kVersionMajor);
    if (b.size() < size)
        return what + ": " + std::to_string(b.size()) + " bytes, version 1.x needs " +
               std::to_string(size);
    return {};
}

std::string get_string(const uint8_t* p, size_t n, bool* ok) {
    assert(p != nullptr && ok != nullptr);
    std::string s;
    for (size_t i = 0; i < n && p[i] != 0; ++i) {
        if (p[i] < 0x20 || p[i] > 0x7e) *ok = false;
        s.push_back(char(p[i]));
    }
    return s;
}
void put_string(uint8_t* p, size_t n, const std::string& s) {
    assert(p != nullptr);
    std::memcpy(p, s.data(), std::min(n, s.size()));
}

// Report descriptor: one vendor application collection; every report is an opaque byte array of
// its exact size (HID 1.11 §6.2.2: Report ID 0x85, Usage 0x09, Report Count 0x95, Input 0x81,
// Feature 0xB1).
constexpr uint8_t kDescriptor[] = {
    0x06, 0x00, 0xFF,                              // Usage Page (Vendor Defined 0xFF00)
    0x09, 0x01,                                    // Usage (0x01)
    0xA1, 0x01,                                    // Collection (Application)
    0x15, 0x00,                                    //   Logical Minimum (0)
    0x26, 0xFF, 0x00,                              //   Logical Maximum (255)
    0x75, 0x08,                                    //   Report Size (8)
    0x85, 0x01, 0x09, 0x21, 0x95, 63, 0x81, 0x02,  // pose: 63 bytes after the id, Input
    0x85, 0x02, 0x09, 0x22, 0x95, 63, 0x81, 0x02,  // IMU samples, Input
    0x85, 0x10, 0x09, 0x30, 0x95, 63, 0xB1, 0x02,  // device info, Feature
    0x85, 0x11, 0x09, 0x31, 0x95, 31, 0xB1, 0x02,  // calibration, Feature
    0x85, 0x12, 0x09, 0x32, 0x95, 7,  0xB1, 0x02,  // report rate, Feature
    0x85, 0x13, 0x09, 0x33, 0x95, 31, 0xB1, 0x02,  // time sync, Feature
    0xC0,                                          // End Collection
};

}  // namespace

double ImuReport::gyro_scale() const {
    return gyro_range_dps / 32768.0 * (3.14159265358979323846 / 180.0);
}

std::span<const uint8_t> report_descriptor() {
    return kDescriptor;
}

TimeSyncEstimate time_sync_estimate(const TimeSyncReport& a, int64_t host_receive_ns) {
    // 128-bit arithmetic: device stamps are untrusted and may be anywhere in u64 µs.
    using i128 = __int128;
    const i128 t1 = a.host_send_ns;
    const i128 t2 = i128(a.device_receive_us) * 1000;
    const i128 t3 = i128(a.device_transmit_us) * 1000;
    const i128 t4 = host_receive_ns;
    auto sat = [](i128 v) {
        return int64_t(std::clamp<i128>(v, std::numeric_limits<int64_t>::min(),
                                        std::numeric_limits<int64_t>::max()));
    };
    TimeSyncEstimate e;
    e.offset_ns = sat(((t1 - t2) + (t4 - t3)) / 2);  // host - device
    e.round_trip_ns = sat((t4 - t1) - (t3 - t2));
    return e;
}

// ---- encoders ----

std::vector<uint8_t> encode(const PoseReport& r) {
    std::vector<uint8_t> b(kPoseReportSize, 0);
    b[0] = kPoseReport;
    b[1] = kVersionByte;
    b[2] = r.flags;
    put_u32(&b[4], r.sequence);
    put_u64(&b[8], r.device_time_us);
    const glm::dquat q = r.orientation;
    const double c[4] = {q.w, q.x, q.y, q.z};
    for (int i = 0; i < 4; ++i)
        put_u32(&b[16 + 4 * i], uint32_t(to_fixed32(c[i], 1.0 / kQuatScale)));
    if (r.flags & kPoseFlagPositionValid) put_vec3(&b[32], r.position_m, kPositionUnitM);
    if (r.flags & kPoseFlagAngularVelocityValid)
        put_vec3(&b[44], r.angular_velocity, kAngVelUnitRadS);
    return b;
}

std::vector<uint8_t> encode(const ImuReport& r) {
    assert(r.count <= kMaxImuSamples);
    std::vector<uint8_t> b(kImuReportSize, 0);
    b[0] = kImuReport;
    b[1] = kVersionByte;
    b[2] = r.count;
    b[3] = r.accel_range_g;
    put_u16(&b[4], r.gyro_range_dps);
    put_u32(&b[8], r.first_sequence);
    put_u64(&b[12], r.device_time_us);
    for (size_t i = 0; i < r.count; ++i) {
        assert(20 + 14 * (i + 1) <= b.size());  // the sample's 14 bytes lie within the report
        uint8_t* p = &b[20 + 14 * i];
        const ImuSample& s = r.samples[i];
        put_u16(p, s.dt_us);
        for (int k = 0; k < 3; ++k) put_u16(p + 2 + 2 * k, uint16_t(s.accel[k]));
        for (int k = 0; k < 3; ++k) put_u16(p + 8 + 2 * k, uint16_t(s.gyro[k]));
    }
    return b;
}

std::vector<uint8_t> encode(const DeviceInfoReport& r) {
    std::vector<uint8_t> b(kDeviceInfoReportSize, 0);
    b[0] = kDeviceInfoReport;
    b[1] = kVersionByte;
    b[2] = r.firmware_major;
    b[3] = r.firmware_minor;
    put_u16(&b[4], r.firmware_patch);
    put_u32(&b[6], r.capabilities);
    put_u16(&b[10], r.pose_rate_hz);
    put_u16(&b[12], r.imu_rate_hz);
    put_string(&b[16], 16, r.serial);
    put_string(&b[32], 32, r.product);
    return b;
}

std::vector<uint8_t> encode(const CalibrationReport& r) {
    std::vector<uint8_t> b(kCalibrationReportSize, 0);
    b[0] = kCalibrationReport;
    b[1] = kVersionByte;
    b[2] = r.accel_range_g;
    put_u16(&b[4], r.gyro_range_dps);
    put_vec3(&b[8], r.gyro_bias, kBiasGyroUnitRadS);
    put_vec3(&b[20], r.accel_bias, kBiasAccelUnitMs2);
    return b;
}

std::vector<uint8_t> encode(const ReportRateReport& r) {
    std::vector<uint8_t> b(kReportRateReportSize, 0);
    b[0] = kReportRateReport;
    b[1] = kVersionByte;
    put_u16(&b[2], r.pose_rate_hz);
    put_u16(&b[4], r.imu_rate_hz);
    return b;
}

std::vector<uint8_t> encode(const TimeSyncReport& r) {
    std::vector<uint8_t> b(kTimeSyncReportSize, 0);
    b[0] = kTimeSyncReport;
    b[1] = kVersionByte;
    put_u32(&b[4], r.nonce);
    put_u64(&b[8], uint64_t(r.host_send_ns));
    put_u64(&b[16], r.device_receive_us);
    put_u64(&b[24], r.device_transmit_us);
    return b;
}

// ---- decoders ----

Result<PoseReport> decode_pose(std::span<const uint8_t> b) {
    if (auto e = check_header(b, kPoseReport, kPoseReportSize, "pose"); !e.empty())
        return make_error(e);
    assert(b.size() >= kPoseReportSize);  // check_header: every field below lies within b
    PoseReport r;
    r.version = b[1];
    r.flags = b[2];
    r.sequence = get_u32(&b[4]);
    r.device_time_us = get_u64(&b[8]);
    glm::dquat q(get_i32(&b[16]) / kQuatScale, get_i32(&b[20]) / kQuatScale,
                 get_i32(&b[24]) / kQuatScale, get_i32(&b[28]) / kQuatScale);
    if (r.flags & kPoseFlagOrientationValid) {
        const double n = glm::length(q);
        if (!(n > 0.9 && n < 1.1))
            return make_error("pose report 0x01: bytes 16-31 (orientation) have norm " +
                              std::to_string(n) + ", not a unit quaternion");
        q = q / n;
    } else {
        q = glm::dquat(1, 0, 0, 0);
    }
    r.orientation = q;
    if (r.flags & kPoseFlagPositionValid) r.position_m = get_vec3(&b[32], kPositionUnitM);
    if (r.flags & kPoseFlagAngularVelocityValid)
        r.angular_velocity = get_vec3(&b[44], kAngVelUnitRadS);
    return r;
}

Result<ImuReport> decode_imu(std::span<const uint8_t> b) {
    if (auto e = check_header(b, kImuReport, kImuReportSize, "IMU"); !e.empty())
        return make_error(e);
    assert(b.size() >= kImuReportSize);
    ImuReport r;
    r.version = b[1];
    r.count = b[2];
    if (r.count < 1 || r.count > kMaxImuSamples)
        return make_error("IMU report 0x02: byte 2 (count) is " + std::to_string(r.count) +
                          ", must be 1.." + std::to_string(kMaxImuSamples));
    r.accel_range_g = b[3];
    r.gyro_range_dps = get_u16(&b[4]);
    if (r.accel_range_g == 0) return make_error("IMU report 0x02: byte 3 (accel range) is 0");
    if (r.gyro_range_dps == 0) return make_error("IMU report 0x02: bytes 4-5 (gyro range) are 0");
    r.first_sequence = get_u32(&b[8]);
    r.device_time_us = get_u64(&b[12]);
    for (size_t i = 0; i < r.count; ++i) {
        assert(20 + 14 * (i + 1) <= b.size());  // count <= kMaxImuSamples keeps the cursor in
        const uint8_t* p = &b[20 + 14 * i];
        ImuSample& s = r.samples[i];
        s.dt_us = get_u16(p);
        for (int k = 0; k < 3; ++k) s.accel[k] = int16_t(get_u16(p + 2 + 2 * k));
        for (int k = 0; k < 3; ++k) s.gyro[k] = int16_t(get_u16(p + 8 + 2 * k));
        if (i == 0 && s.dt_us != 0)
            return make_error("IMU report 0x02: bytes 20-21 (first sample dt) must be 0");
        if (i > 0 && s.dt_us <= r.samples[i - 1].dt_us)
            return make_error("IMU report 0x02: byte " + std::to_string(20 + 14 * i) +
                              " (sample dt) does not increase");
    }
    return r;
}

Result<DeviceInfoReport> decode_device_info(std::span<const uint8_t> b) {
    if (auto e = check_header(b, kDeviceInfoReport, kDeviceInfoReportSize, "device-info");
        !e.empty())
        return make_error(e);
    assert(b.size() >= kDeviceInfoReportSize);
    DeviceInfoReport r;
    r.version = b[1];
    r.firmware_major = b[2];
    r.firmware_minor = b[3];
    r.firmware_patch = get_u16(&b[4]);
    r.capabilities = get_u32(&b[6]);
    r.pose_rate_hz = get_u16(&b[10]);
    r.imu_rate_hz = get_u16(&b[12]);
    bool ok = true;
    r.serial = get_string(&b[16], 16, &ok);
    if (!ok) return make_error("device-info report 0x10: bytes 16-31 (serial) are not ASCII");
    r.product = get_string(&b[32], 32, &ok);
    if (!ok) return make_error("device-info report 0x10: bytes 32-63 (product) are not ASCII");
    return r;
}

Result<CalibrationReport> decode_calibration(std::span<const uint8_t> b) {
    if (auto e = check_header(b, kCalibrationReport, kCalibrationReportSize, "calibration");
        !e.empty())
        return make_error(e);
    assert(b.size() >= kCalibrationReportSize);
    CalibrationReport r;
    r.version = b[1];
    r.accel_range_g = b[2];
    r.gyro_range_dps = get_u16(&b[4]);
    if (r.accel_range_g == 0)
        return make_error("calibration report 0x11: byte 2 (accel range) is 0");
    if (r.gyro_range_dps == 0)
        return make_error("calibration report 0x11: bytes 4-5 (gyro range) are 0");
    r.gyro_bias = get_vec3(&b[8], kBiasGyroUnitRadS);
    r.accel_bias = get_vec3(&b[20], kBiasAccelUnitMs2);
    return r;
}

Result<ReportRateReport> decode_report_rate(std::span<const uint8_t> b) {
    if (auto e = check_header(b, kReportRateReport, kReportRateReportSize, "report-rate");
        !e.empty())
        return make_error(e);
    assert(b.size() >= kReportRateReportSize);
    ReportRateReport r;
    r.version = b[1];
    r.pose_rate_hz = get_u16(&b[2]);
    r.imu_rate_hz = get_u16(&b[4]);
    return r;
}

Result<TimeSyncReport> decode_time_sync(std::span<const uint8_t> b) {
    if (auto e = check_header(b, kTimeSyncReport, kTimeSyncReportSize, "time-sync"); !e.empty())
        return make_error(e);
    assert(b.size() >= kTimeSyncReportSize);
    TimeSyncReport r;
    r.version = b[1];
    r.nonce = get_u32(&b[4]);
    r.host_send_ns = int64_t(get_u64(&b[8]));
    r.device_receive_us = get_u64(&b[16]);
    r.device_transmit_us = get_u64(&b[24]);
    return r;
}

}  // namespace hmdnode::refproto
