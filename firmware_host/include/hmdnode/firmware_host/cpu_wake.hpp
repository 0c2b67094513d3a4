// Keeping the cores awake while the frame loop runs (docs/latency.md, "Waking cores").
//
// The frame loop sleeps between its renders and warps, and so do the renderer's worker threads
// (llvmpipe's rasteriser threads on a CPU renderer). A core that idles in between pays to wake
// up: the exit latency of a deep C-state on a real CPU, and on a virtual machine whose idle is HLT
// the hypervisor takes the vCPU away and gives it back when it pleases. That wake-up lands in the
// middle of the warp (measured on a 2-core VM with lavapipe: the one-sample warp's p50 rose from
// about 6.5 to 9-10 ms, its p99 from 12-15 to 25-30 ms). Two levers, as latency-bound Linux
// programs use them:
//
//  - PM QoS: /dev/cpu_dma_latency held at 0 µs while the guard lives (the kernel then keeps every
//    core out of idle states with an exit latency; the request ends when the file is closed).
//    Root only; effective where a cpuidle driver picks idle states.
//  - Idle spinning: one SCHED_IDLE thread per online core, pinned to it, spinning on a pause
//    instruction. The scheduler runs such a thread only when nothing else wants the core, so it
//    takes no time from the node or from anyone else, but the core never halts. It costs power:
//    every core is busy all the time.
//
// CpuWake::automatic: PM QoS where a cpuidle driver is present (a real CPU's C-states), spinning
// where none is (idle is HLT: a virtual machine, or a kernel booted with idle=halt).
//
// Threads: the guard is made and destroyed on one thread (the one that runs the node); its
// spinning threads start in start() and are joined in the destructor. Cost: nothing on the frame
// path.
#pragma once

#include <atomic>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

namespace hmdnode {

enum class CpuWake { off, automatic, qos, spin };
const char* cpu_wake_name(CpuWake w);
// "off", "auto", "qos" or "spin"; nullopt for anything else.
std::optional<CpuWake> parse_cpu_wake(std::string_view name);

class CpuWakeGuard {
  public:
    // Starts what `mode` asks for. Never fails: a lever that cannot be had (not root for PM QoS,
    // a thread that cannot be made) is left out, and description() says so.
    static std::unique_ptr<CpuWakeGuard> start(CpuWake mode);
    ~CpuWakeGuard();
    CpuWakeGuard(const CpuWakeGuard&) = delete;
    CpuWakeGuard& operator=(const CpuWakeGuard&) = delete;

    CpuWake mode() const { return mode_; }
    bool qos_held() const { return qos_fd_ >= 0; }
    size_t spinning_threads() const { return spinners_.size(); }
    // What is held, for logs and summaries: e.g. "spinning on 2 cores (SCHED_IDLE; no cpuidle
    // driver)", "PM QoS 0 us (/dev/cpu_dma_latency)", "off".
    const std::string& description() const { return description_; }
    // The kernel's thread ids of the spinning threads (tests check their policy).
    std::vector<int> spinner_tids() const;

  private:
    explicit CpuWakeGuard(CpuWake mode) : mode_(mode) {}
    CpuWake mode_;
    int qos_fd_ = -1;
    std::atomic<bool> stop_{false};
    std::vector<std::thread> spinners_;
    std::unique_ptr<std::atomic<int>[]> tids_;  // one per spinner, set by the spinner
    std::string description_;
};

// Whether the kernel has a cpuidle driver (/sys/devices/system/cpu/cpuidle/current_driver names
// one other than "none").
bool has_cpuidle_driver();

}  // namespace hmdnode
