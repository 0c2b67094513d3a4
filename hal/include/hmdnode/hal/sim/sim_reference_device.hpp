// The simulated hmdnode reference tracker: the firmware's logic running on the host, and a "sim"
// TransportBackend that delivers its reports exactly as a plugged-in device would.
//
// SimReferenceFirmware is what a headset maker's firmware does (docs/tracker-protocol.md): it
// samples a motion source at the pose report rate (default 1 kHz), stamps each report with its own
// device clock in µs (offset and drift settable) and a sequence number, encodes it byte-exact with
// refproto::encode, and answers the feature reports (device info, calibration, report rate,
// time sync). It is pure: every call takes the host time explicitly, so it also drives the uhid
// device of the real-kernel lane.
//
// The sim backend owns a firmware and a clock. Reports become readable when the clock reaches
// their arrival time (measurement + latency_ns): on a SimulatedClock, read_input(timeout) moves
// time forward (Clock::sleep_until_ns) to the next report or the timeout, so a run is
// deterministic; on the system clock it really waits. unplug() makes every open Transport fail
// as an unplugged device does and hides the device from enumerate(); replug() brings it back
// (by default rebooted: sequence and device clock restart, the first report flags a clock reset).
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "hmdnode/core/pose.hpp"
#include "hmdnode/core/result.hpp"
#include "hmdnode/core/time.hpp"
#include "hmdnode/core/trace.hpp"
#include "hmdnode/hal/codec/reference_protocol.hpp"
#include "hmdnode/hal/transport.hpp"

namespace hmdnode {

// The true head pose at a host time (orientation head-to-world; angular velocity world frame).
using MotionSource = std::function<Pose(int64_t host_time_ns)>;

// A trace as motion: host time host_start_ns plays trace time trace.start_ns(); past the end it
// loops (when `loop`) or holds the last pose. The trace is shared, not copied.
MotionSource motion_from_trace(std::shared_ptr<const Trace> trace, int64_t host_start_ns,
                               bool loop = true);
// Synthetic motion: yaw = amplitude * sin(2 pi f t), pitch = amplitude/2 * sin(2 pi f/2 t).
MotionSource sinusoidal_motion(double amplitude_deg = 30.0, double frequency_hz = 0.5);

struct SimReferenceDeviceConfig {
    uint16_t vendor_id = refproto::kDevVendorId;
    uint16_t product_id = refproto::kDevProductId;
    std::string serial = "SIM-REF-0001";
    std::string product = "hmdnode simulated ref tracker";  // <= 32 bytes on the wire
    uint16_t pose_rate_hz = 1000;                           // 0: no pose reports
    int64_t latency_ns = 500'000;         // measurement to host arrival (USB + kernel)
    int64_t device_clock_offset_us = 0;   // device clock at boot
    double device_clock_drift_ppm = 0.0;  // device clock runs (1 + ppm 1e-6) times host speed
    uint32_t first_sequence = 0;          // sequence of the first report after boot
    bool send_position = false;           // position valid flag and bytes
    size_t queue_capacity = 4096;  // reports waiting for the reader (a real host's buffer); the
                                   // oldest is dropped when full and counted
};

// The firmware. Not thread-safe: one caller at a time (the sim backend serialises).
class SimReferenceFirmware {
  public:
    SimReferenceFirmware(SimReferenceDeviceConfig config, MotionSource motion);

    // Power on at host time boot_ns: device clock = offset, sequence = first_sequence, the first
    // pose report carries kPoseFlagClockReset. Reports are measured at boot_ns + k / rate.
    void boot(int64_t boot_ns);

    // Appends (to out, oldest first) every input report that has arrived at the host by host time
    // `until_ns` (arrival = measurement + latency), stamped with its arrival time. Returns how
    // many.
    size_t produce(int64_t until_ns, std::vector<InputReport>& out);
    // Host arrival time of the next report produce() will give (INT64_MAX when reports are off).
    int64_t next_arrival_ns() const;
    // Skips the reports arriving before host time t_ns without encoding them (nobody listened);
    // their sequence numbers are used up, as on a device whose reports went nowhere.
    void skip_until(int64_t t_ns);

    // Feature reports at host time now_ns. get: the report's bytes (id first). set: data[0] is
    // the id; rate and time-sync sets change the firmware's state.
    Result<std::vector<uint8_t>> get_feature(uint8_t report_id, int64_t now_ns);
    Status set_feature(std::span<const uint8_t> data, int64_t now_ns);

    // Device clock (µs) at host time t_ns.
    uint64_t device_time_us(int64_t t_ns) const;
    const SimReferenceDeviceConfig& config() const { return config_; }
    uint64_t reports_produced() const { return produced_; }

  private:
    int64_t measure_time_ns(uint64_t index) const;

    SimReferenceDeviceConfig config_;
    MotionSource motion_;
    refproto::CalibrationReport calibration_;
    refproto::TimeSyncReport pending_sync_;
    bool sync_pending_ = false;
    int64_t boot_ns_ = 0;
    int64_t schedule_origin_ns_ = 0;  // measurement time of report index schedule_index_
    uint64_t schedule_index_ = 0;
    uint64_t next_index_ = 0;  // reports since boot
    bool clock_reset_flag_ = true;
    uint64_t produced_ = 0;
};

// The "sim" TransportBackend with its device. Thread-safe: the plug controls may be called from
// any thread while another reads; each Transport is read by one thread.
class SimReferenceBackend : public TransportBackend {
  public:
    virtual void unplug() = 0;
    // reboot: the device restarts (sequence, device clock, clock-reset flag); else it carries on
    // as if only the host had stopped listening (sequence numbers jump over the gap).
    virtual void replug(bool reboot = true) = 0;
    virtual bool plugged() const = 0;
    // Reports dropped because a reader fell queue_capacity behind.
    virtual uint64_t reports_dropped() const = 0;
    // Number of times the device was plugged in (1 after creation).
    virtual uint64_t plug_count() const = 0;
};

// A plugged-in simulated device on `clock` (which must outlive the backend), booted at
// clock.now_ns(). enumerate() lists it while plugged (path "sim:<serial>").
std::unique_ptr<SimReferenceBackend> create_sim_reference_backend(Clock& clock,
                                                                  SimReferenceDeviceConfig config,
                                                                  MotionSource motion);

}  // namespace hmdnode
