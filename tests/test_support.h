#pragma once
// What several test programs need: a temp folder per test, whole-file reads and writes, the
// fogmap binary run through the shell with its output captured, the InputError a call must
// throw, and the rule for tests that need ../shared/volumes (skip, but fail when CI=true).

#include "core/error.h"

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>

namespace fogmap::test {

namespace fs = std::filesystem;

inline std::string slurp(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

inline void spit(const fs::path& p, const std::string& bytes) {
    std::ofstream(p, std::ios::binary) << bytes;
}

/// A fresh folder for the running test (named after the prefix, the process and the test),
/// removed at the end.
class TempDir {
public:
    explicit TempDir(const std::string& prefix) {
        const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
        path_ = fs::temp_directory_path() /
                (prefix + "_" + std::to_string(::getpid()) + "_" + info->name());
        fs::remove_all(path_);
        fs::create_directories(path_);
    }
    ~TempDir() { fs::remove_all(path_); }
    TempDir(const TempDir&) = delete;
    TempDir& operator=(const TempDir&) = delete;

    const fs::path& path() const { return path_; }
    /// Writes `bytes` to the file `name` in the folder; returns its path.
    std::string write(const std::string& name, const std::string& bytes) const {
        const fs::path p = path_ / name;
        spit(p, bytes);
        return p.string();
    }

private:
    fs::path path_;
};

struct RunResult {
    int code = -1;          ///< exit code; -1 when killed by a signal
    bool signaled = false;  ///< killed by a signal (directly or as the shell reports it, > 128)
    std::string out, err;
};

/// Runs `shell_prefix <fogmap> args` through the shell (e.g. prefix "ulimit -v N; " or
/// "cd DIR && "), stdout and stderr captured in files inside `dir`.
inline RunResult run_fogmap(const std::string& args, const fs::path& dir,
                            const std::string& shell_prefix = "") {
    const fs::path out = dir / "stdout.txt", err = dir / "stderr.txt";
    const std::string cmd = shell_prefix + std::string(FOGMAP_BINARY) + " " + args + " >" +
                            out.string() + " 2>" + err.string();
    const int status = std::system(cmd.c_str());
    RunResult r;
    r.signaled = WIFSIGNALED(status) || (WIFEXITED(status) && WEXITSTATUS(status) > 128);
    r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    r.out = slurp(out);
    r.err = slurp(err);
    return r;
}

/// Frames 1..n of a small generated plume, `dir`/vol/p.####.vdb, and `dir`/s.json, a path-traced
/// scene rendering them (16x12, 2 spp). Fails the test if fogmap cannot write them.
inline void write_plume_sequence(const fs::path& dir, int n) {
    const RunResult r = run_fogmap("volume plume --frames 1-" + std::to_string(n) + " -o " +
                                       (dir / "vol/p.####.vdb").string() +
                                       " --resolution 16 --voxel-size 0.1",
                                   dir);
    ASSERT_EQ(r.code, 0) << r.err;
    spit(dir / "s.json", R"({
  "camera": {"position": [0, 0.8, 3], "look_at": [0, 0.8, 0], "width": 16, "height": 12},
  "lights": [{"type": "sun", "direction": [0.3, -1, 0.2], "irradiance": 3}],
  "media": [{"type": "vdb", "file": "vol/p.####.vdb", "sigma_s": 20, "sigma_a": 1}],
  "render": {"integrator": "path", "spp": 2}
})");
}

/// For a test whose shared volume (../shared/volumes) is missing: records a skip, or, when the
/// environment variable CI is "true", a failure (a CI machine must have the volumes, and a
/// silent skip there would hide the test). The caller returns right after:
/// `if (!fs::exists(path)) return test::missing_shared_volume(path);`
inline void missing_shared_volume(const std::string& what) {
    const char* ci = std::getenv("CI");
    if (ci != nullptr && std::string(ci) == "true")
        ADD_FAILURE() << what << " not found: CI=true requires ../shared/volumes";
    else
        GTEST_SKIP() << what << " not found (shared volumes absent)";
}

/// Runs f, expects an InputError, returns it (a failed expectation otherwise).
inline InputError catch_input_error(const std::function<void()>& f) {
    try {
        f();
    } catch (const InputError& e) {
        return e;
    }
    ADD_FAILURE() << "expected an InputError";
    return InputError("", "", "");
}

}  // namespace fogmap::test
