// Keeping the cores awake while the frame loop runs (hmdnode/firmware_host/cpu_wake.hpp): PM QoS
// through /dev/cpu_dma_latency (the kernel's interface for a latency request: a 32-bit value in
// microseconds written to the open file, held until it is closed; Documentation/power/pm_qos_
// interface.rst) and SCHED_IDLE spinners pinned one per core (sched(7): SCHED_IDLE runs only when
// no other thread wants the core). Cost: one open and write, or one thread per core that spins
// on a pause instruction; nothing on the frame path.
#include "hmdnode/firmware_host/cpu_wake.hpp"

#include <fcntl.h>
#include <pthread.h>
#include <sched.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <cassert>
#include <cerrno>
#include <cstdint>
#include <cstring>
#include <fstream>

namespace hmdnode {
namespace {

inline void cpu_relax() {
#if defined(__x86_64__) || defined(__i386__)
    __builtin_ia32_pause();
#elif defined(__aarch64__) || defined(__arm__)
    asm volatile("yield");
#endif
}

}  // namespace

bool has_cpuidle_driver() {
    std::ifstream in("/sys/devices/system/cpu/cpuidle/current_driver");
    std::string driver;
    return in && std::getline(in, driver) && !driver.empty() && driver != "none";
}

std::unique_ptr<CpuWakeGuard> CpuWakeGuard::start(CpuWake mode) {
    std::unique_ptr<CpuWakeGuard> g(new CpuWakeGuard(mode));
    if (mode == CpuWake::off) {
        g->description_ = "off";
        return g;
    }
    const bool cpuidle = has_cpuidle_driver();
    const bool want_qos = mode == CpuWake::qos || (mode == CpuWake::automatic && cpuidle);
    const bool want_spin = mode == CpuWake::spin || (mode == CpuWake::automatic && !cpuidle);
    std::string why;
    if (want_qos) {
        g->qos_fd_ = ::open("/dev/cpu_dma_latency", O_WRONLY | O_CLOEXEC);
        const int32_t zero = 0;
        if (g->qos_fd_ >= 0 && ::write(g->qos_fd_, &zero, sizeof zero) == ssize_t(sizeof zero)) {
            g->description_ = "PM QoS 0 us (/dev/cpu_dma_latency)";
        } else {
            why =
                std::string("PM QoS not held (/dev/cpu_dma_latency: ") + std::strerror(errno) + ")";
            if (g->qos_fd_ >= 0) ::close(g->qos_fd_);
            g->qos_fd_ = -1;
        }
        if (!cpuidle) g->description_ += g->qos_fd_ >= 0 ? " (no cpuidle driver: no effect)" : "";
    }
    if (want_spin) {
        cpu_set_t allowed;
        CPU_ZERO(&allowed);
        if (sched_getaffinity(0, sizeof allowed, &allowed) != 0) CPU_SET(0, &allowed);
        std::vector<int> cpus;
        for (int c = 0; c < CPU_SETSIZE; ++c)
            if (CPU_ISSET(c, &allowed)) cpus.push_back(c);
        assert(!cpus.empty());  // the thread runs somewhere (CPU 0 when the mask is unknown)
        g->tids_ = std::make_unique<std::atomic<int>[]>(cpus.size());
        for (size_t i = 0; i < cpus.size(); ++i) {
            std::atomic<int>* tid = &g->tids_[i];
            std::atomic<bool>* stop = &g->stop_;
            const int cpu = cpus[i];
            try {
                g->spinners_.emplace_back([tid, stop, cpu] {
                    // Idle class first: from here on this thread never takes a core from anyone.
                    sched_param p{};
                    p.sched_priority = 0;
                    (void)sched_setscheduler(0, SCHED_IDLE, &p);
                    cpu_set_t one;
                    CPU_ZERO(&one);
                    CPU_SET(cpu, &one);
                    (void)pthread_setaffinity_np(pthread_self(), sizeof one, &one);
                    tid->store(int(::syscall(SYS_gettid)), std::memory_order_release);
                    while (!stop->load(std::memory_order_relaxed)) cpu_relax();
                });
            } catch (const std::system_error& e) {
                why += (why.empty() ? "" : "; ") + std::string("a spinning thread: ") + e.what();
                break;
            }
        }
        assert(g->spinners_.size() <= cpus.size());  // one spinner per allowed core at most
        if (!g->spinners_.empty()) {
            if (!g->description_.empty()) g->description_ += "; ";
            g->description_ += "spinning on " + std::to_string(g->spinners_.size()) +
                               (g->spinners_.size() == 1 ? " core" : " cores") + " (SCHED_IDLE" +
                               (cpuidle ? ")" : "; no cpuidle driver)");
        }
    }
    if (!why.empty()) g->description_ += (g->description_.empty() ? "" : "; ") + why;
    if (g->description_.empty()) g->description_ = "nothing held";
    return g;
}

CpuWakeGuard::~CpuWakeGuard() {
    stop_.store(true, std::memory_order_relaxed);
    for (std::thread& t : spinners_) t.join();
    if (qos_fd_ >= 0) ::close(qos_fd_);
}

std::vector<int> CpuWakeGuard::spinner_tids() const {
    std::vector<int> out;
    for (size_t i = 0; i < spinners_.size(); ++i) {
        // Each spinner sets its id first thing; wait for it (a few microseconds).
        int tid;
        while ((tid = tids_[i].load(std::memory_order_acquire)) == 0) std::this_thread::yield();
        out.push_back(tid);
    }
    return out;
}

}  // namespace hmdnode
