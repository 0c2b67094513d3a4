// Reading a Vive/Index device's JSON configuration over HID feature reports (0x10 start, 0x11
// chunks, zlib): lighthouse_config.hpp. Cost: one round trip per 62 compressed bytes, O(size).
#include "hmdnode/hal/codec/lighthouse_config.hpp"

#include <algorithm>
#include <cctype>
#include <vector>

#include "transport/gunzip.hpp"

namespace hmdnode {

Result<std::string> read_lighthouse_config(Transport& t) {
    using namespace lighthouse_config;
    auto start = t.get_feature(kStartReportId, kReportSize);
    if (!start)
        return make_error("configuration read: feature report 0x10: " + start.error().message);
    if (start->size() < 3 || (*start)[0] != kStartReportId)
        return make_error("configuration read: feature report 0x10 answered " +
                          std::to_string(start->size()) + " bytes starting with report id " +
                          std::to_string(start->empty() ? -1 : int((*start)[0])));
    const size_t expected = size_t((*start)[1]) << 8 | (*start)[2];
    std::vector<uint8_t> compressed;
    for (size_t chunk = 0;; ++chunk) {
        if (chunk == kMaxChunks)
            return make_error("configuration read: more than " + std::to_string(kMaxChunks) +
                              " chunks (feature report 0x11) without the closing empty one");
        auto r = t.get_feature(kChunkReportId, kReportSize);
        if (!r)
            return make_error("configuration read: feature report 0x11 (chunk " +
                              std::to_string(chunk) + "): " + r.error().message);
        if (r->size() < 2 || (*r)[0] != kChunkReportId)
            return make_error("configuration read: chunk " + std::to_string(chunk) +
                              ": a reply of " + std::to_string(r->size()) +
                              " bytes that is not feature report 0x11");
        const size_t n = (*r)[1];
        if (n == 0) break;
        if (n > r->size() - 2)
            return make_error("configuration read: chunk " + std::to_string(chunk) +
                              ": byte 1 gives length " + std::to_string(n) + " in a report of " +
                              std::to_string(r->size()) + " bytes");
        compressed.insert(compressed.end(), r->begin() + 2, r->begin() + 2 + long(n));
    }
    if (compressed.size() < expected)
        return make_error("configuration read: " + std::to_string(compressed.size()) +
                          " compressed bytes, fewer than the " + std::to_string(expected) +
                          " feature report 0x10 announced");
    bool truncated = false;
    auto json = gunzip(compressed, &truncated);
    if (!json) return make_error("configuration read: " + json.error().message);
    if (truncated)
        return make_error("configuration read: the zlib stream of " +
                          std::to_string(compressed.size()) + " bytes is cut short");
    return std::string(json->begin(), json->end());
}

LighthouseModel lighthouse_model(const std::string& model_number) {
    std::string m = model_number;
    std::transform(m.begin(), m.end(), m.begin(),
                   [](unsigned char c) { return char(std::tolower(c)); });
    if (m.empty()) return LighthouseModel::Unknown;
    if (m.find("utah") != std::string::npos || m.find("index") != std::string::npos)
        return LighthouseModel::Index;
    if (m.find("vive_pro") != std::string::npos || m.find("vive pro") != std::string::npos)
        return LighthouseModel::VivePro;
    return LighthouseModel::Other;
}

}  // namespace hmdnode
