// cat(a, b, ...): its arguments streamed into one string, for error messages that name a file, a
// field or a byte ("mesh ", i, " \"", name, "\": ...").
//
// Thread: any. Cost: one std::ostringstream per call.
#pragma once

#include <sstream>
#include <string>

namespace hmdnode {

template <class... Args>
std::string cat(const Args&... args) {
    std::ostringstream s;
    (s << ... << args);
    return s.str();
}

}  // namespace hmdnode
