#include "hmdnode/firmware_host/control_socket.hpp"

#include <fcntl.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace hmdnode {
namespace {

Result<sockaddr_un> unix_address(const std::filesystem::path& path) {
    sockaddr_un a{};
    a.sun_family = AF_UNIX;
    if (path.string().size() >= sizeof a.sun_path)
        return make_error("control socket " + path.string() + ": path too long");
    std::memcpy(a.sun_path, path.c_str(), path.string().size());
    return a;
}

}  // namespace

ControlServer::ControlServer(int fd, std::filesystem::path path, Handler handler)
    : fd_(fd), path_(std::move(path)), handler_(std::move(handler)) {
    clients_.reserve(kMaxClients);
}

ControlServer::~ControlServer() {
    for (Client& c : clients_) ::close(c.fd);
    ::close(fd_);
    ::unlink(path_.c_str());
}

Result<std::unique_ptr<ControlServer>> ControlServer::open(const std::filesystem::path& path,
                                                           Handler handler) {
    Result<sockaddr_un> a = unix_address(path);
    if (!a.ok()) return a.error();
    const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
    if (fd < 0) return make_error("control socket: " + std::string(std::strerror(errno)));
    struct stat st {};
    if (::lstat(path.c_str(), &st) == 0 && S_ISSOCK(st.st_mode)) ::unlink(path.c_str());
    if (::bind(fd, reinterpret_cast<const sockaddr*>(&*a), sizeof *a) != 0 ||
        ::chmod(path.c_str(), 0660) != 0 || ::listen(fd, int(kMaxClients)) != 0) {
        const std::string why = std::strerror(errno);
        ::close(fd);
        return make_error("control socket " + path.string() + ": " + why);
    }
    return std::unique_ptr<ControlServer>(new ControlServer(fd, path, std::move(handler)));
}

void ControlServer::reply(Client& c, const nlohmann::json& j) {
    // note: replace, not throw: a reply may carry a device's or the system's text, which need not
    // be UTF-8 (last_error).
    const std::string line =
        j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
    // note: a client that does not read its replies loses them; the loop never waits for it.
    (void)::send(c.fd, line.data(), line.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
}

void ControlServer::drop(size_t i) {
    ::close(clients_[i].fd);
    clients_.erase(clients_.begin() + long(i));
}

void ControlServer::serve() {
    pollfd fds[kMaxClients + 1];
    fds[0] = {fd_, POLLIN, 0};
    for (size_t i = 0; i < clients_.size(); ++i) fds[i + 1] = {clients_[i].fd, POLLIN, 0};
    if (::poll(fds, nfds_t(clients_.size() + 1), 0) <= 0) return;
    // Clients first (indices stay valid), from the last so that dropping one keeps the others'.
    for (size_t k = clients_.size(); k-- > 0;) {
        if (!(fds[k + 1].revents & (POLLIN | POLLHUP | POLLERR))) continue;
        Client& c = clients_[k];
        char buf[kMaxLine];
        const ssize_t n = ::recv(c.fd, buf, sizeof buf, MSG_DONTWAIT);
        if (n <= 0) {
            if (n < 0 && (errno == EAGAIN || errno == EINTR)) continue;
            drop(k);
            continue;
        }
        c.in.append(buf, size_t(n));
        bool close_it = false;
        for (size_t nl; !close_it && (nl = c.in.find('\n')) != std::string::npos;) {
            const std::string line = c.in.substr(0, nl);
            c.in.erase(0, nl + 1);
            if (line.size() > kMaxLine) {
                reply(c, {{"ok", false}, {"error", "command longer than 4096 bytes"}});
                close_it = true;
                break;
            }
            reply(c, answer_control_line(line, handler_));
        }
        if (!close_it && c.in.size() > kMaxLine) {
            reply(c, {{"ok", false}, {"error", "command longer than 4096 bytes"}});
            close_it = true;
        }
        if (close_it) drop(k);
    }
    if (fds[0].revents & POLLIN) {
        const int cfd = ::accept4(fd_, nullptr, nullptr, SOCK_CLOEXEC | SOCK_NONBLOCK);
        if (cfd >= 0) {
            if (clients_.size() < kMaxClients) {
                clients_.push_back({cfd, {}});
            } else {
                const char busy[] = "{\"ok\":false,\"error\":\"too many clients\"}\n";
                (void)::send(cfd, busy, sizeof busy - 1, MSG_NOSIGNAL | MSG_DONTWAIT);
                ::close(cfd);
            }
        }
    }
}

Result<nlohmann::json> control_request(const std::filesystem::path& path,
                                       const nlohmann::json& command, int timeout_ms) {
    Result<sockaddr_un> a = unix_address(path);
    if (!a.ok()) return a.error();
    const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
    if (fd < 0) return make_error(std::string("socket: ") + std::strerror(errno));
    struct Closer {
        int fd;
        ~Closer() { ::close(fd); }
    } closer{fd};
    if (::connect(fd, reinterpret_cast<const sockaddr*>(&*a), sizeof *a) != 0)
        return make_error(path.string() + ": cannot connect: " + std::strerror(errno) +
                          " (is hmdnoded running with a control socket there?)");
    const std::string line = command.dump() + "\n";
    if (::send(fd, line.data(), line.size(), MSG_NOSIGNAL) != ssize_t(line.size()))
        return make_error(path.string() + ": send failed: " + std::strerror(errno));
    std::string in;
    while (in.find('\n') == std::string::npos) {
        pollfd p{fd, POLLIN, 0};
        if (::poll(&p, 1, timeout_ms) <= 0)
            return make_error(path.string() + ": no reply within " + std::to_string(timeout_ms) +
                              " ms");
        char buf[65536];
        const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
        if (n <= 0) return make_error(path.string() + ": connection closed without a reply");
        in.append(buf, size_t(n));
    }
    nlohmann::json j = nlohmann::json::parse(in.substr(0, in.find('\n')), nullptr, false);
    if (j.is_discarded()) return make_error(path.string() + ": the reply is not JSON");
    return j;
}

}  // namespace hmdnode
