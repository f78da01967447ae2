#pragma once
// How much memory a run may plan to use, so that estimates made before the work starts (image and
// photon memory, a VDB grid's sampler) can refuse a run that cannot fit, naming the estimate,
// instead of failing or swapping halfway. The budget is the memory available now (MemAvailable in
// /proc/meminfo, else the physical memory from sysconf), within the limit of the process's memory
// cgroup and its ancestors (a container's or a Slurm job's: the limit less what the group uses
// beyond its file cache, which the kernel reclaims first; cgroup v1 or v2), and within the
// address-space limit (RLIMIT_AS, `ulimit -v`) less what the process already maps. Reads the
// system on every call; thread-safe.

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>

namespace fogmap {

namespace detail {

/// A number from the first line of `file` ("max" or no file: none).
inline bool read_bytes(const std::string& file, uint64_t* out) {
    std::ifstream in(file);
    std::string text;
    if (!(in >> text) || text.empty() || text[0] < '0' || text[0] > '9') return false;
    *out = std::strtoull(text.c_str(), nullptr, 10);
    return true;
}

/// The value of `key` in a memory.stat file (0 when absent).
inline uint64_t stat_value(const std::string& file, const std::string& key) {
    std::ifstream in(file);
    std::string k;
    uint64_t v = 0;
    while (in >> k >> v)
        if (k == key) return v;
    return 0;
}

/// What the memory cgroups of this process (v2 "0::PATH", v1 "N:memory:PATH" in `proc_cgroup`)
/// and their ancestors leave, their files under `sys_root` (v1: its memory/): the least of
/// limit − (usage − file cache). UINT64_MAX when none limits it.
inline uint64_t cgroup_memory_left(const std::string& proc_cgroup = "/proc/self/cgroup",
                                   const std::string& sys_root = "/sys/fs/cgroup") {
    uint64_t left = UINT64_MAX;
    std::ifstream cgroup(proc_cgroup);
    for (std::string line; std::getline(cgroup, line);) {
        const bool v2 = line.rfind("0::", 0) == 0;
        const size_t at = line.find(":memory:");
        if (!v2 && at == std::string::npos) continue;
        std::string dir = v2 ? line.substr(3) : line.substr(at + 8);
        const std::string root = v2 ? sys_root : sys_root + "/memory";
        for (;;) {
            const std::string base = root + (dir == "/" ? "" : dir);
            uint64_t limit = 0, usage = 0;
            if (v2 ? read_bytes(base + "/memory.max", &limit) &&
                         read_bytes(base + "/memory.current", &usage)
                   : read_bytes(base + "/memory.limit_in_bytes", &limit) &&
                         read_bytes(base + "/memory.usage_in_bytes", &usage)) {
                const uint64_t cache =
                    v2 ? stat_value(base + "/memory.stat", "file")
                       : stat_value(base + "/memory.stat", "total_inactive_file") +
                             stat_value(base + "/memory.stat", "total_active_file");
                const uint64_t used = usage > cache ? usage - cache : 0;
                left = std::min(left, limit > used ? limit - used : 0);
            }
            if (dir.size() <= 1) break;
            dir = dir.substr(0, std::max<size_t>(1, dir.find_last_of('/')));
        }
    }
    return left;
}

}  // namespace detail

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
    available = std::min(available, detail::cgroup_memory_left());
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
