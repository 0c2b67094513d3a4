// Lighthouse light reports and events (light_codec.hpp): report 0x25 (lighthouse 1) and 0x28
// (lighthouse 2) parsing, the lighthouse-1 sync/sweep decoder, the lighthouse-2 rotor-phase
// decoder, the base stations' OOTX streams, and the angle models.
//
// Learnt from (the code is this project's own):
//  * libsurvive (Charles Lohr, Joshua Allen, Justin Berger et al., MIT licence),
//    https://github.com/cntools/libsurvive: src/driver_vive.c (report 0x25: nine {u8 sensor, u16
//    length, u32 time}; report 0x28: parse_and_process_raw1_lightcap's channel bytes and 32-bit
//    words, fix_time24's extension of a 24-bit time against the last IMU tick);
//    src/disambiguator_statebased.c (the lighthouse-1 flash timing: ACODE_TIMING, the 20,000 /
//    400,000-tick pattern, which base station sweeps, the sync's first start and the pulse
//    centre as the sweep's ends); src/survive_process_gen1.c (angle = t * pi / 400,000 - pi / 2);
//    src/survive_process_gen2.c (the per-channel rotor rates, the sync acceptance within 1 Hz,
//    time since sync -> phase -> plane 0/1 at -2 pi / 3 and -4 pi / 3; its plane choice near pi
//    uses past angles, ours the order of a sensor's hits within a turn);
//    src/survive_reproject_gen2.c and src/survive_reproject.c (the calibrated angle models);
//    src/survive_recording.c (the W/B/Y/C/A lines this decoder is compared with).
//  * Monado's Vive driver (src/xrt/drivers/vive/vive_device.c, _decode_pulse_report; Philipp
//    Zabel, Collabora and the Monado authors, BSL-1.0),
//    https://gitlab.freedesktop.org/monado/monado: report 0x25's nine slots, whose ids 0xfb, 0xfd
//    (a camera frame) and 0xfe (vsync) are the device's time stamps, not pulses (it only checks the
//    sizes of 0x27 and 0x28).
//
// Cost: O(1) per pulse and word, plus a sort of each lighthouse-1 sync window (its <= 32 pulses)
// and the OOTX decoder's per-bit and per-frame work (ootx.cpp).
#include "hmdnode/hal/codec/light_codec.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace hmdnode::lighthouse {
namespace {

constexpr double kPi = 3.14159265358979323846;

// Lighthouse 1 (ticks of 48 MHz).
constexpr uint32_t kSyncMin = 2250;      // sync flashes are 2,750..6,250 nominal (libsurvive's
constexpr uint32_t kSyncMax = 6750;      // LOWER_/UPPER_SYNC_TIME bound them so)
constexpr uint32_t kLongPulse = 10'000;  // longer: no sweep hit (libsurvive drops them too)
constexpr int64_t kWindow = 3000;        // a flash's pulses start within this of the first
constexpr int64_t kEndCluster = 300;     // ...and end together (a late start is a late sensor)
constexpr int64_t kTolerance = 1000;     // timing slack of the 20,000 / 400,000 pattern
constexpr int64_t kMaxCycles = 240;      // 2 s: a base station unseen longer is found afresh
constexpr int64_t kStaleTicks = kMaxCycles * kLh1CycleTicks;
constexpr int kSingleStationChain = 8;  // unpaired flashes a cycle apart: one base station

// Lighthouse 2.
constexpr double kLh2Hz[kLh2Channels] = {50.0521, 50.1567, 50.3673, 50.5796, 50.6864, 50.9014,
                                         51.0096, 51.1182, 51.2273, 51.6685, 52.2307, 52.6894,
                                         52.9217, 53.2741, 53.7514, 54.1150};
constexpr double kMaxRateError = 1.0;  // Hz
constexpr int64_t kMaxTurnsSkipped = 100;
constexpr int64_t kMaxTurnsAfterSync = 10;
constexpr size_t kMaxModelSensors = 64;

int64_t ticks_to_ns(int64_t t) {
    return t / 48 * 1000 + (t % 48) * 1000 / 48;
}

std::string hex(unsigned v, int digits) {
    char b[16];
    std::snprintf(b, sizeof b, "0x%0*x", digits, v);
    return b;
}

std::string station_name(Generation g, int n) {
    return std::string(generation_name(g)) +
           (g == Generation::lh1 ? " base station " : " channel ") + std::to_string(n);
}

// Report 0x25 slot ids that are not a sensor: 0xff empty; 0xfb, 0xfd (a camera frame), 0xfe
// (vsync): the device's time stamps (Monado's _decode_pulse_report).
bool is_empty_slot(uint8_t id) {
    return id == 0xff;
}
bool is_device_stamp(uint8_t id) {
    return id == 0xfb || id == 0xfd || id == 0xfe;
}

int64_t mod(int64_t a, int64_t m) {
    const int64_t r = a % m;
    return r < 0 ? r + m : r;
}

}  // namespace

