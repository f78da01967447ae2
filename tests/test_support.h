#pragma once
// What several test programs need: a temp folder per test, whole-file reads and writes, a density
// grid written and loaded back, the fogmap binary run through the shell with its output captured,
// the InputError a call must throw, the rule for tests that need ../shared/volumes (skip, but fail
// when CI=true), and the statistics stochastic tests derive their tolerances from (sample means
// with their standard errors, the chi-square statistic and its critical values).

#include "core/error.h"
#include "core/math.h"
#include "media/density_grid.h"
#include "media/volume_gen.h"

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

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

/// A fresh folder for the running test (named after the prefix, the process and the test; the
/// '/' of a parameterised test's name as '_', so the folder is one level), removed at the end.
class TempDir {
public:
    explicit TempDir(const std::string& prefix) {
        const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
        std::string test = info->name();
        std::replace(test.begin(), test.end(), '/', '_');
        path_ =
            fs::temp_directory_path() / (prefix + "_" + std::to_string(::getpid()) + "_" + test);
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

/// The grid "density" of value(i, j, k) on nx × ny × nz voxels (voxel size and translation as
/// write_float_grid takes them), written to a VDB file in a folder of its own and loaded.
inline std::shared_ptr<const DensityGrid> density_grid(
    int nx, int ny, int nz, const std::function<float(int, int, int)>& value,
    Vec3 voxel_size = Vec3(1.0f), Vec3 translation = Vec3(0.0f)) {
    const TempDir dir("fogmap_grid");
    const std::string path = (dir.path() / "density.vdb").string();
    write_float_grid(path, "density", nx, ny, nz, value, voxel_size, translation);
    return DensityGrid::load(path, "density", "");
}

struct RunResult {
    int code = -1;          ///< exit code; -1 when killed by a signal
    bool signaled = false;  ///< killed by a signal (directly or as the shell reports it, > 128)
    std::string out, err;
};

/// The line of a text report that starts with `key`, up to its rate in parentheses ("" if none).
inline std::string report_line(const std::string& out, const std::string& key) {
    const size_t at = out.find("\n" + key);
    if (at == std::string::npos) return "";
    const std::string line = out.substr(at + 1, out.find('\n', at + 1) - at - 1);
    return line.substr(0, line.find(" ("));
}

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

/// Sums of samples and of their squares (T = double, or DVec3 for per-channel figures): the mean
/// and its standard error sqrt(s² / n), s² the samples' variance about their mean with 1/n
/// (standard_error) or 1/(n − 1) (standard_error_unbiased), clamped at 0 against rounding.
template <class T = double>
struct SampleStats {
    T sum{0.0}, sum2{0.0};
    double n = 0.0;

    void add(const T& v) {
        sum += v;
        sum2 += v * v;
        n += 1.0;
    }
    T mean() const { return sum / n; }
    T standard_error() const { return glm::sqrt(spread() / n); }
    T standard_error_unbiased() const { return glm::sqrt(spread() / (n - 1.0)); }

private:
    T spread() const {  // E[x²] − E[x]², at least 0
        const T m = mean();
        return glm::max(sum2 / n - m * m, T(0.0));
    }
};

/// A sample mean and its standard error.
struct MeanEstimate {
    double mean = 0.0, standard_error = 0.0;
};

/// Mean and standard error (1/n variance) of f(0), ..., f(n − 1).
template <class F>
MeanEstimate estimate_mean(int n, F&& f) {
    SampleStats<> s;
    for (int i = 0; i < n; ++i) s.add(f(i));
    return {s.mean(), s.standard_error()};
}

/// FNV-1a, 64 bit, written out here apart from core/hash.h: the checksum a checkpoint ends in.
inline uint64_t fnv1a_64(const std::string& s) {
    uint64_t h = 14695981039346656037ull;
    for (unsigned char c : s) h = (h ^ c) * 1099511628211ull;
    return h;
}

/// Upper quantile of chi-square with k degrees of freedom by the Wilson–Hilferty cube
/// approximation: k (1 − 2/(9k) + z sqrt(2/(9k)))³, z the standard normal quantile (3.090232
/// for p = 0.001); good to ~0.1% at k ≈ 100.
inline double chi_square_quantile(double k, double z) {
    const double a = 2.0 / (9.0 * k);
    const double t = 1.0 - a + z * std::sqrt(a);
    return k * t * t * t;
}

/// Pearson's statistic Σ (counts[b] − expected[b])² / expected[b].
inline double chi_square(const std::vector<int>& counts, const std::vector<double>& expected) {
    double chi2 = 0.0;
    for (size_t b = 0; b < counts.size(); ++b)
        chi2 += (counts[b] - expected[b]) * (counts[b] - expected[b]) / expected[b];
    return chi2;
}

/// The same against one expected count for every bin.
inline double chi_square(const std::vector<int>& counts, double expected) {
    return chi_square(counts, std::vector<double>(counts.size(), expected));
}

}  // namespace fogmap::test
