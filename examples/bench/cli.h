// Command-line helpers the benchmark programs share (aacbvh-bench,
// aacbvh-hit-accuracy), and the CPU model every reported figure is named with.
#pragma once

#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

namespace bench {

/// The non-empty parts of `s` between `sep` characters.
inline std::vector<std::string> split(const std::string &s, char sep) {
    std::vector<std::string> out;
    size_t start = 0;
    while (start <= s.size()) {
        const size_t end = s.find(sep, start);
        const std::string part = s.substr(start, end == std::string::npos ? std::string::npos : end - start);
        if (!part.empty()) out.push_back(part);
        if (end == std::string::npos) break;
        start = end + 1;
    }
    return out;
}

/// A whole decimal number without sign; false for anything else.
inline bool parse_uint(const char *s, uint64_t &out) {
    char *end = nullptr;
    const unsigned long long v = std::strtoull(s, &end, 10);
    if (!s[0] || *end || s[0] == '-') return false;
    out = v;
    return true;
}

/// The CPU's model name from /proc/cpuinfo, or "unknown CPU".
inline std::string cpu_name() {
    std::ifstream f("/proc/cpuinfo");
    std::string line;
    while (std::getline(f, line)) {
        if (line.rfind("model name", 0) == 0) {
            const size_t c = line.find(':');
            if (c != std::string::npos) return line.substr(c + 2);
        }
    }
    return "unknown CPU";
}

} // namespace bench
