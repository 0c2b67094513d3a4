#include "daemon/sd_notify.hpp"

#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <algorithm>
#include <cstddef>
#include <cstdlib>
#include <cstring>

namespace hmdnode {

SystemdNotifier::SystemdNotifier() {
    const char* sock = std::getenv("NOTIFY_SOCKET");
    const char* wd = std::getenv("WATCHDOG_USEC");
    const char* wd_pid = std::getenv("WATCHDOG_PID");
    if (wd && (!wd_pid || std::strtoll(wd_pid, nullptr, 10) == int64_t(getpid())))
        watchdog_usec_ = std::max<int64_t>(0, std::strtoll(wd, nullptr, 10));
    if (sock && (sock[0] == '/' || sock[0] == '@') &&
        std::strlen(sock) < sizeof(sockaddr_un::sun_path)) {
        address_ = sock;
        if (address_[0] == '@') address_[0] = '\0';
        fd_ = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
    }
    if (fd_ < 0) watchdog_usec_ = 0;  // note: no socket, nobody to pet
    ::unsetenv("NOTIFY_SOCKET");
    ::unsetenv("WATCHDOG_USEC");
    ::unsetenv("WATCHDOG_PID");
}

SystemdNotifier::~SystemdNotifier() {
    if (fd_ >= 0) ::close(fd_);
}

bool SystemdNotifier::notify(std::string_view state) {
    if (fd_ < 0) return false;
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    std::memcpy(addr.sun_path, address_.data(), address_.size());
    const socklen_t len = socklen_t(offsetof(sockaddr_un, sun_path) + address_.size() +
                                    (address_[0] == '\0' ? 0 : 1));
    return ::sendto(fd_, state.data(), state.size(), MSG_NOSIGNAL | MSG_DONTWAIT,
                    reinterpret_cast<const sockaddr*>(&addr), len) == ssize_t(state.size());
}

}  // namespace hmdnode