double lh2_rotor_hz(int channel) {
    return channel >= 0 && channel < kLh2Channels ? kLh2Hz[channel] : 0.0;
}

// ---- Reports ------------------------------------------------------------------------------------

Result<Lh1Report> parse_lh1_report(std::span<const uint8_t> b) {
    if (b.empty() || b[0] != kLh1ReportId)
        return make_error(b.empty() ? "an empty report"
                                    : "report id " + hex(b[0], 2) + ", not 0x25");
    Lh1Report r;
    for (size_t i = 0; i < kLh1PulsesPerReport; ++i) {
        const size_t at = 1 + kLh1PulseBytes * i;
        if (at >= b.size()) break;
        if (b.size() - at < kLh1PulseBytes)
            return make_error("byte " + std::to_string(at) + ": pulse " + std::to_string(i) +
                              " is cut short (" + std::to_string(b.size() - at) + " of 7 bytes)");
        const uint8_t sensor = b[at];
        if (is_empty_slot(sensor)) continue;
        if (is_device_stamp(sensor)) {
            ++r.device_stamps;
            continue;
        }
        Lh1Pulse& p = r.pulses[r.count++];
        p.sensor = sensor;
        p.length = uint32_t(b[at + 1] | b[at + 2] << 8);
        p.start = uint32_t(b[at + 3]) | uint32_t(b[at + 4]) << 8 | uint32_t(b[at + 5]) << 16 |
                  uint32_t(b[at + 6]) << 24;
    }
    return r;
}

Result<Lh2Report> parse_lh2_report(std::span<const uint8_t> b) {
    if (b.empty() || b[0] != kLh2ReportId)
        return make_error(b.empty() ? "an empty report"
                                    : "report id " + hex(b[0], 2) + ", not 0x28");
    if (b.size() < 2) return make_error("byte 1: no payload length");
    const size_t n = b[1];
    if (n > b.size() - 2)
        return make_error("byte 1: a payload of " + std::to_string(n) + " bytes in a report of " +
                          std::to_string(b.size()));
    Lh2Report r;
    int channel = -1;
    bool conflict = false;
    size_t i = 2;
    while (i < 2 + n) {
        const uint8_t c = b[i];
        if (c & 1) {
            if (c & 0x0a)
                return make_error("byte " + std::to_string(i) + ": channel byte " + hex(c, 2) +
                                  " has unknown flags (bits 1, 3)");
            channel = c >> 4;
            conflict = (c & 4) != 0;
            ++i;
            continue;
        }
        if (2 + n - i < 4)
            return make_error("byte " + std::to_string(i) + ": a word cut short (" +
                              std::to_string(2 + n - i) + " of 4 bytes)");
        if (channel < 0)
            return make_error("byte " + std::to_string(i) + ": a word before any channel byte");
        if (r.count == r.words.size())
            return make_error("byte " + std::to_string(i) + ": more than 16 words");
        const uint32_t w = uint32_t(b[i]) | uint32_t(b[i + 1]) << 8 | uint32_t(b[i + 2]) << 16 |
                           uint32_t(b[i + 3]) << 24;
        Lh2Word& o = r.words[r.count++];
        o.channel = uint8_t(channel);
        o.conflict = conflict;
        o.byte = i;
        o.sweep = (w & 2) != 0;
        if (o.sweep) {
            o.sensor = uint8_t(w >> 27);
            o.time24 = (w >> 3) & 0xffffff;
            o.half_clock = (w & 4) != 0;
        } else {
            o.time24 = (w >> 2) & 0xffffff;
            o.ootx = (w >> 26) & 1;
            o.gen = (w >> 27) & 1;
        }
        i += 4;
    }
    return r;
}

