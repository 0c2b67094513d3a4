// Text helpers shared by the trace CSV reader/writer (trace.cpp) and the table importer
// (trace_import.cpp): line splitting, strict locale-independent number parsing of whole fields,
// shortest round-trip number formatting. Pure functions, no I/O.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace hmdnode::trace_text {

struct Line {
    size_t number = 0;      // 1-based physical line number, for messages
    std::string_view text;  // without the line ending
};

// Splits text into lines: "\n" and "\r\n" both end a line; a leading UTF-8 byte-order mark is
// skipped; a last line without an ending is kept. The views point into `text`.
std::vector<Line> split_lines(std::string_view text);

// Without leading and trailing spaces and tabs.
std::string_view trim(std::string_view s);
inline bool is_blank(std::string_view s) {
    return trim(s).empty();
}
// True when the first non-blank character is '#'.
bool is_comment(std::string_view s);

// Whole-field parsers: surrounding blanks and one leading '+' are accepted; anything left over,
// an empty field or an out-of-range value gives nullopt. "nan"/"inf" parse (check finiteness).
std::optional<double> parse_double(std::string_view s);
std::optional<long double> parse_long_double(std::string_view s);
std::optional<int64_t> parse_int64(std::string_view s);

// Appends the shortest decimal text that reads back to exactly `v` (at most 17 significant
// digits), independent of the locale.
void append_double(std::string& out, double v);
void append_int64(std::string& out, int64_t v);

// Appends `item` to a list, with `separator` before it unless the list is empty.
void append_item(std::string& list, std::string_view item, std::string_view separator);

// `s` in single quotes for a message, cut to 40 characters.
std::string in_quotes(std::string_view s);

// "source:line: ", the start of a message about one line of a file.
inline std::string where(const std::string& source, size_t line) {
    return source + ":" + std::to_string(line) + ": ";
}

}  // namespace hmdnode::trace_text
