// The light codec on real captures: every light report of a Vive HMD's lighthouse-1 capture
// (report 0x25) and of a lighthouse-2 device's (report 0x28) decodes without error into events on
// the device's own sensors and base stations, with angles in range and every base station's
// calibration frame decoded with a good CRC, the same on every repeat. On synthetic base stations
// (the angle models inverted) the decoded angles are the model's. Bad reports (cut, unknown, a
// sensor beyond the model) are errors naming the report and byte, and give nothing.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "hal/light_capture.hpp"
#include "hmdnode/hal/codec/light_codec.hpp"
#include "hmdnode/hal/codec/ootx.hpp"

namespace hmdnode {
namespace {

using namespace lighthouse;
constexpr double kPi = 3.14159265358979323846;
const std::string kTraces = std::string(HMDNODE_SOURCE_DIR) + "/data/traces/";

// The Knuckles/tracker model of the lighthouse-2 capture: 24 sensors, raw channels 0 and 18 unused.
SensorModel knuckles_model() {
    SensorModel m;
    for (int c = 1; c <= 25; ++c)
        if (c != 18) m.channel_map.push_back(c);
    m.count = m.channel_map.size();
    return m;
}

TEST(LightCodec, EveryLightReportOfTheViveCaptureDecodesOnItsSensorsAndBaseStations) {
    auto d = test::decode_light_capture(kTraces + "vive_cal.pcap.gz", 1, 62, 0x82);
    ASSERT_TRUE(d);
    EXPECT_EQ(d->sensors, 32u);  // the HMD's own configuration, read from the capture
    EXPECT_EQ(d->reports_by_id.size(), 1u);
    EXPECT_EQ(d->reports_by_id[kLh1ReportId], 16311u);
    EXPECT_EQ(d->rejected_by_id[kLh1ReportId], 0u);
    ASSERT_TRUE(d->errors.empty()) << d->errors.front();
    EXPECT_TRUE(d->warnings.empty()) << d->warnings.front();

    // Two base stations flash 240 times a second between them over the capture's 22.4 s.
    ASSERT_GT(d->syncs.size(), 2u);
    const double span_s = double(d->syncs.back().ticks - d->syncs.front().ticks) / kTickHz;
    EXPECT_NEAR(double(d->syncs.size()) / span_s, 240.0, 1.0);
    EXPECT_EQ(d->syncs.size(), 5376u);
    EXPECT_LE(d->dec.counters().unassigned_syncs, 2u);

    std::map<std::pair<int, int>, uint64_t> per_station_axis;
    std::set<int> sensors;
    for (const LightEvent& e : d->events) {
        ASSERT_EQ(e.generation, Generation::lh1);
        ASSERT_LT(e.sensor, 32);
        ASSERT_LT(e.base_station, 2);
        ASSERT_GT(e.angle, -kPi / 2);
        ASSERT_LT(e.angle, kPi / 2);
        ASSERT_GT(e.ticks_in_sweep, 0);
        ++per_station_axis[{e.base_station, e.plane}];
        sensors.insert(e.sensor);
    }
    EXPECT_EQ(d->events.size(), 30797u);
    EXPECT_GE(sensors.size(), 24u);  // a headset lying still: its top and front sensors
    for (int lh = 0; lh < 2; ++lh)
        for (int axis = 0; axis < 2; ++axis)
            EXPECT_GT((per_station_axis[{lh, axis}]), 7000u)
                << "base station " << lh << " axis " << axis;

    // Both base stations' calibration, repeated with the same payload every time.
    const std::map<int, uint32_t> ids = {{0, 0xf77e21f3u}, {1, 0x0aa54f65u}};
    for (auto [lh, id] : ids) {
        const BaseStationState* s = d->dec.base_station(Generation::lh1, uint8_t(lh));
        ASSERT_NE(s, nullptr);
        ASSERT_TRUE(s->calibration) << d->dec.calibration_status(Generation::lh1, uint8_t(lh));
        EXPECT_EQ(s->calibration->id, id);
        EXPECT_EQ(s->calibration->payload.size(), kLh1PayloadBytes);
        EXPECT_EQ(s->calibration->firmware_version, 0x6d06);
        EXPECT_GE(s->ootx.good_frames, 4u);
        EXPECT_EQ(s->ootx.bad_crc, 0u);
        EXPECT_EQ(s->calibration_changes, 0u);
        for (const PlaneCalibration& p : s->calibration->plane) {
            EXPECT_LT(std::abs(p.phase), 0.1);
            EXPECT_LT(std::abs(p.tilt), 0.05);
            EXPECT_LT(std::abs(p.curve), 0.05);
            EXPECT_EQ(p.ogee_mag, 0.0);
        }
        EXPECT_EQ(
            d->dec.calibration_status(Generation::lh1, uint8_t(lh)).rfind("calibration: id ", 0),
            0u);
    }
}

TEST(LightCodec, EveryLightReportOfTheLighthouse2CaptureDecodesOnItsSensorsAndChannels) {
    auto d = test::decode_light_capture(kTraces + "lh2_test_cal.pcap.gz", 1, 8, 0x83);
    ASSERT_TRUE(d);
    EXPECT_EQ(d->sensors, 24u);
    EXPECT_EQ(d->reports_by_id[kLh2ReportId], 1804u);
    EXPECT_EQ(d->rejected_by_id[kLh2ReportId], 0u);
    // Reports 0x25 before the device is switched to its lighthouse-2 mode decode, but hold no
    // lighthouse-1 flash pattern: no lighthouse-1 event or base station comes of them.
    EXPECT_EQ(d->reports_by_id[kLh1ReportId], 50u);
    EXPECT_EQ(d->rejected_by_id[kLh1ReportId], 0u);
    EXPECT_EQ(d->dec.base_station(Generation::lh1, 0), nullptr);
    EXPECT_EQ(d->dec.base_station(Generation::lh1, 1), nullptr);
    // One report 0x27 (the device's other lighthouse-2 mode) is refused, by number and id.
    EXPECT_EQ(d->rejected_by_id[0x27], 1u);
    ASSERT_EQ(d->errors.size(), 1u);
    EXPECT_EQ(d->errors[0].rfind("light report 50 (id 0x27): ", 0), 0u) << d->errors[0];

    std::map<int, uint64_t> per_channel;
    std::set<int> sensors;
    for (const LightEvent& e : d->events) {
        ASSERT_EQ(e.generation, Generation::lh2);
        ASSERT_LT(e.sensor, 24);
        ASSERT_GE(e.rotor_phase, 0);
        ASSERT_LT(e.rotor_phase, 2 * kPi);
        ASSERT_LT(std::abs(e.angle), kPi / 2);
        ++per_channel[e.base_station];
        sensors.insert(e.sensor);
    }
    EXPECT_EQ(d->events.size(), 19303u);
    EXPECT_EQ(per_channel.size(), 2u);
    EXPECT_GT(per_channel[6], 9000u);
    EXPECT_GT(per_channel[10], 9000u);
    EXPECT_GE(sensors.size(), 10u);
    // One sync per rotor turn, at each channel's rate (the median turn between syncs; some turns
    // are not seen).
    std::map<int, std::vector<int64_t>> sync_ticks;
    for (const SyncEvent& s : d->syncs) sync_ticks[s.base_station].push_back(s.ticks);
    for (auto& [ch, t] : sync_ticks) {
        const double nominal = kTickHz / lh2_rotor_hz(ch);
        std::vector<double> turn;
        for (size_t i = 1; i < t.size(); ++i) {
            const double dt = double(t[i] - t[i - 1]), n = std::round(dt / nominal);
            if (n >= 1 && n <= 10) turn.push_back(dt / n);
        }
        ASSERT_GT(turn.size(), 800u);
        std::nth_element(turn.begin(), turn.begin() + long(turn.size() / 2), turn.end());
        EXPECT_NEAR(kTickHz / turn[turn.size() / 2], lh2_rotor_hz(ch), 0.01) << "channel " << ch;
    }
    const std::map<int, uint32_t> ids = {{6, 0xa4dbc8a4u}, {10, 0xdadd6923u}};
    for (auto [ch, id] : ids) {
        const BaseStationState* s = d->dec.base_station(Generation::lh2, uint8_t(ch));
        ASSERT_NE(s, nullptr);
        ASSERT_TRUE(s->calibration) << d->dec.calibration_status(Generation::lh2, uint8_t(ch));
        EXPECT_EQ(s->calibration->id, id);
        EXPECT_EQ(s->calibration->payload.size(), kLh2PayloadBytes);
        EXPECT_EQ(s->ootx.bad_crc, 0u);
        for (const PlaneCalibration& p : s->calibration->plane) {
            EXPECT_LT(std::abs(p.phase), 0.1);
            EXPECT_LT(std::abs(p.tilt), 0.1);
        }
    }
    EXPECT_TRUE(d->warnings.empty()) << d->warnings.front();
}

// ---- Synthetic base stations --------------------------------------------------------------------

TEST(LightCodec, ALighthouse2SweepGivesTheAnglesOfTheIdealModelAndItsCalibrationFrame) {
    const int ch = 3;
    const double period = kTickHz / lh2_rotor_hz(ch);
    const glm::dvec3 p(0.4, -0.25, -2.0);  // in front of the base station (-z)
    const PlaneCalibration ideal{};
    const double a0 = lh2_predict_angle(ideal, 0, p), a1 = lh2_predict_angle(ideal, 1, p);
    // The ideal model inverted gives the point's direction back.
    EXPECT_NEAR(glm::length(lh2_ideal_direction(a0, a1) - glm::normalize(p)), 0.0, 1e-12);

    std::vector<uint8_t> payload(kLh2PayloadBytes);
    for (size_t i = 0; i < payload.size(); ++i) payload[i] = uint8_t(i * 37 + 11);
    const std::vector<uint8_t> bits = encode_ootx_frame(payload);

    LightDecoder dec(knuckles_model());
    std::vector<LightEvent> events;
    const double t0 = 1000.0;  // ticks; the 24-bit times wrap every 0.35 s and are extended
    int frames_at = -1;
    for (size_t k = 0; k < bits.size() + 40; ++k) {
        const double sync = t0 + double(k) * period;
        const int bit = k < 20 ? 1 : (k - 20 < bits.size() ? bits[k - 20] : 1);
        if (k == 100) continue;  // a missed turn: an unknown bit the CRC resolves
        std::vector<Lh2Word> w(3);
        w[0] = {false, uint8_t(ch), 0, uint32_t(std::llround(sync)) & 0xffffff, false, bit != 0};
        for (int plane = 0; plane < 2; ++plane) {
            const double a = plane ? a1 : a0;
            const double hit = sync + (a + (plane ? 4 : 2) * kPi / 3) / (2 * kPi) * period;
            const double half_ticks = std::floor(hit * 2);
            Lh2Word& s = w[size_t(1 + plane)];
            s.sweep = true;
            s.channel = uint8_t(ch);
            s.sensor = 7;  // raw channel 7: model sensor 6
            s.time24 = uint32_t(int64_t(half_ticks) / 2) & 0xffffff;
            s.half_clock = int64_t(half_ticks) % 2 != 0;
        }
        ASSERT_TRUE(dec.decode_report(encode_lh2_report(w)).ok());
        const BaseStationState* st = dec.base_station(Generation::lh2, uint8_t(ch));
        if (frames_at < 0 && st && st->calibration) frames_at = int(k);
        if (k == 50) {
            EXPECT_EQ(
                dec.calibration_status(Generation::lh2, uint8_t(ch)).rfind("no calibration yet", 0),
                0u);
        }
    }
    dec.take_events(events);
    ASSERT_EQ(events.size(), 2 * (bits.size() + 40 - 1));
    for (const LightEvent& e : events) {
        EXPECT_EQ(e.sensor, 6);
        EXPECT_EQ(e.base_station, ch);
        // a tick of rounding at each end
        EXPECT_NEAR(e.angle, e.plane ? a1 : a0, 2 * (2 * kPi / period)) << "plane " << int(e.plane);
    }
    EXPECT_EQ(frames_at,
              int(20 + bits.size() - 2));  // its last data bit (the sync bit after it unneeded)
    const BaseStationState* st = dec.base_station(Generation::lh2, uint8_t(ch));
    ASSERT_TRUE(st && st->calibration);
    EXPECT_EQ(st->calibration->payload, payload);
    EXPECT_EQ(st->ootx.unknown_bits, 1u);
    EXPECT_TRUE(dec.take_warnings().empty());
}

// Lighthouse 1, as libsurvive's disambiguator describes the pattern: per 400,000-tick slot base
// station 1 flashes, then 0 20,000 ticks later; the one not skipping sweeps; four slots: 0 sweeps
// x, 0 sweeps y, 1 sweeps x, 1 sweeps y.
struct Lh1Sim {
    std::vector<Lh1Pulse> pulses;
    uint32_t t = 5'000'000;
    void flash(uint32_t start, int code) {
        const uint32_t len = uint32_t(3000 + 500 * code - 30);
        for (uint8_t s = 0; s < 5; ++s)  // sensors starting up to 200 ticks late, ending together
            pulses.push_back({s, start + 40u * s, len - 40u * s});
    }
    void slot(int k, int data1, int data0, const glm::dvec3& p) {
        const int phase = k % 4, axis = phase % 2;
        const bool zero_sweeps = phase < 2;
        flash(t, (zero_sweeps ? 4 : 0) | data1 << 1 | axis);
        flash(t + 20'000, (zero_sweeps ? 0 : 4) | data0 << 1 | axis);
        const double a = axis ? std::atan2(p.y, -p.z) : -std::atan2(p.x, -p.z);
        const double tis = (a + kPi / 2) * 400'000 / kPi;
        const uint32_t sync = zero_sweeps ? t + 20'000 : t;
        const uint32_t len = 300;
        pulses.push_back({9, uint32_t(sync + std::llround(tis) - len / 2), len});
        t += 400'000;
    }
};

TEST(LightCodec, ALighthouse1PairGivesTheAnglesOfItsSweepsAndEachBaseStationsCalibration) {
    const glm::dvec3 p(-0.3, 0.5, -1.5);
    std::vector<uint8_t> pay0(kLh1PayloadBytes, 0x5a), pay1(kLh1PayloadBytes, 0xa5);
    pay0[2] = 0x65;  // id 0x...65
    pay1[2] = 0xf3;
    const auto bits0 = encode_ootx_frame(pay0), bits1 = encode_ootx_frame(pay1);
    Lh1Sim sim;
    const size_t n = std::max(bits0.size(), bits1.size()) + 10;
    for (size_t k = 0; k < n; ++k)
        sim.slot(int(k), k < bits1.size() ? bits1[k] : 1, k < bits0.size() ? bits0[k] : 1, p);
    LightDecoder dec;
    for (size_t i = 0; i < sim.pulses.size(); i += 9)
        ASSERT_TRUE(
            dec
                .decode_report(encode_lh1_report(
                    std::span(sim.pulses).subspan(i, std::min<size_t>(9, sim.pulses.size() - i))))
                .ok());
    dec.finish();
    std::vector<LightEvent> events;
    dec.take_events(events);
    ASSERT_EQ(events.size(), n);  // every slot's sweep
    std::map<std::pair<int, int>, int> count;
    for (const LightEvent& e : events) {
        EXPECT_EQ(e.sensor, 9);
        const double want = e.plane ? std::atan2(p.y, -p.z) : -std::atan2(p.x, -p.z);
        EXPECT_NEAR(e.angle, want, 1.5 * kPi / 400'000);
        ++count[{e.base_station, e.plane}];
    }
    EXPECT_EQ(count.size(), 4u);  // both base stations, both axes
    const glm::dvec3 dir = lh1_ideal_direction(-std::atan2(p.x, -p.z), std::atan2(p.y, -p.z));
    EXPECT_NEAR(glm::length(dir - glm::normalize(p)), 0.0, 1e-12);
    for (auto [lh, pay] : {std::pair{0, &pay0}, std::pair{1, &pay1}}) {
        const BaseStationState* s = dec.base_station(Generation::lh1, uint8_t(lh));
        ASSERT_TRUE(s && s->calibration) << lh;
        EXPECT_EQ(s->calibration->payload, *pay);
    }
    EXPECT_EQ(dec.counters().unassigned_syncs, 0u);  // the first flash: taken with its pair
}

TEST(LightCodec, ALoneLighthouse1BaseStationIsFoundAfterEightCycles) {
    LightDecoder dec;
    uint32_t t = 1'000'000;
    for (int k = 0; k < 20; ++k, t += 400'000) {
        const uint32_t len = uint32_t(3000 + 500 * (k % 2) - 30);
        const std::vector<Lh1Pulse> flash = {
            {1, t, len}, {4, t + 80, len - 80}, {2, t + 120'000, 250}};
        ASSERT_TRUE(dec.decode_report(encode_lh1_report(flash)).ok());
    }
    dec.finish();
    std::vector<LightEvent> events;
    dec.take_events(events);
    EXPECT_EQ(dec.counters().unassigned_syncs, 8u);
    EXPECT_EQ(events.size(), 12u);
    for (const LightEvent& e : events) EXPECT_EQ(e.base_station, 0);
}

// ---- The angle models ---------------------------------------------------------------------------

TEST(LightCodec, TheAngleModelsInvertAndTheirCalibrationPhaseShiftsTheAngle) {
    PlaneCalibration shifted{};
    shifted.phase = 0.01;
    for (double x : {-1.0, -0.2, 0.5})
        for (double y : {-0.8, 0.0, 0.6}) {
            const glm::dvec3 p(x, y, -2.0);
            const PlaneCalibration ideal{};
            const double a0 = lh2_predict_angle(ideal, 0, p), a1 = lh2_predict_angle(ideal, 1, p);
            EXPECT_NEAR(glm::length(lh2_ideal_direction(a0, a1) - glm::normalize(p)), 0, 1e-12);
            const double ax = lh1_predict_angle(ideal, 0, p), ay = lh1_predict_angle(ideal, 1, p);
            EXPECT_NEAR(glm::length(lh1_ideal_direction(ax, ay) - glm::normalize(p)), 0, 1e-12);
            EXPECT_NEAR(lh2_predict_angle(shifted, 0, p), a0 - 0.01, 1e-12);
            EXPECT_NEAR(lh1_predict_angle(shifted, 1, p), ay - 0.01, 1e-12);
            // The planes tilted +-30 degrees: above the centre plane 0 hits earlier than plane 1.
            if (y > 0) {
                EXPECT_LT(a0, a1);
            }
        }
}

TEST(LightCodec, ReportSlotsCarryingTheDevicesOwnTimeStampsAreSkipped) {
    LightDecoder dec;
    const std::vector<Lh1Pulse> slots = {
        {0xfd, 1000, 0}, {3, 2000, 3000}, {0xfe, 3000, 0}, {0xfb, 4000, 0}, {4, 2010, 2990}};
    ASSERT_TRUE(dec.decode_report(encode_lh1_report(slots)).ok());
    EXPECT_EQ(dec.counters().lh1_pulses, 2u);
    EXPECT_EQ(dec.counters().lh1_device_stamps, 3u);
    auto r = parse_lh1_report(encode_lh1_report(slots));
    ASSERT_TRUE(r.ok());
    EXPECT_EQ(r->count, 2u);
    EXPECT_EQ(r->pulses[1].sensor, 4);
}

// ---- Bad reports --------------------------------------------------------------------------------

TEST(LightCodec, ACutOrUnknownReportOrAnOutOfModelSensorIsAnErrorNamingTheByteAndGivesNothing) {
    LightDecoder dec(knuckles_model());
    std::vector<Lh1Pulse> pulses = {{1, 1000, 3000}, {2, 1010, 2990}, {3, 1020, 2980}};
    std::vector<uint8_t> r = encode_lh1_report(pulses);
    r.resize(1 + 7 * 3 + 4);  // a fourth slot cut after 4 bytes
    auto cut = dec.decode_report(r);
    ASSERT_FALSE(cut.ok());
    EXPECT_EQ(cut.error().message,
              "light report 0 (id 0x25): byte 22: pulse 3 is cut short (4 of 7 bytes)");
    pulses[1].sensor = 18;  // no model point on raw channel 18
    auto beyond = dec.decode_report(encode_lh1_report(pulses));
    ASSERT_FALSE(beyond.ok());
    EXPECT_EQ(beyond.error().message,
              "light report 1 (id 0x25): byte 8: sensor channel 18 is not in the device's model "
              "(24 sensors)");
    auto unknown = dec.decode_report(std::vector<uint8_t>{0x26, 1, 2, 3});
    ASSERT_FALSE(unknown.ok());
    EXPECT_NE(unknown.error().message.find("light report 2 (id 0x26): not a light report"),
              std::string::npos);
    EXPECT_EQ(dec.counters().lh1_pulses, 0u);  // nothing of a refused report was used

    // Report 0x28: a sync, then a sweep on raw channel 0 (not in the model): refused whole.
    std::vector<Lh2Word> w(2);
    w[0] = {false, 3, 0, 12345, false, true};
    w[1] = {true, 3, 0, 12999, false, false};
    auto lh2_beyond = dec.decode_report(encode_lh2_report(w));
    ASSERT_FALSE(lh2_beyond.ok());
    EXPECT_EQ(lh2_beyond.error().message,
              "light report 3 (id 0x28): byte 7: sensor channel 0 is not in the device's model "
              "(24 sensors)");
    std::vector<uint8_t> ok = encode_lh2_report(std::span(w).first(1));
    std::vector<uint8_t> long_len = ok;
    long_len[1] = 63;
    std::vector<uint8_t> cut_word = ok;
    cut_word[1] = 4;  // the channel byte and 3 bytes of the word
    std::vector<uint8_t> no_channel = {0x28, 4, 0x54, 0x15, 0xa5, 0x02};
    std::vector<uint8_t> bad_flag = ok;
    bad_flag[2] |= 0x02;
    const std::pair<std::vector<uint8_t>*, const char*> bad[] = {
        {&long_len, "byte 1: a payload of 63 bytes in a report of 64"},
        {&cut_word, "byte 3: a word cut short (3 of 4 bytes)"},
        {&no_channel, "byte 2: a word before any channel byte"},
        {&bad_flag, "byte 2: channel byte 0x33 has unknown flags (bits 1, 3)"},
    };
    for (auto [bytes, want] : bad) {
        auto st = dec.decode_report(*bytes);
        ASSERT_FALSE(st.ok()) << want;
        EXPECT_NE(st.error().message.find(want), std::string::npos) << st.error().message;
    }
    EXPECT_EQ(dec.counters().syncs, 0u);
    EXPECT_EQ(dec.counters().rejected, dec.counters().reports);
    EXPECT_TRUE(dec.decode_report(ok).ok());
    EXPECT_EQ(dec.counters().syncs, 1u);
}

}  // namespace
}  // namespace hmdnode
