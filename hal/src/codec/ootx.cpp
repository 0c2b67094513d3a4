// Lighthouse base-station calibration frames (OOTX): the bit-stream decoder, the CRC check with
// unknown bits resolved by trying them, and the lighthouse-1 (v6) and lighthouse-2 (v15) payload
// layouts (ootx.hpp).
//
// Learnt from libsurvive (Joshua Allen et al., MIT licence): src/ootx_decoder.c and
// src/ootx_decoder.h (the preamble of 17 zeros and a one, the sync bit after every 16 bits, the
// length word, the CRC-32 after the padded payload, the v6 and v15 field layouts),
// https://github.com/cntools/libsurvive; and src/survive_process_gen2.c there (which fields are
// used per plane). The code is this project's own. Cost: O(1) per bit; a finished frame costs one
// CRC-32 of its payload per completion tried (2^k for k unknown bits, k <= kMaxUnknownBits).
#include "hmdnode/hal/codec/ootx.hpp"

#include <cmath>
#include <cstring>

#include <zlib.h>

namespace hmdnode::lighthouse {
namespace {

uint16_t le16(std::span<const uint8_t> p, size_t at) {
    return uint16_t(p[at] | (p[at + 1] << 8));
}
uint32_t le32(std::span<const uint8_t> p, size_t at) {
    return uint32_t(p[at]) | uint32_t(p[at + 1]) << 8 | uint32_t(p[at + 2]) << 16 |
           uint32_t(p[at + 3]) << 24;
}
double half(std::span<const uint8_t> p, size_t at) {
    return half_to_double(le16(p, at));
}

uint32_t crc32_of(const std::vector<uint8_t>& bytes, size_t at, size_t n) {
    uLong c = crc32(0L, Z_NULL, 0);
    return uint32_t(crc32(c, n ? bytes.data() + at : Z_NULL, uInt(n)));
}

}  // namespace

const char* generation_name(Generation g) {
    return g == Generation::lh1 ? "lighthouse 1" : "lighthouse 2";
}

double half_to_double(uint16_t h) {
    const int sign = (h >> 15) & 1;
    const int exponent = (h >> 10) & 0x1f;
    const int mantissa = h & 0x3ff;
    double v;
    if (exponent == 0)
        v = std::ldexp(double(mantissa), -24);  // subnormal: m / 1024 * 2^-14
    else if (exponent == 0x1f)
        v = mantissa ? std::nan("") : INFINITY;
    else
        v = std::ldexp(double(mantissa | 0x400), exponent - 25);  // (1 + m / 1024) * 2^(e - 15)
    return sign ? -v : v;
}

Result<BaseStationCalibration> parse_ootx_payload(Generation generation,
                                                  std::span<const uint8_t> p) {
    const size_t need = generation == Generation::lh1 ? kLh1PayloadBytes : kLh2PayloadBytes;
    if (p.size() < need)
        return make_error(std::string("OOTX payload of ") + std::to_string(p.size()) +
                          " bytes, shorter than the " + generation_name(generation) + " layout's " +
                          std::to_string(need));
    BaseStationCalibration c;
    c.generation = generation;
    c.payload.assign(p.begin(), p.end());
    c.firmware_version = le16(p, 0);
    c.id = le32(p, 2);
    for (size_t i = 0; i < 2; ++i) {
        PlaneCalibration& pl = c.plane[i];
        pl.phase = half(p, 6 + 2 * i);
        pl.tilt = half(p, 10 + 2 * i);
        pl.curve = half(p, 16 + 2 * i);
        pl.gibbous_phase = half(p, 23 + 2 * i);
        pl.gibbous_mag = half(p, 27 + 2 * i);
        if (generation == Generation::lh2) {
            pl.ogee_phase = half(p, 33 + 2 * i);
            pl.ogee_mag = half(p, 37 + 2 * i);
        }
    }
    c.sys_unlock_count = p[14];
    c.hw_version = p[15];
    for (size_t i = 0; i < 3; ++i) c.accel_dir[i] = int8_t(p[20 + i]);
    c.mode_current = p[31];
    c.sys_faults = p[32];
    if (generation == Generation::lh2) c.nonce = le16(p, 41);
    return c;
}

std::vector<uint8_t> encode_ootx_frame(std::span<const uint8_t> payload) {
    std::vector<uint8_t> bytes;
    bytes.push_back(uint8_t(payload.size() & 0xff));
    bytes.push_back(uint8_t(payload.size() >> 8));
    bytes.insert(bytes.end(), payload.begin(), payload.end());
    if (payload.size() & 1) bytes.push_back(0);
    const uint32_t crc = crc32_of(bytes, 2, payload.size());
    for (int k = 0; k < 4; ++k) bytes.push_back(uint8_t(crc >> (8 * k)));
    std::vector<uint8_t> bits(17, 0);
    bits.push_back(1);
    for (size_t i = 0; i < bytes.size(); i += 2) {
        for (size_t b = i; b < i + 2; ++b)
            for (int k = 7; k >= 0; --k) bits.push_back((bytes[b] >> k) & 1);
        bits.push_back(1);  // the sync bit
    }
    return bits;
}

void OotxDecoder::reset() {
    if (in_frame_) ++counters_.resets;
    in_frame_ = false;
    zeros_ = 0;
}

std::optional<OotxFrame> OotxDecoder::push(int bit) {
    ++counters_.bits;
    if (bit < 0) ++counters_.unknown_bits;
    if (bit == 1 && zeros_ >= 17) {  // a preamble, wherever it comes (a frame in progress ends)
        ++counters_.preambles;
        in_frame_ = true;
        bits_.clear();
        word_bit_ = 0;
        frame_unknown_ = 0;
        needed_bits_ = 0;
        zeros_ = 0;
        return std::nullopt;
    }
    zeros_ = bit == 0 ? zeros_ + 1 : 0;
    if (!in_frame_) return std::nullopt;
    if (word_bit_ == 16) {  // the sync bit after a word: 1 (an unknown one is taken as 1)
        word_bit_ = 0;
        if (bit == 0) {
            ++counters_.bad_sync_bits;
            in_frame_ = false;
        }
        return std::nullopt;
    }
    ++word_bit_;
    bits_.push_back(int8_t(bit < 0 ? -1 : bit));
    if (bit < 0 && ++frame_unknown_ > kMaxUnknownBits) {
        ++counters_.too_many_unknown;
        in_frame_ = false;
        return std::nullopt;
    }
    if (bits_.size() == 16) {  // the length word
        size_t length = 0;
        for (size_t k = 0; k < 16; ++k) {
            if (bits_[k] < 0) {  // the length itself cannot be guessed
                ++counters_.too_many_unknown;
                in_frame_ = false;
                return std::nullopt;
            }
            // byte 0 (bits 0..7) is the low byte, each byte most significant bit first
            length |= size_t(bits_[k]) << (k < 8 ? 7 - k : 15 - (k - 8));
        }
        if (length > kMaxPayload) {
            ++counters_.too_long;
            in_frame_ = false;
            return std::nullopt;
        }
        needed_bits_ = 8 * (2 + length + (length & 1) + 4);
    }
    if (needed_bits_ && bits_.size() == needed_bits_) return finish();
    return std::nullopt;
}

OotxFrame OotxDecoder::finish() {
    in_frame_ = false;
    ++counters_.frames;
    const size_t n_bytes = bits_.size() / 8;
    std::vector<uint8_t> bytes(n_bytes, 0);
    std::vector<size_t> unknown;
    for (size_t k = 0; k < bits_.size(); ++k) {
        if (bits_[k] < 0)
            unknown.push_back(k);
        else if (bits_[k])
            bytes[k / 8] |= uint8_t(1u << (7 - k % 8));
    }
    const size_t length = size_t(bytes[0]) | size_t(bytes[1]) << 8;
    const size_t crc_at = 2 + length + (length & 1);
    OotxFrame f;
    f.end_bit = counters_.bits;
    f.unknown_bits = int(unknown.size());
    auto received_crc = [&] { return le32(bytes, crc_at); };
    for (uint32_t combo = 0; combo < (1u << unknown.size()); ++combo) {
        for (size_t u = 0; u < unknown.size(); ++u) {
            const size_t k = unknown[u];
            const uint8_t mask = uint8_t(1u << (7 - k % 8));
            bytes[k / 8] =
                (combo >> u) & 1 ? uint8_t(bytes[k / 8] | mask) : uint8_t(bytes[k / 8] & ~mask);
        }
        const uint32_t computed = crc32_of(bytes, 2, length);
        if (computed == received_crc()) {
            f.crc_ok = true;
            f.crc_received = f.crc_computed = computed;
            break;
        }
        if (combo == 0) f.crc_computed = computed;
    }
    if (!f.crc_ok) {  // report what arrived, unknown bits as 0
        for (size_t k : unknown) bytes[k / 8] &= uint8_t(~(1u << (7 - k % 8)));
        f.crc_received = received_crc();
    }
    f.payload.assign(bytes.begin() + 2, bytes.begin() + 2 + long(length));
    if (f.crc_ok)
        ++counters_.good_frames;
    else
        ++counters_.bad_crc;
    return f;
}

}  // namespace hmdnode::lighthouse
