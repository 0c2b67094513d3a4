// gzip inflation to memory with zlib (transport/gunzip.hpp). Used by the usbmon capture reader and
// the libsurvive recording reader.
#include "transport/gunzip.hpp"

#include <zlib.h>

#include <algorithm>
#include <string>

namespace hmdnode {

Result<std::vector<uint8_t>> gunzip(std::span<const uint8_t> in, bool* truncated) {
    z_stream zs{};
    if (inflateInit2(&zs, 15 + 32) != Z_OK) return make_error("gzip: inflateInit failed");
    std::vector<uint8_t> out;
    out.resize(std::max<size_t>(in.size() * 4, 1 << 16));
    zs.next_in = const_cast<Bytef*>(in.data());
    zs.avail_in = uInt(in.size());
    int rc = Z_OK;
    while (true) {
        if (zs.total_out == out.size()) out.resize(out.size() * 2);
        zs.next_out = out.data() + zs.total_out;
        zs.avail_out = uInt(out.size() - zs.total_out);
        rc = inflate(&zs, Z_NO_FLUSH);
        if (rc == Z_STREAM_END) break;
        if (rc == Z_BUF_ERROR && zs.avail_in == 0) break;  // truncated stream
        if (rc != Z_OK && rc != Z_BUF_ERROR) {
            std::string msg = zs.msg ? zs.msg : "error";
            inflateEnd(&zs);
            return make_error("gzip: corrupt data at compressed byte " +
                              std::to_string(zs.total_in) + ": " + msg);
        }
        if (out.size() > (size_t(4) << 30)) {
            inflateEnd(&zs);
            return make_error("gzip: inflates past 4 GiB");
        }
    }
    const size_t n = zs.total_out;
    inflateEnd(&zs);
    *truncated = rc != Z_STREAM_END;
    out.resize(n);
    return out;
}

}  // namespace hmdnode
