// The memory budget's cgroup part on made-up cgroup trees (v1 and v2 layouts): what the process's
// group and its ancestors leave, limit − (usage − file cache), computed by hand.

#include "core/memory_budget.h"

#include "test_support.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

namespace fogmap {
namespace {

namespace fs = std::filesystem;

void put(const fs::path& file, const std::string& text) {
    fs::create_directories(file.parent_path());
    std::ofstream(file) << text << "\n";
}

constexpr uint64_t kMB = uint64_t(1) << 20;

TEST(MemoryBudget, ACgroupV2LeavesItsLimitLessWhatItUsesBeyondItsFileCache) {
    const test::TempDir dir("budget_v2");
    const fs::path root = dir.path() / "sys", proc = dir.path() / "cgroup";
    put(proc, "0::/job/step");
    // The job: 1000 MB, 700 used of which 300 file cache (600 MB left); its step: no limit.
    put(root / "job/memory.max", std::to_string(1000 * kMB));
    put(root / "job/memory.current", std::to_string(700 * kMB));
    put(root / "job/memory.stat",
        "anon " + std::to_string(400 * kMB) + "\nfile " + std::to_string(300 * kMB));
    put(root / "job/step/memory.max", "max");
    put(root / "job/step/memory.current", std::to_string(650 * kMB));
    EXPECT_EQ(detail::cgroup_memory_left(proc.string(), root.string()), 600 * kMB);
    // A tighter step: 500 MB with 450 used, 50 of it cache -> 100 MB left.
    put(root / "job/step/memory.max", std::to_string(500 * kMB));
    put(root / "job/step/memory.current", std::to_string(450 * kMB));
    put(root / "job/step/memory.stat", "file " + std::to_string(50 * kMB));
    EXPECT_EQ(detail::cgroup_memory_left(proc.string(), root.string()), 100 * kMB);
    // Over its limit (the kernel about to reclaim): nothing left.
    put(root / "job/step/memory.current", std::to_string(600 * kMB));
    EXPECT_EQ(detail::cgroup_memory_left(proc.string(), root.string()), 0u);
}

TEST(MemoryBudget, ACgroupV1MemoryControllerIsReadWithItsFileCache) {
    const test::TempDir dir("budget_v1");
    const fs::path root = dir.path() / "sys", proc = dir.path() / "cgroup";
    put(proc, "5:cpu:/a\n4:memory:/slurm/uid_0/job_7\n0::/");
    const fs::path job = root / "memory/slurm/uid_0/job_7";
    put(job / "memory.limit_in_bytes", std::to_string(2048 * kMB));
    put(job / "memory.usage_in_bytes", std::to_string(1024 * kMB));
    put(job / "memory.stat", "cache 1\ntotal_inactive_file " + std::to_string(100 * kMB) +
                                 "\ntotal_active_file " + std::to_string(156 * kMB));
    // The unlimited root of v1 (its limit the largest page-aligned int64) does not bind.
    put(root / "memory/memory.limit_in_bytes", "9223372036854771712");
    put(root / "memory/memory.usage_in_bytes", std::to_string(9000 * kMB));
    EXPECT_EQ(detail::cgroup_memory_left(proc.string(), root.string()), (2048 - 768) * kMB);
}

TEST(MemoryBudget, NoMemoryCgroupLimitsNothing) {
    const test::TempDir dir("budget_none");
    const fs::path proc = dir.path() / "cgroup";
    put(proc, "0::/");
    EXPECT_EQ(detail::cgroup_memory_left(proc.string(), (dir.path() / "sys").string()), UINT64_MAX);
    EXPECT_EQ(detail::cgroup_memory_left((dir.path() / "none").string(), "/nowhere"), UINT64_MAX);
}

}  // namespace
}  // namespace fogmap