std::vector<uint8_t> encode_lh1_report(std::span<const Lh1Pulse> pulses) {
    std::vector<uint8_t> b(1 + kLh1PulseBytes * kLh1PulsesPerReport, 0xff);
    b[0] = kLh1ReportId;
    for (size_t i = 0; i < pulses.size() && i < kLh1PulsesPerReport; ++i) {
        uint8_t* p = b.data() + 1 + kLh1PulseBytes * i;
        const Lh1Pulse& x = pulses[i];
        p[0] = x.sensor;
        p[1] = uint8_t(x.length);
        p[2] = uint8_t(x.length >> 8);
        for (int k = 0; k < 4; ++k) p[3 + k] = uint8_t(x.start >> (8 * k));
    }
    return b;
}

std::vector<uint8_t> encode_lh2_report(std::span<const Lh2Word> words) {
    std::vector<uint8_t> b = {kLh2ReportId, 0};
    int channel = -1;
    for (const Lh2Word& w : words) {
        if (w.channel != channel) {
            b.push_back(uint8_t(w.channel << 4 | (w.conflict ? 4 : 0) | 1));
            channel = w.channel;
        }
        uint32_t v;
        if (w.sweep)
            v = uint32_t(w.sensor & 31) << 27 | (w.time24 & 0xffffff) << 3 |
                (w.half_clock ? 4u : 0u) | 2u;
        else
            v = uint32_t(w.gen) << 27 | uint32_t(w.ootx) << 26 | (w.time24 & 0xffffff) << 2;
        for (int k = 0; k < 4; ++k) b.push_back(uint8_t(v >> (8 * k)));
    }
    b[1] = uint8_t(b.size() - 2);
    b.resize(std::max<size_t>(b.size(), 64), 0);
    return b;
}

// ---- The decoder --------------------------------------------------------------------------------

LightDecoder::LightDecoder(SensorModel model) : model_(std::move(model)) {
    raw_to_model_.fill(-1);
    if (!model_.channel_map.empty()) model_.count = model_.channel_map.size();
    model_.count = std::min(model_.count, kMaxModelSensors);
    if (model_.channel_map.empty()) {
        for (size_t i = 0; i < model_.count; ++i) raw_to_model_[i] = int(i);
    } else {
        for (size_t i = 0; i < model_.count; ++i) {
            const int raw = model_.channel_map[i];
            if (raw >= 0 && raw < 256) raw_to_model_[size_t(raw)] = int(i);
        }
    }
    pending_.resize(model_.count);
}

Result<uint8_t> LightDecoder::model_sensor(uint8_t raw) const {
    const int m = raw_to_model_[raw];
    if (m < 0)
        return make_error("sensor channel " + std::to_string(raw) +
                          " is not in the device's model (" + std::to_string(model_.count) +
                          " sensors)");
    return uint8_t(m);
}

int64_t LightDecoder::unwrap(uint32_t timecode) {
    if (!have_time_) {
        have_time_ = true;
        last_raw_ = timecode;
        last_ticks_ = timecode;
        return last_ticks_;
    }
    last_ticks_ += int32_t(timecode - last_raw_);
    last_raw_ = timecode;
    return last_ticks_;
}

uint32_t LightDecoder::extend24(uint32_t t24) {
    const uint32_t ref = have_imu_ ? imu_ticks_ : (have_time_ ? last_raw_ : 0u);
    uint32_t upper = ref & 0xff000000u;
    const uint32_t lower = ref & 0x00ffffffu;
    if (lower > t24 && lower - t24 > (1u << 23))
        upper += 0x01000000u;
    else if (lower < t24 && t24 - lower > (1u << 23))
        upper -= 0x01000000u;
    return upper | t24;
}

void LightDecoder::note_imu_ticks(uint32_t ticks) {
    have_imu_ = true;
    imu_ticks_ = ticks;
}

BaseStationState& LightDecoder::station(Generation g, uint8_t number) {
    auto [it, fresh] = stations_.try_emplace({int(g), int(number)});
    if (fresh) {
        it->second.generation = g;
        it->second.base_station = number;
    }
    return it->second;
}

