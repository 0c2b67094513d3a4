// libFuzzer harness: every decoder of the reference tracker protocol on untrusted bytes. A report
// that decodes must encode back to bytes that decode again to the same fields.
#include <cstdint>
#include <cstdlib>
#include <span>

#include "hmdnode/hal/codec/reference_protocol.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    using namespace hmdnode::refproto;
    std::span<const uint8_t> b(data, size);
    if (auto r = decode_pose(b); r.ok()) {
        auto again = decode_pose(encode(*r));
        if (!again.ok() || again->sequence != r->sequence ||
            again->device_time_us != r->device_time_us || again->flags != r->flags)
            abort();
    }
    if (auto r = decode_imu(b); r.ok()) {
        auto again = decode_imu(encode(*r));
        if (!again.ok() || again->count != r->count || again->first_sequence != r->first_sequence)
            abort();
        for (size_t i = 0; i < r->count; ++i)
            if (again->samples[i].accel != r->samples[i].accel ||
                again->samples[i].gyro != r->samples[i].gyro)
                abort();
    }
    if (auto r = decode_device_info(b); r.ok()) {
        auto again = decode_device_info(encode(*r));
        if (!again.ok() || again->capabilities != r->capabilities) abort();
    }
    if (auto r = decode_calibration(b); r.ok())
        if (!decode_calibration(encode(*r)).ok()) abort();
    if (auto r = decode_report_rate(b); r.ok())
        if (!decode_report_rate(encode(*r)).ok()) abort();
    if (auto r = decode_time_sync(b); r.ok()) {
        auto again = decode_time_sync(encode(*r));
        if (!again.ok() || again->nonce != r->nonce) abort();
        (void)time_sync_estimate(*r, 0);
    }
    return 0;
}
