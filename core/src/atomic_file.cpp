#include "hmdnode/core/atomic_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>

namespace hmdnode {

Status write_file_atomically(const std::filesystem::path& path, std::string_view bytes) {
    std::filesystem::path dir = path.parent_path().empty() ? "." : path.parent_path();
    std::error_code ec;
    if (!std::filesystem::is_directory(dir, ec))
        return make_error(path.string() + ": directory " + dir.string() + " does not exist");
    std::string tmpl = (dir / ("." + path.filename().string() + ".tmp.XXXXXX")).string();
    int fd = mkstemp(tmpl.data());
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
    const int fd = mkstemp(tmpl.data());
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