void LightDecoder::ootx_bits(BaseStationState& s, int64_t ticks, int missing, int bit) {
    const auto key = std::make_pair(int(s.generation), int(s.base_station));
    OotxDecoder& dec = ootx_[key];
    std::vector<OotxFrame> frames;
    if (missing < 0 || missing > 64) {
        dec.reset();
    } else {
        for (int i = 0; i < missing; ++i)
            if (auto f = dec.push(-1)) frames.push_back(std::move(*f));
    }
    if (auto f = dec.push(bit)) frames.push_back(std::move(*f));
    for (OotxFrame& f : frames) {
        const std::string who = station_name(s.generation, s.base_station) + ": OOTX frame " +
                                std::to_string(dec.counters().frames) + " (ending at bit " +
                                std::to_string(f.end_bit) + ")";
        if (!f.crc_ok) {
            warnings_.push_back(who + ": bad CRC-32 (the frame says " + hex(f.crc_received, 8) +
                                ", its payload gives " + hex(f.crc_computed, 8) + "); not used");
            continue;
        }
        auto cal = parse_ootx_payload(s.generation, f.payload);
        if (!cal) {
            warnings_.push_back(who + ": " + cal.error().message + "; not used");
            continue;
        }
        if (!s.calibration) {
            s.calibration_ticks = ticks;
        } else if (s.calibration->payload != cal->payload) {
            ++s.calibration_changes;
            warnings_.push_back(who + ": the calibration changed (id " + hex(s.calibration->id, 8) +
                                " -> " + hex(cal->id, 8) + ")");
        }
        s.calibration = std::move(*cal);
    }
    s.ootx = dec.counters();
}

Status LightDecoder::decode_report(std::span<const uint8_t> report) {
    const uint64_t index = counters_.reports++;
    auto fail = [&](const std::string& what) {
        ++counters_.rejected;
        return Status(make_error(
            "light report " + std::to_string(index) +
            (report.empty() ? std::string() : " (id " + hex(report[0], 2) + ")") + ": " + what));
    };
    if (report.empty()) return fail("empty");
    if (report[0] == kLh1ReportId) {
        auto r = parse_lh1_report(report);
        if (!r) return fail(r.error().message);
        std::array<uint8_t, kLh1PulsesPerReport> m{};
        size_t slot = 0;
        for (size_t i = 0; i < r->count; ++i) {
            while (is_empty_slot(report[1 + kLh1PulseBytes * slot]) ||
                   is_device_stamp(report[1 + kLh1PulseBytes * slot]))
                ++slot;  // the pulse's own slot
            auto s = model_sensor(r->pulses[i].sensor);
            if (!s)
                return fail("byte " + std::to_string(1 + kLh1PulseBytes * slot) + ": " +
                            s.error().message);
            m[i] = *s;
            ++slot;
        }
        counters_.lh1_device_stamps += r->device_stamps;
        for (size_t i = 0; i < r->count; ++i) {
            ++counters_.lh1_pulses;
            lh1_pulse({m[i], unwrap(r->pulses[i].start), r->pulses[i].length});
        }
        return {};
    }
    if (report[0] == kLh2ReportId) {
        auto r = parse_lh2_report(report);
        if (!r) return fail(r.error().message);
        std::array<uint8_t, 16> m{};
        for (size_t i = 0; i < r->count; ++i) {
            if (!r->words[i].sweep) continue;
            auto s = model_sensor(r->words[i].sensor);
            if (!s)
                return fail("byte " + std::to_string(r->words[i].byte) + ": " + s.error().message);
            m[i] = *s;
        }
        std::array<bool, kLh2Channels> warned{};
        for (size_t i = 0; i < r->count; ++i) {
            const Lh2Word& w = r->words[i];
            ++counters_.lh2_words;
            if (w.conflict && !warned[w.channel]) {
                warned[w.channel] = true;
                ++counters_.channel_conflicts;
                if (counters_.channel_conflicts <= 10)
                    warnings_.push_back("light report " + std::to_string(index) +
                                        ": two or more base stations on " +
                                        station_name(Generation::lh2, w.channel) +
                                        " (the device's conflict flag): tracking may fail");
            }
            const uint32_t t = extend24(w.time24);
            const int64_t ticks = unwrap(t);
            if (w.sweep)
                lh2_sweep(w.channel, m[i], ticks, t, w.half_clock);
            else
                lh2_sync(w.channel, ticks, t, w.ootx, w.gen);
        }
        return {};
    }
    if (report[0] == 0x27)
        return fail(
            "a lighthouse-2 light report of the device's other mode (libsurvive reads it "
            "as raw mode 0 and does not decode it either)");
    return fail("not a light report (0x25: lighthouse 1, 0x28: lighthouse 2)");
}

