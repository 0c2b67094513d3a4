// The systemd service notification protocol (sd_notify(3), "Notes": a datagram of newline-separated
// KEY=VALUE lines sent to the AF_UNIX socket named by $NOTIFY_SOCKET; '@' starts an abstract
// name), implemented here rather than linking libsystemd: one socket, one sendto per message.
// Cost: one non-blocking sendto a message; nothing when $NOTIFY_SOCKET is unset (not under
// systemd, or Type=simple).
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

namespace hmdnode {

class SystemdNotifier {
  public:
    // Reads $NOTIFY_SOCKET and $WATCHDOG_USEC (honoured only when $WATCHDOG_PID is unset or this
    // process), then unsets them so that no child process inherits them.
    SystemdNotifier();
    ~SystemdNotifier();
    SystemdNotifier(const SystemdNotifier&) = delete;
    SystemdNotifier& operator=(const SystemdNotifier&) = delete;

    bool enabled() const { return fd_ >= 0; }
    // The watchdog period systemd asked for (WatchdogSec=), 0 when none.
    int64_t watchdog_usec() const { return watchdog_usec_; }
    // Sends `state` ("READY=1\nSTATUS=..."); never blocks. False when not enabled or not sent.
    bool notify(std::string_view state);

  private:
    int fd_ = -1;
    std::string address_;  // sockaddr_un path bytes; abstract: a leading NUL
    int64_t watchdog_usec_ = 0;
};

}  // namespace hmdnode
