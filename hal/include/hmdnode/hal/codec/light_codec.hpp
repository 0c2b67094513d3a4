// Lighthouse light data of a Vive/Index-family device: the USB light reports, the light events
// they give on the device clock (48 MHz ticks), the angles each event measures, and the base
// stations' calibration frames carried in their sync signal (docs/tracking.md §9).
//
// Two systems, one decoder:
//  * Lighthouse 1 (report 0x25, a Vive HMD's endpoint 0x82; libsurvive's `C` lines): pulses
//    {sensor, start, length}. A sync flash lights most sensors at once, its length encoding three
//    bits (length ~ 3000 + 500 * code ticks; code = skip << 2 | data << 1 | axis); the two base
//    stations flash 20,000 ticks apart every 400,000 ticks (the first one is libsurvive's base
//    station 1, the second its 0); the one whose skip bit is clear then sweeps a laser plane along
//    its axis, and a sensor's hit at (pulse centre - that sync's start) = t gives the angle
//    t * pi / 400,000 - pi / 2. The data bits of one base station's syncs form its OOTX stream.
//  * Lighthouse 2 (report 0x28, a tracker's or an Index's light endpoint; libsurvive's `Y` and `W`
//    lines): sync events {channel, time, OOTX bit} once per rotor turn (~50 Hz, a rate per
//    channel) and sweep hits {channel, sensor, time}. The position in the rotor period, phase =
//    2 pi (t - sync) / period, is one of two planes tilted +-30 degrees: plane 0 sweeps a sensor at
//    phase - 2 pi / 3, plane 1 at phase - 4 pi / 3 (the angles libsurvive's `B` lines carry).
//
// decode_report rejects a truncated or unknown report, and a sensor beyond the device's model,
// with an error naming the report and byte, and then uses nothing of it. One thread.
// Cost: O(1) per pulse or word (a sync window sorts its pulses: O(n log n), n <= the sensors).
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <map>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "hmdnode/core/result.hpp"
#include "hmdnode/hal/codec/ootx.hpp"

