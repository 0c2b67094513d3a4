// Lighthouse base-station calibration ("OOTX"): the frame a base station repeats, one bit at a
// time, in its sync signal (lighthouse 1: the data bit of every sync pulse it sends, 120 bits/s;
// lighthouse 2: one bit per rotor turn, carried with the device's sync events, ~50 bits/s), and the
// per-plane parameters it holds.
//
// Frame (as libsurvive's ootx_decoder.c and the "LighthouseRedox" notes describe it): a preamble of
// 17 zeros and a one; then 16-bit words, each followed by a sync bit that must be 1 (so a frame
// never holds 17 zeros in a row); the first word is the payload length in bytes (low byte sent
// first, each byte most significant bit first), then the payload (padded to an even length), then
// its CRC-32 (zlib's, little endian) over the unpadded payload. Payload layouts: lighthouse 1
// "v6" (33 bytes), lighthouse 2 "v15" (43 bytes), both little endian with IEEE half floats
// (libsurvive's init_lighthouse_info_v6 / _v15).
//
// A sync the device missed (a gap of k rotor turns) is an unknown bit: a frame with at most
// kMaxUnknownBits unknown data bits is completed by trying every value against its CRC (a wrong
// completion passes with probability 2^(k-32)); more, a bad sync bit, or a frame longer than
// kMaxPayload abandon the frame. A bad CRC is reported, never used. One thread; O(1) per bit,
// O(2^k · payload) per frame with k unknown bits.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "hmdnode/core/result.hpp"

namespace hmdnode::lighthouse {

enum class Generation : uint8_t { lh1 = 1, lh2 = 2 };
const char* generation_name(Generation g);  // "lighthouse 1", "lighthouse 2"

// One rotor's (lighthouse 1) or one tilted plane's (lighthouse 2) factory calibration, as the frame
// holds it: radians (tilt: the plane's tilt angle for lighthouse 2, the tangent's argument for
// lighthouse 1, as libsurvive applies tan() to it), the gibbous/ogee phases in radians, magnitudes
// dimensionless. The ogee terms are lighthouse 2 only (0 for lighthouse 1).
struct PlaneCalibration {
    double phase = 0, tilt = 0, curve = 0, gibbous_phase = 0, gibbous_mag = 0, ogee_phase = 0,
           ogee_mag = 0;
};

struct BaseStationCalibration {
    Generation generation = Generation::lh2;
    uint16_t firmware_version = 0;  // bits 15..6 firmware, 5..0 protocol
    uint32_t id = 0;                // the base station's unique id
    std::array<PlaneCalibration, 2> plane{};
    std::array<int8_t, 3> accel_dir{};  // "up" as the base station's accelerometer reads it
    uint8_t sys_unlock_count = 0;
    uint8_t hw_version = 0;    // lighthouse 1: hardware version; lighthouse 2: "OOTX model"
    uint8_t mode_current = 0;  // lighthouse 1: 0 = A, 1 = B, 2 = C; lighthouse 2: bit 7 flag + mode
    uint8_t sys_faults = 0;
    uint16_t nonce = 0;            // lighthouse 2 only
    std::vector<uint8_t> payload;  // the frame's payload bytes as received
};

constexpr size_t kLh1PayloadBytes = 33;
constexpr size_t kLh2PayloadBytes = 43;
constexpr size_t kMaxPayload = 58;  // libsurvive's 64-byte frame buffer less length and CRC
constexpr int kMaxUnknownBits = 8;

// IEEE 754 binary16 to double (subnormals, infinities and NaN included).
double half_to_double(uint16_t h);

// The payload of a frame of `generation`; too short a payload is an error naming its length.
Result<BaseStationCalibration> parse_ootx_payload(Generation generation,
                                                  std::span<const uint8_t> payload);

// The bits of one frame for a payload (tests, fuzz seeds and simulated base stations): preamble,
// length, payload, padding, CRC-32, a sync bit after every 16 bits.
std::vector<uint8_t> encode_ootx_frame(std::span<const uint8_t> payload);

struct OotxFrame {
    uint64_t end_bit = 0;  // the decoder's bit count when the frame ended
    bool crc_ok = false;   // a bad CRC: payload is what arrived, not to be used
    int unknown_bits = 0;  // resolved by the CRC when crc_ok
    uint32_t crc_received = 0;
    uint32_t crc_computed = 0;  // of the payload as received (unknown bits as 0) when !crc_ok
    std::vector<uint8_t> payload;
};

struct OotxCounters {
    uint64_t bits = 0;          // bits pushed, unknown ones included
    uint64_t unknown_bits = 0;  // of those
    uint64_t preambles = 0;
    uint64_t frames = 0;  // complete frames (good or bad CRC)
    uint64_t good_frames = 0;
    uint64_t bad_crc = 0;
    uint64_t bad_sync_bits = 0;     // a 0 where a sync bit belongs: the frame abandoned
    uint64_t too_many_unknown = 0;  // frames abandoned with more than kMaxUnknownBits unknown
    uint64_t too_long = 0;          // a length word beyond kMaxPayload
    uint64_t resets = 0;            // discontinuities (reset()) inside a frame
};

class OotxDecoder {
  public:
    // One bit of the stream: 0, 1, or -1 for a sync the device missed. Returns the frame the bit
    // completed, if it did.
    std::optional<OotxFrame> push(int bit);
    // A discontinuity (the device's clock restarted, many syncs lost): any frame in progress is
    // abandoned; the preamble search starts afresh.
    void reset();
    const OotxCounters& counters() const { return counters_; }
    // Where a frame in progress stands: data bits received after its preamble (0 when searching)
    // and the bits the frame needs in all (0 until its length word arrived).
    uint64_t frame_bits() const { return in_frame_ ? bits_.size() : 0; }
    uint64_t frame_bits_needed() const { return needed_bits_; }

  private:
    OotxFrame finish();
    OotxCounters counters_;
    int zeros_ = 0;             // consecutive known zeros (the preamble's 17)
    bool in_frame_ = false;     // after a preamble
    int word_bit_ = 0;          // 0..16 within the current 17-bit group
    std::vector<int8_t> bits_;  // the frame's data bits (sync bits dropped), -1 = unknown
    int frame_unknown_ = 0;
    uint64_t needed_bits_ = 0;
};

}  // namespace hmdnode::lighthouse
