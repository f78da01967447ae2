#pragma once
// FNV-1a, 64 bit: a stable fingerprint of a string (std::hash is not stable across builds), for
// file names of cached results and for checkpoints' settings. Pure; thread-safe.

#include <cstdint>
#include <string>

namespace fogmap {

inline uint64_t fnv1a(const std::string& s) {
    uint64_t h = 0xcbf29ce484222325ull;
    for (unsigned char c : s) {
        h ^= c;
        h *= 0x100000001b3ull;
    }
    return h;
}

}  // namespace fogmap