namespace hmdnode::lighthouse {

constexpr double kTickHz = 48e6;
constexpr uint8_t kLh1ReportId = 0x25;  // libsurvive: VIVE_REPORT_USB_LIGHTCAP_REPORT_V1
constexpr uint8_t kLh2ReportId = 0x28;  // libsurvive: VIVE_REPORT_USB_LIGHTCAP_REPORT_RAW_MODE_1
constexpr size_t kLh1PulseBytes = 7;    // u8 sensor, u16 length, u32 start (little endian)
constexpr size_t kLh1PulsesPerReport = 9;
constexpr size_t kMaxSensors = 32;  // a device's photodiode channels (raw ids 0..31)
constexpr int kLh2Channels = 16;
constexpr int64_t kLh1CycleTicks = 400'000;  // one sync slot (120 per second)
constexpr int64_t kLh1PairTicks = 20'000;    // the second base station's flash after the first

// The device's 32-bit, 48 MHz clock. Its light events and its IMU samples are unwrapped from
// their own first ticks, so the two can lie whole turns apart: onto_imu_turn() moves a light
// time onto the turn of the IMU time it is nearest (the light tracking and the offline log do);
// imu_ticks() is an IMU sample's 32-bit tick, LightDecoder::note_imu_ticks()'s argument.
constexpr int64_t kClockTurnNs =
    int64_t(4294967296LL / 48 * 1000 + (4294967296LL % 48) * 1000 / 48);  // 2^32 ticks in ns
inline int64_t onto_imu_turn(int64_t light_ns, int64_t imu_ns) {
    const int64_t d = light_ns - imu_ns;
    if ((d < 0 ? -d : d) <= kClockTurnNs / 2) return light_ns;
    return light_ns - int64_t(std::llround(double(d) / double(kClockTurnNs))) * kClockTurnNs;
}
inline uint32_t imu_ticks(int64_t device_ns) {
    return uint32_t(uint64_t(device_ns) * 48 / 1000);
}

// Nominal rotor rate of a lighthouse-2 channel 0..15 (Hz), as libsurvive's table has them.
double lh2_rotor_hz(int channel);

// ---- Raw report contents --------------------------------------------------------------------

struct Lh1Pulse {
    uint8_t sensor = 0;  // raw photodiode channel
    uint32_t start = 0;  // 48 MHz ticks
    uint32_t length = 0;
};
struct Lh1Report {
    std::array<Lh1Pulse, kLh1PulsesPerReport> pulses{};
    size_t count = 0;          // slots with a sensor
    size_t device_stamps = 0;  // slots with id 0xfb, 0xfd (a camera frame) or 0xfe (vsync)
};
// Report 0x25: id + up to nine 7-byte slots. Slot id 0xff is empty; 0xfb, 0xfd and 0xfe carry the
// device's own time stamps (as Monado reads them), not pulses, and are skipped. A cut slot, or
// another report id, is an error naming the byte.
Result<Lh1Report> parse_lh1_report(std::span<const uint8_t> bytes);

struct Lh2Word {
    bool sweep = false;       // else a sync
    uint8_t channel = 0;      // from the channel byte before it
    uint8_t sensor = 0;       // sweep: raw photodiode channel (5 bits)
    uint32_t time24 = 0;      // 24 bits of the 48 MHz clock
    bool half_clock = false;  // sweep: a further half tick (the device's 96 MHz bit)
    bool ootx = false;        // sync: the OOTX bit
    bool gen = false;         // sync: libsurvive's "g" flag (constant per base station)
    bool conflict = false;    // the channel byte's flag: two base stations on one channel
    size_t byte = 0;          // where in the report the word starts
};
struct Lh2Report {
    std::array<Lh2Word, 16> words{};
    size_t count = 0;
};
// Report 0x28: id, payload length n, n bytes of channel bytes (bit 0 set: channel in bits 7..4,
// bit 2 the conflict flag, bits 1 and 3 clear) and 4-byte little-endian words (bit 0 clear; bit 1
// set: a sweep {sensor in bits 31..27, time in 26..3, half tick in 2}, clear: a sync {g flag 27,
// OOTX bit 26, time in 25..2}). A length beyond the report, a cut word, a word before any channel
// byte or a channel byte with bit 1 or 3 set is an error naming the byte.
Result<Lh2Report> parse_lh2_report(std::span<const uint8_t> bytes);
// Encoders for tests, fuzz seeds and simulated devices.
std::vector<uint8_t> encode_lh1_report(std::span<const Lh1Pulse> pulses);
std::vector<uint8_t> encode_lh2_report(std::span<const Lh2Word> words);

// ---- Events ---------------------------------------------------------------------------------

// A sweep hit with the angle it measures. `base_station`: the lighthouse-2 channel (0..15), or
// the lighthouse-1 base station (0 or 1, libsurvive's numbering: 1 flashes first).
struct LightEvent {
    Generation generation = Generation::lh2;
    uint8_t base_station = 0;
    uint8_t sensor = 0;          // the device model's sensor index (after its channel map)
    int64_t ticks = 0;           // lighthouse 2: the hit; lighthouse 1: the pulse's start
    int64_t device_time_ns = 0;  // of the hit (lighthouse 1: the pulse's centre)
    uint32_t timecode = 0;       // `ticks` on the device's 32-bit clock (a W / C line's)
    uint8_t plane = 0;           // lighthouse 2: the tilted plane 0/1; lighthouse 1: the axis 0/1
    bool half_clock = false;     // lighthouse 2
    uint32_t length = 0;         // lighthouse 1: the pulse's length (ticks)
    int64_t ticks_in_sweep = 0;  // lighthouse 1: pulse centre - the sweeping base station's sync
    double rotor_phase = 0;      // lighthouse 2: 2 pi (hit - sync) / period, in [0, 2 pi)
    double angle = 0;            // radians: as libsurvive's B (lighthouse 2) and A (1) lines
};

// A base station's sync as decoded (one per rotor turn / per lighthouse-1 flash).
struct SyncEvent {
    Generation generation = Generation::lh2;
    uint8_t base_station = 0;
    int64_t ticks = 0;      // lighthouse 1: the flash's start (earliest sensor)
    uint32_t timecode = 0;  // on the 32-bit clock
    int ootx = 0;           // the OOTX bit it carries
    bool gen = false;       // lighthouse 2: the "g" flag
    uint32_t length = 0;    // lighthouse 1: the longest sensor's pulse
    uint8_t code = 0;       // lighthouse 1: skip << 2 | data << 1 | axis
};

// The device's photodiodes: `channel_map[i]` is the raw channel of model sensor i (the device
// configuration's lighthouse_config.channelMap); empty means raw = model index, `count` sensors.
struct SensorModel {
    size_t count = kMaxSensors;
    std::vector<int> channel_map;
};

struct LightCounters {
    uint64_t reports = 0;   // reports given to decode_report
    uint64_t rejected = 0;  // of those, errors (nothing used)
    uint64_t lh1_pulses = 0;
    uint64_t lh1_device_stamps = 0;  // report 0x25 slots 0xfb/0xfd/0xfe (skipped)
    uint64_t lh2_words = 0;
    uint64_t syncs = 0;   // accepted sync events, both systems
    uint64_t events = 0;  // light events emitted
    // lighthouse 1
    uint64_t stray_sync_pulses = 0;    // sync-length pulses outside the window's main cluster
    uint64_t unassigned_syncs = 0;     // flashes that fit no base station's timing (yet)
    uint64_t pulses_in_sync = 0;       // short pulses inside a sync window
    uint64_t long_pulses = 0;          // >= 10,000 ticks (not a sweep; lh2 devices send them)
    uint64_t sweeps_without_sync = 0;  // no sweeping base station's sync in this slot
    uint64_t sweeps_out_of_slot = 0;   // centre outside (0, 400,000) ticks of its sync
    // lighthouse 2
    uint64_t early_syncs = 0;         // less than half a period after the last
    uint64_t off_rate_syncs = 0;      // a rotor rate more than 1 Hz off the channel's
    uint64_t sync_restarts = 0;       // a gap of more than 100 turns, or time going back
    uint64_t sweeps_before_sync = 0;  // no sync of the channel yet, or before it
    uint64_t late_sweeps = 0;         // more than 10 turns after the channel's last sync
    uint64_t channel_conflicts = 0;   // the report's "two base stations on one channel" flag
};

// What is known of one base station.
struct BaseStationState {
    Generation generation = Generation::lh2;
    uint8_t base_station = 0;
    uint64_t syncs = 0;
    uint64_t events = 0;
    int64_t first_sync_ticks = 0;  // (before a calibration: since the last restart)
    OotxCounters ootx;
    std::optional<BaseStationCalibration> calibration;  // the latest good frame's
    int64_t calibration_ticks = 0;     // the sync that completed the first good frame
    uint64_t calibration_changes = 0;  // good frames whose payload differs from the one before
};

class LightDecoder {
  public:
    explicit LightDecoder(SensorModel model = {});

