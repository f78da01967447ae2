#pragma once
// How much memory a run may plan to use, so that estimates made before the work starts (image and
// photon memory, a VDB grid's sampler) can refuse a run that cannot fit, naming the estimate,
// instead of failing or swapping halfway. The budget is the memory available now (MemAvailable in
// /proc/meminfo, else the physical memory from sysconf), within the address-space limit
// (RLIMIT_AS, `ulimit -v`) less what the process already maps. Reads the system on every call;
// thread-safe.

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <string>

namespace fogmap {

/// Bytes the process may still allocate (see the header comment); at least 1.
inline uint64_t memory_budget_bytes() {
    uint64_t available = 0;
    std::ifstream meminfo("/proc/meminfo");
    std::string key;
    uint64_t kb = 0;
    std::string unit;
    while (meminfo >> key >> kb >> unit)
        if (key == "MemAvailable:") {
            available = kb << 10;
            break;
        }
    if (available == 0) {
        const long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
        if (pages > 0 && page > 0)
            available = static_cast<uint64_t>(pages) * static_cast<uint64_t>(page);
    }
    rlimit as{};
    if (getrlimit(RLIMIT_AS, &as) == 0 && as.rlim_cur != RLIM_INFINITY) {
        uint64_t mapped = 0;  // first field of /proc/self/statm: the process's size in pages
        std::ifstream("/proc/self/statm") >> mapped;
        mapped *= static_cast<uint64_t>(std::max(1L, sysconf(_SC_PAGESIZE)));
        const uint64_t limit = static_cast<uint64_t>(as.rlim_cur);
        const uint64_t left = limit > mapped ? limit - mapped : 0;
        available = available == 0 ? left : std::min(available, left);
    }
    return std::max<uint64_t>(available, 1);
}

/// "1234 MB" (rounded up) for messages.
inline std::string mb_text(uint64_t bytes) {
    return std::to_string((bytes + (uint64_t(1) << 20) - 1) >> 20) + " MB";
}

}  // namespace fogmap