Status LightDecoder::add_lh1_pulse(uint8_t raw_sensor, uint32_t start, uint32_t length) {
    auto s = model_sensor(raw_sensor);
    if (!s) return s.error();
    ++counters_.lh1_pulses;
    lh1_pulse({*s, unwrap(start), length});
    return {};
}

Status LightDecoder::add_lh2_sync(uint8_t channel, uint32_t timecode, bool ootx, bool gen) {
    if (channel >= kLh2Channels)
        return make_error("channel " + std::to_string(channel) + " beyond 0..15");
    ++counters_.lh2_words;
    lh2_sync(channel, unwrap(timecode), timecode, ootx, gen);
    return {};
}

Status LightDecoder::add_lh2_sweep(uint8_t channel, uint8_t sensor, uint32_t timecode,
                                   bool half_clock) {
    if (channel >= kLh2Channels)
        return make_error("channel " + std::to_string(channel) + " beyond 0..15");
    if (sensor >= model_.count)
        return make_error("sensor " + std::to_string(sensor) + " beyond the device's model (" +
                          std::to_string(model_.count) + " sensors)");
    ++counters_.lh2_words;
    lh2_sweep(channel, sensor, unwrap(timecode), timecode, half_clock);
    return {};
}

void LightDecoder::finish() {
    lh1_close_window();
    lh1_flush();
}

// ---- Lighthouse 1 -------------------------------------------------------------------------------

void LightDecoder::lh1_pulse(const Pulse64& p) {
    if (!window_.empty() && p.start - window_first_ > kWindow) lh1_close_window();
    if (p.length >= kSyncMin && p.length <= kSyncMax) {
        if (window_.empty()) window_first_ = p.start;
        window_.push_back(p);
        return;
    }
    if (!window_.empty()) {
        ++counters_.pulses_in_sync;
        return;
    }
    if (p.length >= kLongPulse) {
        ++counters_.long_pulses;
        return;
    }
    const Lh1Sync* sweeper = nullptr;
    for (auto it = slot_.rbegin(); it != slot_.rend() && !sweeper; ++it)
        if (!(it->code & 4)) sweeper = &*it;
    if (!sweeper || p.start < sweeper->start || p.start - sweeper->start > kLh1CycleTicks) {
        ++counters_.sweeps_without_sync;
        return;
    }
    std::optional<Pulse64>& slot = pending_[p.sensor];
    if (!slot || p.length > slot->length) slot = p;
}

void LightDecoder::lh1_close_window() {
    if (window_.empty()) return;
    // A flash's pulses end together; a sensor that sees it late starts late. So the flash is the
    // largest group of pulses ending within kEndCluster of each other; the rest are strays.
    std::sort(window_.begin(), window_.end(), [](const Pulse64& a, const Pulse64& b) {
        return a.start + a.length < b.start + b.length;
    });
    size_t best_at = 0, best_n = 0;
    uint32_t best_len = 0;
    for (size_t i = 0; i < window_.size();) {
        size_t j = i + 1;
        uint32_t len = window_[i].length;
        while (j < window_.size() && (window_[j].start + window_[j].length) -
                                             (window_[j - 1].start + window_[j - 1].length) <=
                                         kEndCluster) {
            len = std::max(len, window_[j].length);
            ++j;
        }
        if (j - i > best_n || (j - i == best_n && len > best_len)) {
            best_at = i;
            best_n = j - i;
            best_len = len;
        }
        i = j;
    }
    counters_.stray_sync_pulses += window_.size() - best_n;
    Lh1Sync g;
    g.start = window_[best_at].start;
    for (size_t k = best_at; k < best_at + best_n; ++k)
        g.start = std::min(g.start, window_[k].start);
    g.length = best_len;
    g.code = uint8_t(std::clamp<long>(std::lround((double(g.length) - 3000.0) / 500.0), 0L, 7L));
    window_.clear();
    lh1_assign(g);
}

