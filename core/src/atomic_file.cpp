#include "hmdnode/core/atomic_file.hpp"

#include <fcntl.h>
#include <pthread.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstring>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>

namespace hmdnode {
namespace {

// The temporary files in flight: a slot is claimed with `state` 0 -> 1 (being filled), published
// as 2 (its path complete) and freed with 0. The handler reads only published slots.
constexpr int kSlots = 16;
constexpr size_t kPathMax = 4096;
struct Slot {
    std::atomic<int> state{0};
    char path[kPathMax];
};
Slot g_slots[kSlots];

void remove_temporaries_and_die(int sig) {
    for (Slot& s : g_slots)
        if (s.state.load() == 2) ::unlink(s.path);
    std::signal(sig, SIG_DFL);
    ::raise(sig);
}

}  // namespace

TemporaryFileGuard::TemporaryFileGuard(const std::string& path) {
    if (path.size() >= kPathMax) return;
    for (int i = 0; i < kSlots; ++i) {
        int expected = 0;
        if (g_slots[i].state.compare_exchange_strong(expected, 1)) {
            std::memcpy(g_slots[i].path, path.c_str(), path.size() + 1);
            g_slots[i].state.store(2);
            slot_ = i;
            return;
        }
    }
}

TemporaryFileGuard::~TemporaryFileGuard() {
    if (slot_ >= 0) g_slots[slot_].state.store(0);
}

namespace {

// mkstemp and its registration with the termination signals blocked, so no moment leaves the
// file on disk unregistered.
int make_temporary(std::string& tmpl, std::optional<TemporaryFileGuard>* guard) {
    sigset_t block, old;
    sigemptyset(&block);
    for (int sig : {SIGTERM, SIGINT, SIGHUP}) sigaddset(&block, sig);
    pthread_sigmask(SIG_BLOCK, &block, &old);
    const int fd = mkstemp(tmpl.data());
    const int saved = errno;
    if (fd >= 0) guard->emplace(tmpl);
    pthread_sigmask(SIG_SETMASK, &old, nullptr);
    errno = saved;
    return fd;
}

}  // namespace

void remove_temporaries_on_termination() {
    struct sigaction sa {};
    sa.sa_handler = remove_temporaries_and_die;
    sigemptyset(&sa.sa_mask);
    // note: the other two blocked while one is handled, so the table is unlinked once.
    for (int sig : {SIGTERM, SIGINT, SIGHUP}) sigaddset(&sa.sa_mask, sig);
    for (int sig : {SIGTERM, SIGINT, SIGHUP}) sigaction(sig, &sa, nullptr);
}

Status write_file_atomically(const std::filesystem::path& path, std::string_view bytes) {
    std::filesystem::path dir = path.parent_path().empty() ? "." : path.parent_path();
    std::error_code ec;
    if (!std::filesystem::is_directory(dir, ec))
        return make_error(path.string() + ": directory " + dir.string() + " does not exist");
    std::string tmpl = (dir / ("." + path.filename().string() + ".tmp.XXXXXX")).string();
    std::optional<TemporaryFileGuard> guard;
    int fd = make_temporary(tmpl, &guard);
    if (fd < 0)
        return make_error(path.string() +
                          ": cannot create temporary file: " + std::strerror(errno));
    size_t done = 0;
    while (done < bytes.size()) {
        ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
        if (n < 0) {
            if (errno == EINTR) continue;
            std::string why = std::strerror(errno);
            ::close(fd);
            ::unlink(tmpl.c_str());
            return make_error(path.string() + ": write failed: " + why);
        }
        done += size_t(n);
    }
    fchmod(fd, 0644);
    if (::fsync(fd) != 0 || ::close(fd) != 0) {
        ::unlink(tmpl.c_str());
        return make_error(path.string() + ": flush failed: " + std::strerror(errno));
    }
    if (std::rename(tmpl.c_str(), path.c_str()) != 0) {
        std::string why = std::strerror(errno);
        ::unlink(tmpl.c_str());
        return make_error(path.string() + ": rename failed: " + why);
    }
    return {};
}

Status check_output_file(const std::filesystem::path& path) {
    const std::filesystem::path dir = path.parent_path().empty() ? "." : path.parent_path();
    std::error_code ec;
    if (path.filename().empty() || std::filesystem::is_directory(path, ec))
        return make_error(path.string() + ": is a directory");
    if (!std::filesystem::is_directory(dir, ec))
        return make_error(path.string() + ": directory " + dir.string() + " does not exist");
    std::string tmpl = (dir / ("." + path.filename().string() + ".check.XXXXXX")).string();
    std::optional<TemporaryFileGuard> guard;
    const int fd = make_temporary(tmpl, &guard);
    if (fd < 0)
        return make_error(path.string() + ": cannot create a file in " + dir.string() + ": " +
                          std::strerror(errno));
    ::close(fd);
    ::unlink(tmpl.c_str());
    return {};
}

Result<std::string> read_file(const std::filesystem::path& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) return make_error(path.string() + ": cannot open: " + std::strerror(errno));
    std::ostringstream ss;
    ss << in.rdbuf();
    if (in.bad()) return make_error(path.string() + ": read failed");
    return ss.str();
}

}  // namespace hmdnode