    // A USB light report (0x25 or 0x28). An error names the report (its number among those
    // given, from 0) and byte; nothing of a rejected report is used.
    Status decode_report(std::span<const uint8_t> report);
    // The newest IMU sample's 32-bit tick: the reference that extends a report 0x28's 24-bit
    // times (as libsurvive does); without one, the last light time is.
    void note_imu_ticks(uint32_t ticks);

    // Events from a recording (libsurvive's lines), on the 32-bit clock. `raw_sensor` is a raw
    // channel (C lines), `sensor` a model index (W lines). An out-of-model sensor or channel is
    // an error naming it.
    Status add_lh1_pulse(uint8_t raw_sensor, uint32_t start, uint32_t length);
    Status add_lh2_sync(uint8_t channel, uint32_t timecode, bool ootx, bool gen);
    Status add_lh2_sweep(uint8_t channel, uint8_t sensor, uint32_t timecode, bool half_clock);
    // The end of the stream: emits the lighthouse-1 hits still held for their sweep.
    void finish();

    // The model index of a raw channel; an error when the model has none.
    Result<uint8_t> model_sensor(uint8_t raw) const;

    // Moves the events (and syncs) decoded since the last call to the end of `out`.
    void take_events(std::vector<LightEvent>& out);
    void take_syncs(std::vector<SyncEvent>& out);
    // Warnings since the last call: a bad CRC (naming the base station and the frame), a
    // calibration that changed, a channel conflict.
    std::vector<std::string> take_warnings();