void LightDecoder::lh1_assign(Lh1Sync g) {
    int lh = -1;
    for (int s = 0; s < 2; ++s) {
        if (!locked_[s]) continue;
        const int64_t d = g.start - station_last_[s];
        if (d > kStaleTicks || d < -kStaleTicks) {
            locked_[s] = false;
            continue;
        }
        const int64_t k = std::llround(double(d) / double(kLh1CycleTicks));
        if (k >= 1 && std::llabs(d - k * kLh1CycleTicks) < kTolerance) lh = s;
    }
    if (lh < 0 && prev_ && prev_->station < 0 &&
        std::llabs(g.start - prev_->start - kLh1PairTicks) < kTolerance) {
        // A pair: the first flash is base station 1, the second 0 (libsurvive's numbering).
        Lh1Sync first = *prev_;
        first.station = 1;
        --counters_.unassigned_syncs;  // it was counted when it came alone
        lh1_accept(first);
        lh = 0;
    }
    if (lh < 0 && locked_[1] &&
        std::llabs(mod(g.start - station_last_[1], kLh1CycleTicks) - kLh1PairTicks) < kTolerance)
        lh = 0;
    if (lh < 0 && locked_[0]) {
        const int64_t m = mod(g.start - station_last_[0] + kLh1PairTicks, kLh1CycleTicks);
        if (m < kTolerance || kLh1CycleTicks - m < kTolerance) lh = 1;
    }
    if (lh < 0) {
        // One base station alone (mode A): its flashes a cycle apart, never paired.
        if (prev_ && prev_->station < 0 &&
            std::llabs(g.start - prev_->start - kLh1CycleTicks) < kTolerance)
            ++single_chain_;
        else
            single_chain_ = 0;
        if (single_chain_ >= kSingleStationChain && !locked_[0] && !locked_[1]) lh = 0;
    }
    if (lh < 0) {
        ++counters_.unassigned_syncs;
        prev_ = g;
        return;
    }
    g.station = lh;
    lh1_accept(g);
    prev_ = g;
}

void LightDecoder::lh1_accept(const Lh1Sync& g) {
    locked_[size_t(g.station)] = true;
    station_last_[size_t(g.station)] = g.start;
    lh1_flush();
    if (!slot_.empty() && g.start - slot_.front().start > kLh1PairTicks + kTolerance) slot_.clear();
    slot_.push_back(g);
    const uint8_t n = uint8_t(g.station);
    BaseStationState& s = station(Generation::lh1, n);
    if (s.syncs++ == 0) s.first_sync_ticks = g.start;
    ++counters_.syncs;
    SyncEvent e;
    e.generation = Generation::lh1;
    e.base_station = n;
    e.ticks = g.start;
    e.timecode = uint32_t(g.start);
    e.ootx = (g.code >> 1) & 1;
    e.length = g.length;
    e.code = g.code;
    syncs_.push_back(e);
    const auto key = std::make_pair(int(Generation::lh1), int(n));
    int missing = 0;
    if (auto it = last_bit_ticks_.find(key); it != last_bit_ticks_.end()) {
        const int64_t k = std::llround(double(g.start - it->second) / double(kLh1CycleTicks));
        missing = k < 1 ? -1 : int(std::min<int64_t>(k - 1, 1000));
    }
    last_bit_ticks_[key] = g.start;
    ootx_bits(s, g.start, missing, e.ootx);
}

void LightDecoder::lh1_flush() {
    const Lh1Sync* sweeper = nullptr;
    for (auto it = slot_.rbegin(); it != slot_.rend() && !sweeper; ++it)
        if (!(it->code & 4)) sweeper = &*it;
    for (std::optional<Pulse64>& slot : pending_) {
        if (!slot) continue;
        const Pulse64 p = *slot;
        slot.reset();
        if (!sweeper) continue;
        const int64_t centre = p.start + p.length / 2;
        const int64_t tis = centre - sweeper->start;
        if (tis <= 0 || tis >= kLh1CycleTicks) {
            ++counters_.sweeps_out_of_slot;
            continue;
        }
        LightEvent e;
        e.generation = Generation::lh1;
        e.base_station = uint8_t(sweeper->station);
        e.sensor = p.sensor;
        e.ticks = p.start;
        e.device_time_ns = ticks_to_ns(centre);
        e.timecode = uint32_t(p.start);
        e.plane = sweeper->code & 1;
        e.length = p.length;
        e.ticks_in_sweep = tis;
        e.angle = double(tis) * kPi / double(kLh1CycleTicks) - kPi / 2;
        events_.push_back(e);
        ++counters_.events;
        ++station(Generation::lh1, e.base_station).events;
    }
}

// ---- Lighthouse 2 -------------------------------------------------------------------------------

