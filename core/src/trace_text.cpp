#include "trace_text.hpp"

#include <charconv>
#include <system_error>

namespace hmdnode::trace_text {

std::vector<Line> split_lines(std::string_view text) {
    std::vector<Line> lines;
    if (text.substr(0, 3) == "\xEF\xBB\xBF") text.remove_prefix(3);
    size_t number = 1;
    while (!text.empty()) {
        size_t end = text.find('\n');
        std::string_view line = text.substr(0, end);
        if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
        lines.push_back({number++, line});
        if (end == std::string_view::npos) break;
        text.remove_prefix(end + 1);
    }
    return lines;
}

std::string_view trim(std::string_view s) {
    size_t b = s.find_first_not_of(" \t");
    if (b == std::string_view::npos) return {};
    size_t e = s.find_last_not_of(" \t");
    return s.substr(b, e - b + 1);
}

bool is_comment(std::string_view s) {
    s = trim(s);
    return !s.empty() && s.front() == '#';
}

namespace {

// The trimmed field without one leading '+' (from_chars rejects it), or empty when unusable.
std::string_view number_text(std::string_view s) {
    s = trim(s);
    if (!s.empty() && s.front() == '+') {
        s.remove_prefix(1);
        // note: "+-1" must not parse.
        if (!s.empty() && s.front() == '-') return {};
    }
    return s;
}

template <class T>
std::optional<T> parse_whole(std::string_view s) {
    s = number_text(s);
    if (s.empty()) return std::nullopt;
    T v{};
    auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
    if (ec != std::errc() || ptr != s.data() + s.size()) return std::nullopt;
    return v;
}

}  // namespace

std::optional<double> parse_double(std::string_view s) {
    return parse_whole<double>(s);
}
std::optional<long double> parse_long_double(std::string_view s) {
    return parse_whole<long double>(s);
}
std::optional<int64_t> parse_int64(std::string_view s) {
    return parse_whole<int64_t>(s);
}

void append_double(std::string& out, double v) {
    char buf[64];
    auto [ptr, ec] = std::to_chars(buf, buf + sizeof buf, v);
    out.append(buf, ec == std::errc() ? ptr : buf);
}

void append_int64(std::string& out, int64_t v) {
    char buf[32];
    auto [ptr, ec] = std::to_chars(buf, buf + sizeof buf, v);
    out.append(buf, ec == std::errc() ? ptr : buf);
}

void append_item(std::string& list, std::string_view item, std::string_view separator) {
    if (!list.empty()) list += separator;
    list += item;
}

std::string in_quotes(std::string_view s) {
    constexpr size_t kMax = 40;
    std::string out = "'";
    out += s.substr(0, kMax);
    if (s.size() > kMax) out += "...";
    out += "'";
    return out;
}

}  // namespace hmdnode::trace_text