    const LightCounters& counters() const { return counters_; }
    // Every base station seen, lighthouse 1 first, by number.
    std::vector<BaseStationState> base_stations() const;
    const BaseStationState* base_station(Generation g, uint8_t number) const;
    // "calibration: id 0x..., ... s after its first sync" or "no calibration yet (N OOTX bits,
    // ...)".
    std::string calibration_status(Generation g, uint8_t number) const;

  private:
    struct Pulse64 {
        uint8_t sensor;  // model index
        int64_t start;
        uint32_t length;
    };
    struct Lh1Sync {
        int64_t start = 0;
        uint32_t length = 0;
        uint8_t code = 0;
        int station = -1;
    };
    struct Lh2Channel {
        bool have_sync = false;
        int64_t last_sync = 0;
        double period = 0;    // ticks per turn; 0 = unknown (the nominal is used)
        uint64_t serial = 0;  // accepted syncs
        std::array<uint64_t, 64>
            last_hit_turn{};  // (serial << 8 | turn) + 1 of a sensor's last hit
    };

    int64_t unwrap(uint32_t timecode);
    uint32_t extend24(uint32_t time24);
    BaseStationState& station(Generation g, uint8_t number);
    void ootx_bits(BaseStationState& s, int64_t ticks, int missing, int bit);
    void lh1_pulse(const Pulse64& p);
    void lh1_close_window();
    void lh1_assign(Lh1Sync g);
    void lh1_accept(const Lh1Sync& g);
    void lh1_flush();
    void lh2_sync(uint8_t channel, int64_t ticks, uint32_t timecode, bool ootx, bool gen);
    void lh2_sweep(uint8_t channel, uint8_t sensor, int64_t ticks, uint32_t timecode, bool half);

    SensorModel model_;
    std::array<int, 256> raw_to_model_{};
    LightCounters counters_;
    std::vector<LightEvent> events_;
    std::vector<SyncEvent> syncs_;
    std::vector<std::string> warnings_;
    std::map<std::pair<int, int>, BaseStationState> stations_;
    std::map<std::pair<int, int>, OotxDecoder> ootx_;
    std::map<std::pair<int, int>, int64_t> last_bit_ticks_;

    bool have_time_ = false;
    uint32_t last_raw_ = 0;
    int64_t last_ticks_ = 0;
    bool have_imu_ = false;
    uint32_t imu_ticks_ = 0;

    // lighthouse 1
    std::vector<Pulse64> window_;
    int64_t window_first_ = 0;
    std::array<bool, 2> locked_{};
    std::array<int64_t, 2> station_last_{};
    std::optional<Lh1Sync> prev_;
    int single_chain_ = 0;  // consecutive unpaired flashes one cycle apart
    std::vector<Lh1Sync> slot_;
    std::vector<std::optional<Pulse64>> pending_;  // per model sensor: the longest hit this sweep

    // lighthouse 2
    std::array<Lh2Channel, kLh2Channels> channels_{};
};

// ---- The angle models -------------------------------------------------------------------------
// Points are in the base station's frame as libsurvive has it: x right, y up, the base station
// looking along -z.

// The angle plane 0 or 1 of a lighthouse-2 base station measures for a point, with that plane's
// calibration (all zero: the ideal planes tilted +-30 degrees); libsurvive's
// survive_reproject_axis_gen2.
double lh2_predict_angle(const PlaneCalibration& cal, int plane, const glm::dvec3& p);
// The angle axis 0 (x) or 1 (y) of a lighthouse-1 base station measures for a point;
// libsurvive's survive_reproject_axis (tilt as the frame holds it; tan() applied here).
double lh1_predict_angle(const PlaneCalibration& cal, int axis, const glm::dvec3& p);
// The ideal models inverted: the unit direction from the base station to the sensor.
glm::dvec3 lh2_ideal_direction(double angle0, double angle1);
glm::dvec3 lh1_ideal_direction(double angle_x, double angle_y);

}  // namespace hmdnode::lighthouse