void LightDecoder::lh2_sync(uint8_t ch, int64_t ticks, uint32_t timecode, bool ootx, bool gen) {
    Lh2Channel& c = channels_[ch];
    const double hz = kLh2Hz[ch];
    const double nominal = kTickHz / hz;
    int missing = 0;
    if (c.have_sync) {
        const int64_t d = ticks - c.last_sync;
        const int64_t n = std::llround(double(d) / nominal);
        if (d < 0 || n > kMaxTurnsSkipped) {
            missing = -1;  // the clock restarted, or the base station was gone for a while
        } else if (n < 1) {
            ++counters_.early_syncs;
            return;
        } else {
            const double period = double(d) / double(n);
            if (std::abs(kTickHz / period - hz) > kMaxRateError) {
                ++counters_.off_rate_syncs;
                if (n <= kMaxTurnsAfterSync) return;
                missing = -1;  // long off the pattern: start afresh from this one
            } else {
                c.period = period;
                missing = int(n - 1);
            }
        }
        if (missing < 0) {
            ++counters_.sync_restarts;
            c.period = 0;
        }
    }
    c.have_sync = true;
    c.last_sync = ticks;
    ++c.serial;
    BaseStationState& s = station(Generation::lh2, ch);
    if (s.syncs++ == 0 || (missing < 0 && !s.calibration)) s.first_sync_ticks = ticks;
    ++counters_.syncs;
    SyncEvent e;
    e.generation = Generation::lh2;
    e.base_station = ch;
    e.ticks = ticks;
    e.timecode = timecode;
    e.ootx = ootx ? 1 : 0;
    e.gen = gen;
    syncs_.push_back(e);
    ootx_bits(s, ticks, missing, e.ootx);
}

void LightDecoder::lh2_sweep(uint8_t ch, uint8_t sensor, int64_t ticks, uint32_t timecode,
                             bool half) {
    Lh2Channel& c = channels_[ch];
    if (!c.have_sync || ticks < c.last_sync) {
        ++counters_.sweeps_before_sync;
        return;
    }
    const double nominal = kTickHz / kLh2Hz[ch];
    const int64_t d = ticks - c.last_sync;
    const int64_t turns = d / int64_t(nominal);
    if (turns > kMaxTurnsAfterSync) {
        ++counters_.late_sweeps;
        return;
    }
    const double period = c.period > 0 ? c.period : nominal;
    const double t = double(d) + (half ? 0.5 : 0.0) - double(turns) * period;
    const double phase = t / period * 2 * kPi;
    // Plane 0 sweeps a sensor before plane 1 within a turn, at phases below and above pi. Near pi
    // (where the tilt can carry either across) a sensor's second hit of the turn is plane 1.
    uint8_t plane = phase > kPi ? 1 : 0;
    const uint64_t turn_key = (c.serial << 8 | uint64_t(turns)) + 1;
    if (phase > 0.9 * kPi && phase < 1.1 * kPi) plane = c.last_hit_turn[sensor] == turn_key ? 1 : 0;
    c.last_hit_turn[sensor] = turn_key;
    LightEvent e;
    e.generation = Generation::lh2;
    e.base_station = ch;
    e.sensor = sensor;
    e.ticks = ticks;
    e.device_time_ns = ticks_to_ns(ticks);
    e.timecode = timecode;
    e.plane = plane;
    e.half_clock = half;
    e.rotor_phase = phase;
    e.angle = phase - (plane ? 4.0 : 2.0) * kPi / 3.0;
    events_.push_back(e);
    ++counters_.events;
    ++station(Generation::lh2, ch).events;
}

// ---- Queries ------------------------------------------------------------------------------------

void LightDecoder::take_events(std::vector<LightEvent>& out) {
    out.insert(out.end(), events_.begin(), events_.end());
    events_.clear();
}

void LightDecoder::take_syncs(std::vector<SyncEvent>& out) {
    out.insert(out.end(), syncs_.begin(), syncs_.end());
    syncs_.clear();
}

std::vector<std::string> LightDecoder::take_warnings() {
    std::vector<std::string> w;
    w.swap(warnings_);
    return w;
}

std::vector<BaseStationState> LightDecoder::base_stations() const {
    std::vector<BaseStationState> out;
    for (const auto& [key, s] : stations_) out.push_back(s);
    return out;
}

const BaseStationState* LightDecoder::base_station(Generation g, uint8_t number) const {
    auto it = stations_.find({int(g), int(number)});
    return it == stations_.end() ? nullptr : &it->second;
}

