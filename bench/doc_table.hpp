// Benchmarks write the tables the docs show: `--write-docs` replaces the text between
// `<!-- NAME -->` and `<!-- /NAME -->` in a markdown file, atomically. Header-only (benches are
// one file each).
#pragma once

#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>

#include "hmdnode/core/atomic_file.hpp"

namespace hmdnode::bench {

// True when --write-docs is among the arguments.
inline bool wants_docs(int argc, char** argv) {
    for (int i = 1; i < argc; ++i)
        if (std::string(argv[i]) == "--write-docs") return true;
    return false;
}

// Replaces the marked block of `path` with `text`; prints why and returns false when it cannot.
inline bool write_doc_table(const std::string& path, const std::string& name,
                            const std::string& text) {
    std::ifstream in(path);
    std::stringstream ss;
    ss << in.rdbuf();
    std::string doc = ss.str();
    const std::string open = "<!-- " + name + " -->", close = "<!-- /" + name + " -->";
    const size_t a = doc.find(open), b = doc.find(close);
    if (a == std::string::npos || b == std::string::npos || b < a) {
        std::fprintf(stderr, "%s: no %s ... %s markers\n", path.c_str(), open.c_str(),
                     close.c_str());
        return false;
    }
    doc = doc.substr(0, a + open.size()) + "\n" + text + doc.substr(b);
    if (Status s = write_file_atomically(path, doc); !s.ok()) {
        std::fprintf(stderr, "%s\n", s.error().message.c_str());
        return false;
    }
    return true;
}

}  // namespace hmdnode::bench
