// hmdnoded's control socket and its client (docs/daemon.md, "Control socket"): a unix stream socket
// taking newline-delimited JSON commands, one JSON reply line each. Served from the frame loop's
// thread between frames (poll with no wait, bounded work: at most kMaxClients clients, kMaxLine
// bytes a command, one read per client per frame), so a client can neither block nor stall the
// loop; a malformed command gets an error reply, an oversized one an error reply and the connection
// closed. Cost per frame: one poll() over the listening socket and the clients.
#pragma once

#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "hmdnode/core/result.hpp"
#include "hmdnode/firmware_host/control_protocol.hpp"

namespace hmdnode {

class ControlServer {
  public:
    static constexpr size_t kMaxClients = 8;
    static constexpr size_t kMaxLine = 4096;

    // Maps a command (a JSON object with "cmd") to its reply object ("ok": true/false, ...).
    using Handler = ControlHandler;

    // Binds `path` (a stale socket there is replaced), mode 0660 (the service user and its group).
    static Result<std::unique_ptr<ControlServer>> open(const std::filesystem::path& path,
                                                       Handler handler);
    ~ControlServer();
    ControlServer(const ControlServer&) = delete;
    ControlServer& operator=(const ControlServer&) = delete;

    // Accepts, reads and answers what is ready now; never waits.
    void serve();

  private:
    struct Client {
        int fd = -1;
        std::string in;
    };
    ControlServer(int fd, std::filesystem::path path, Handler handler);
    void reply(Client& c, const nlohmann::json& j);
    void drop(size_t i);

    int fd_ = -1;
    std::filesystem::path path_;
    Handler handler_;
    std::vector<Client> clients_;
};

// One request to a control socket and its reply line (the `hmdnode ctl` client).
Result<nlohmann::json> control_request(const std::filesystem::path& path,
                                       const nlohmann::json& command, int timeout_ms = 5000);

}  // namespace hmdnode