std::string LightDecoder::calibration_status(Generation g, uint8_t number) const {
    const BaseStationState* s = base_station(g, number);
    if (!s) return "not seen";
    if (s->calibration) {
        char b[160];
        std::snprintf(b, sizeof b,
                      "calibration: id 0x%08x, firmware 0x%04x, first frame %.3f s after its "
                      "first sync",
                      unsigned(s->calibration->id), unsigned(s->calibration->firmware_version),
                      double(s->calibration_ticks - s->first_sync_ticks) / kTickHz);
        return b;
    }
    auto it = ootx_.find({int(g), int(number)});
    std::string st = "no calibration yet (" + std::to_string(s->ootx.bits) + " OOTX bits";
    if (it != ootx_.end() && it->second.frame_bits() > 0) {
        st += ", a frame at bit " + std::to_string(it->second.frame_bits());
        if (it->second.frame_bits_needed())
            st += " of " + std::to_string(it->second.frame_bits_needed());
    }
    if (s->ootx.bad_crc) st += ", " + std::to_string(s->ootx.bad_crc) + " with a bad CRC";
    return st + ")";
}

// ---- Angle models -------------------------------------------------------------------------------

namespace {
double clamp1(double v) {
    return std::clamp(v, -1.0, 1.0);
}
// libsurvive's calc_cal_series (survive_reproject_gen2.c): a polynomial in s and its derivative.
void cal_series(double s, double* m, double* a) {
    constexpr double f[6] = {
        -8.0108022e-06, 0.0028679863, 5.3685255000000001e-06, 0.0076069798000000001, 0, 0};
    *m = f[0];
    *a = 0;
    for (int i = 1; i < 6; ++i) {
        *a = *a * s + *m;
        *m = *m * s + f[i];
    }
}
}  // namespace

double lh2_predict_angle(const PlaneCalibration& cal, int plane, const glm::dvec3& p) {
    const double X = p.x, Y = p.y, Z = -p.z;
    const double B = std::atan2(Z, X);
    const double ydeg = cal.tilt + (plane ? -1.0 : 1.0) * kPi / 6.0;
    const double tan_a = std::tan(ydeg);
    const double norm_xz = std::sqrt(X * X + Z * Z);
    const double asin_arg = tan_a * Y / norm_xz;
    const double sin_y = std::sin(ydeg), cos_y = std::cos(ydeg);
    const double sin_part =
        std::sin(B - std::asin(clamp1(asin_arg)) + cal.ogee_phase) * cal.ogee_mag;
    const double norm_xyz = std::sqrt(X * X + Y * Y + Z * Z);
    const double asin_out = std::asin(clamp1(Y / norm_xyz / cos_y));
    double mod_v, acc;
    cal_series(asin_out, &mod_v, &acc);
    const double curved = sin_part + cal.curve;
    const double asin_arg2 = clamp1(asin_arg + mod_v * curved / (cos_y - acc * curved * sin_y));
    const double asin_out2 = std::asin(asin_arg2);
    const double sin_out2 = std::sin(B - asin_out2 + cal.gibbous_phase);
    return B - asin_out2 + sin_out2 * cal.gibbous_mag - cal.phase - kPi / 2;
}

double lh1_predict_angle(const PlaneCalibration& cal, int axis, const glm::dvec3& p) {
    const double Z = -p.z;
    const double value = axis ? p.y : p.x;
    const double other = axis ? p.x : p.y;
    double ang = kPi / 2 - (axis ? -1.0 : 1.0) * std::atan2(value, Z);
    const double mag = std::sqrt(value * value + Z * Z);
    ang -= cal.phase;
    ang -= std::asin(clamp1(std::tan(cal.tilt) * other / mag));
    ang -= std::cos(cal.gibbous_phase + ang) * cal.gibbous_mag;
    const double o = std::atan2(other, Z);
    ang += cal.curve * o * o;
    return ang - kPi / 2;
}

glm::dvec3 lh2_ideal_direction(double a0, double a1) {
    const double b = (a0 + a1) / 2 + kPi / 2;  // the azimuth in the x/-z plane
    const double y_over_r = std::sin((a1 - a0) / 2) / std::tan(kPi / 6);
    return glm::normalize(glm::dvec3(std::cos(b), y_over_r, -std::sin(b)));
}

glm::dvec3 lh1_ideal_direction(double ax, double ay) {
    return glm::normalize(glm::dvec3(-std::tan(ax), std::tan(ay), -1.0));
}

}  // namespace hmdnode::lighthouse
