// libFuzzer harness: the lighthouse light decoder on untrusted input. The first byte picks the
// mode: 0, a stream of USB reports (each chunk's first byte its length; a chunk starting 0x20
// gives an IMU tick reference instead) through LightDecoder with a 24-sensor channel map; 1, text
// as a libsurvive recording (device T20) whose light lines are replayed into the decoder; 2, an
// OOTX bit stream (each byte: 0, 1 or unknown). Invariants: an event's sensor is in the model,
// its angles finite and in range; a refused report adds nothing; a good frame's payload fits.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <span>
#include <string>
#include <vector>

#include "hmdnode/hal/codec/light_codec.hpp"
#include "hmdnode/hal/codec/ootx.hpp"
#include "hmdnode/hal/tracking/survive_recording.hpp"

namespace {

using namespace hmdnode;
using namespace hmdnode::lighthouse;
constexpr double kPi = 3.14159265358979323846;

void check(LightDecoder& dec, size_t sensors) {
    std::vector<LightEvent> events;
    dec.take_events(events);
    for (const LightEvent& e : events) {
        if (e.sensor >= sensors || !std::isfinite(e.angle)) abort();
        if (e.generation == Generation::lh1 && (e.angle <= -kPi / 2 || e.angle >= kPi / 2)) abort();
        if (e.generation == Generation::lh2 &&
            (e.base_station >= kLh2Channels || !std::isfinite(e.rotor_phase) ||
             std::abs(e.rotor_phase) > 4 * kPi))
            abort();
    }
    for (const BaseStationState& s : dec.base_stations()) {
        if (s.calibration && s.calibration->payload.size() > kMaxPayload) abort();
        (void)dec.calibration_status(s.generation, s.base_station);
    }
    (void)dec.take_warnings();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    if (size == 0) return 0;
    const uint8_t mode = data[0] % 3;
    ++data;
    --size;
    if (mode == 0) {
        SensorModel m;
        for (int c = 1; c <= 25; ++c)
            if (c != 18) m.channel_map.push_back(c);
        LightDecoder dec(m);
        size_t i = 0;
        while (i < size) {
            const size_t n = std::min<size_t>(data[i], size - i - 1);
            std::span<const uint8_t> report(data + i + 1, n);
            i += 1 + n;
            if (n >= 5 && report[0] == 0x20) {
                dec.note_imu_ticks(uint32_t(report[1]) | uint32_t(report[2]) << 8 |
                                   uint32_t(report[3]) << 16 | uint32_t(report[4]) << 24);
                continue;
            }
            const LightCounters before = dec.counters();
            Status st = dec.decode_report(report);
            if (!st.ok() &&
                (dec.counters().syncs != before.syncs || dec.counters().events != before.events ||
                 dec.counters().lh1_pulses != before.lh1_pulses ||
                 dec.counters().lh2_words != before.lh2_words))
                abort();
            check(dec, m.channel_map.size());
        }
        dec.finish();
        check(dec, m.channel_map.size());
    } else if (mode == 1) {
        auto rec = parse_survive_recording(std::string(reinterpret_cast<const char*>(data), size),
                                           "fuzz.rec", "T20");
        if (!rec.ok()) return 0;
        const SensorModel m = survive_sensor_model(*rec);
        LightDecoder dec(m);
        (void)replay_survive_light(*rec, dec);
        check(dec, m.count);
    } else {
        OotxDecoder dec;
        for (size_t i = 0; i < size; ++i) {
            if (data[i] == 0xff) {
                dec.reset();
                continue;
            }
            auto f = dec.push(int(data[i] % 3) - 1);
            if (f && f->crc_ok) {
                if (f->payload.size() > kMaxPayload) abort();
                (void)parse_ootx_payload(Generation::lh1, f->payload);
                (void)parse_ootx_payload(Generation::lh2, f->payload);
            }
        }
    }
    return 0;
}
