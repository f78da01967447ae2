#include "media/vdb_probe.h"

#include "core/error.h"
#include "core/fd_stream.h"
#include "core/input_file.h"
#include "core/memory_budget.h"

#include <openvdb/openvdb.h>

#include <fcntl.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <mutex>
#include <new>
#include <stdexcept>

extern char** environ;

namespace fogmap {

namespace {

// Child address-space limit: 2 GiB for the process itself (libraries, thread stacks, malloc
// arenas) plus 64 bytes per file byte for the grids, and ChildNeeds (what it builds of them). A
// float leaf (2 KB in memory) costs at least ~130 bytes in the file (value masks, chunk header),
// so real files stay below ~20x; a small crafted file asking for 4 GB gets std::bad_alloc instead.
constexpr uint64_t kBaseBytes = uint64_t(2) << 30;
constexpr uint64_t kBytesPerFileByte = 64;
// CPU-time limit, never wall time (a valid file must pass however busy the machine): 10 s plus
// 1 s per 10 MB. The shared volumes read at ~30 MB/s of one core including start-up, so a valid
// file needs a third of its limit at most; a corrupt one that makes OpenVDB loop is refused in
// ~10 CPU-seconds, not a minute.
constexpr double kBaseCpu_s = 10.0;
constexpr double kFileBytesPerCpuSecond = 10e6;
constexpr size_t kMaxMessageBytes = 300;

struct ProbeState {
    std::mutex mutex;
    std::string self_exe;  ///< "" = probe off
};

ProbeState& probe_state() {
    static ProbeState state;
    return state;
}

uint64_t file_bytes(const std::string& path);

/// The child's CPU seconds for reading a file of `bytes` (the parent adds what the child builds
/// and passes the sum). FOGMAP_PROBE_CPU_SECONDS replaces the 10-s base (tests of the limit).
rlim_t cpu_limit_s(uint64_t bytes) {
    double base = kBaseCpu_s;
    if (const char* env = std::getenv("FOGMAP_PROBE_CPU_SECONDS")) {
        const double v = std::atof(env);
        if (v >= 1.0 && v <= kBaseCpu_s) base = v;
    }
    return static_cast<rlim_t>(std::ceil(base + double(bytes) / kFileBytesPerCpuSecond));
}

uint64_t file_bytes(const std::string& path) {
    std::error_code ec;
    const uintmax_t bytes = std::filesystem::file_size(path, ec);
    return ec ? 0 : bytes;
}

struct ChildResult {
    int status = 0;
    double cpu_s = 0.0;  ///< the child's CPU time, user and system
    std::string out;     ///< the child's output after its result, or all of it: first bytes only
};

/// Appends what `fd` has to `out` (bounded); false at end of file.
bool read_some(int fd, std::string& out) {
    char buf[4096];
    const ssize_t n = read(fd, buf, sizeof buf);
    if (n > 0 && out.size() < 64 * 1024) out.append(buf, static_cast<size_t>(n));
    return n > 0 || (n < 0 && errno == EINTR);
}

/// This process's environment for the child, but that glibc's malloc does not advise huge pages
/// (main.cpp's GLIBC_TUNABLES glibc.malloc.hugetlb=1): the child only loads, and faulting its
/// fresh memory in huge pages (compacted on demand) made a 1024^3 plume's load 1.5 s slower.
std::vector<std::string> child_environment() {
    std::vector<std::string> env;
    for (char** e = environ; *e; ++e) {
        std::string v = *e;
        const size_t at = v.find("glibc.malloc.hugetlb=1");
        if (v.rfind("GLIBC_TUNABLES=", 0) == 0 && at != std::string::npos) v[at + 21] = '0';
        env.push_back(std::move(v));
    }
    return env;
}

/// The first bytes of a child's output when a result follows (a message never starts so).
constexpr char kResultMark[8] = {'\x01', 'f', 'o', 'g', 'v', 'd', 'b', '\n'};

/// Runs `exe __probe-vdb ARGS... -- path` (no shell), stdout piped back, stdin and stderr
/// /dev/null; `receive` reads the result when the output starts with kResultMark, the rest is
/// kept as the message; then waits for the child (its CPU-time limit is its own:
/// run_reader_child). fork + exec rather than posix_spawn, to set PR_SET_PDEATHSIG in the child:
/// it then gets SIGKILL when its parent dies (and exits at once if the parent died before the
/// call). Between fork and exec the child makes only async-signal-safe calls.
ChildResult run_child(const std::string& exe, const std::string& path,
                      const std::vector<std::string>& child_args, bool* received,
                      const std::function<void(FdReader&)>& receive) {
    int fds[2];
    if (pipe2(fds, O_CLOEXEC) != 0)
        throw std::runtime_error(std::string("VDB probe: pipe: ") + std::strerror(errno));
    std::vector<std::string> args = {"fogmap", "__probe-vdb"};
    args.insert(args.end(), child_args.begin(), child_args.end());
    args.insert(args.end(), {"--", path});
    std::vector<char*> argv, envp;
    for (std::string& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    std::vector<std::string> env = child_environment();
    for (std::string& e : env) envp.push_back(e.data());
    envp.push_back(nullptr);
    const pid_t parent = getpid();
    const pid_t pid = fork();
    if (pid == 0) {
        if (prctl(PR_SET_PDEATHSIG, SIGKILL) != 0 || getppid() != parent) _exit(127);
        const int null_in = open("/dev/null", O_RDONLY | O_CLOEXEC);
        const int null_err = open("/dev/null", O_WRONLY | O_CLOEXEC);
        if (null_in < 0 || null_err < 0 || dup2(null_in, STDIN_FILENO) < 0 ||
            dup2(fds[1], STDOUT_FILENO) < 0 || dup2(null_err, STDERR_FILENO) < 0)
            _exit(127);
        execve(exe.c_str(), argv.data(), envp.data());
        _exit(127);
    }
    const int fork_errno = errno;
    close(fds[1]);
    if (pid < 0) {
        close(fds[0]);
        throw std::runtime_error("VDB probe: cannot run '" + exe +
                                 "': " + std::strerror(fork_errno));
    }
    // Blocking reads: the child either writes, ends (end of file) or is ended by its CPU limit.
    ChildResult r;
    FdReader in(fds[0]);
    *received = false;
    try {
        char mark[sizeof kResultMark] = {};
        in.bytes(mark, 1);
        r.out.assign(mark, 1);
        if (mark[0] == kResultMark[0]) {
            in.bytes(mark + 1, sizeof mark - 1);
            r.out.clear();
            if (std::memcmp(mark, kResultMark, sizeof mark) == 0) {
                receive(in);
                *received = true;
            }
        }
    } catch (const StreamEnd&) {  // the exit status says why
    } catch (...) {               // the parent failed (out of memory): no child reads on
        kill(pid, SIGKILL);
        close(fds[0]);
        while (waitpid(pid, nullptr, 0) < 0 && errno == EINTR) {
        }
        throw;
    }
    while (read_some(fds[0], r.out)) {
    }
    close(fds[0]);
    rusage usage{};
    while (wait4(pid, &r.status, 0, &usage) < 0)
        if (errno != EINTR)
            throw std::runtime_error(std::string("VDB probe: waitpid: ") + std::strerror(errno));
    r.cpu_s = double(usage.ru_utime.tv_sec) + double(usage.ru_stime.tv_sec) +
              1e-6 * double(usage.ru_utime.tv_usec + usage.ru_stime.tv_usec);
    return r;
}

/// The child's last line of output as one printable line of bounded length.
std::string message(std::string out) {
    while (!out.empty() && (out.back() == '\n' || out.back() == '\r')) out.pop_back();
    out = out.substr(out.find_last_of('\n') + 1);  // npos + 1 == 0: the whole string
    if (out.empty()) return "(no message)";
    std::string s;
    for (const char c : out.substr(0, kMaxMessageBytes))
        s += (static_cast<unsigned char>(c) >= 0x20 && c != 0x7f) ? c : '?';
    return out.size() > kMaxMessageBytes ? s + "..." : s;
}

/// A VDB header (magic, versions, offsets flag, UUID, metadata and grid counts) takes 65 bytes
/// from file format 222 on, and each grid's descriptor names the byte where its data ends (the
/// next descriptor starts there). OpenVDB does not check its stream while reading: a file cut
/// inside the header opens as "0 grids" or reads a garbage string length and allocates gigabytes
/// (found by tests/fuzz), and a grid cut anywhere reads as an empty grid. So the header and the
/// descriptors are walked here, bounded by the file's size, before OpenVDB opens the file.
void check_vdb_layout(const std::string& path, const std::string& field, uint64_t size) {
    constexpr uint64_t kHeaderBytes = 65;
    if (size < kHeaderBytes) {
        throw InputError(path, field,
                         "cannot read VDB file: it ends after " + std::to_string(size) +
                             " bytes, inside the VDB header (" + std::to_string(kHeaderBytes) +
                             " bytes); the file is truncated or not a VDB file");
    }
    std::ifstream in(path, std::ios::binary);
    uint64_t pos = 0;
    const auto cut = [&](const std::string& where) {
        return InputError(path, field,
                          "truncated VDB file: it ends after " + std::to_string(size) +
                              " bytes, inside " + where);
    };
    const auto read = [&](void* out, uint64_t n, const std::string& where) {
        if (n > size - pos) throw cut(where);
        in.seekg(static_cast<std::streamoff>(pos));
        in.read(static_cast<char*>(out), static_cast<std::streamsize>(n));
        if (!in) throw cut(where);
        pos += n;
    };
    const auto u32 = [&](const std::string& where) {
        uint32_t v = 0;
        read(&v, 4, where);
        return v;
    };
    const auto text = [&](const std::string& where) {
        const uint32_t n = u32(where);
        if (n > size - pos)  // OpenVDB would allocate n bytes and read on past the end
            throw InputError(path, field,
                             "truncated or corrupt VDB file: a string in " + where + " claims " +
                                 std::to_string(n) + " bytes (" + mb_text(n) +
                                 " of memory to read), more than the " +
                                 std::to_string(size - pos) + " bytes left in the file");
        std::string out(n, '\0');
        read(out.data(), n, where);
        return out;
    };
    const auto skip = [&](uint64_t n, const std::string& where) {
        if (n > size - pos) throw cut(where);
        pos += n;
    };
    uint64_t magic = 0;
    read(&magic, 8, "the VDB header");
    const uint32_t version = u32("the VDB header");
    if (magic != openvdb::OPENVDB_MAGIC || version < 222) return;  // OpenVDB's own checks
    pos = 20;
    char has_offsets = 0;
    read(&has_offsets, 1, "the VDB header");
    if (!has_offsets) return;  // a stream written without grid offsets
    pos = 57;
    const uint32_t meta_count = u32("the file's metadata");
    for (uint32_t i = 0; i < meta_count; ++i) {
        text("the file's metadata");
        text("the file's metadata");
        skip(u32("the file's metadata"), "the file's metadata");
    }
    const uint32_t grids = u32("the VDB header");
    for (uint32_t g = 0; g < grids; ++g) {
        const std::string which = "grid " + std::to_string(g + 1) + " of " + std::to_string(grids);
        const std::string where = "the descriptor of " + which;
        const std::string name = message(text(where));
        text(where);                                                                // grid type
        if (version >= openvdb::OPENVDB_FILE_VERSION_GRID_INSTANCING) text(where);  // parent
        int64_t grid_pos = 0, block_pos = 0, end_pos = 0;
        read(&grid_pos, 8, where);
        read(&block_pos, 8, where);
        read(&end_pos, 8, where);
        if (end_pos > static_cast<int64_t>(size))
            throw InputError(path, field,
                             "truncated VDB file: it ends after " + std::to_string(size) +
                                 " bytes, but grid '" + name + "' (" + which + ") ends at byte " +
                                 std::to_string(end_pos));
        if (grid_pos < static_cast<int64_t>(pos) || block_pos < grid_pos || end_pos < block_pos)
            throw InputError(path, field,
                             "corrupt VDB file: the data offsets of grid '" + name + "' (" + which +
                                 ") are out of order");
        pos = static_cast<uint64_t>(end_pos);
    }
}

}  // namespace

void check_vdb_file(const std::string& path, const std::string& field) {
    check_vdb_layout(path, field, check_input_file(path, field, "VDB file"));
}

void enable_vdb_probe(std::string self_exe) {
    ProbeState& state = probe_state();
    const std::lock_guard<std::mutex> lock(state.mutex);
    state.self_exe = std::move(self_exe);
}

bool vdb_probe_enabled() {
    ProbeState& state = probe_state();
    const std::lock_guard<std::mutex> lock(state.mutex);
    return !state.self_exe.empty();
}

void read_in_child(const std::string& path, const std::string& field,
                   const std::vector<std::string>& args, const ChildNeeds& needs,
                   const std::function<void(FdReader&)>& receive) {
    std::string exe;
    {
        ProbeState& state = probe_state();
        const std::lock_guard<std::mutex> lock(state.mutex);
        exe = state.self_exe;
    }
    if (exe.empty()) throw std::logic_error("read_in_child: the probe is off");
    const uint64_t bytes = file_bytes(path);
    const rlim_t cpu_s = cpu_limit_s(bytes) + rlim_t(std::ceil(needs.cpu_s));
    const uint64_t as_bytes = kBaseBytes + kBytesPerFileByte * bytes + needs.bytes;
    std::vector<std::string> all = args;
    all.insert(all.end(), {"--cpu-seconds", std::to_string(cpu_s), "--memory-bytes",
                           std::to_string(as_bytes)});
    bool received = false;
    const ChildResult r = run_child(exe, path, all, &received, receive);
    // SIGXCPU at the soft limit, SIGKILL at the hard one a second later.
    const bool out_of_time = WIFSIGNALED(r.status) &&
                             (WTERMSIG(r.status) == SIGXCPU || WTERMSIG(r.status) == SIGKILL) &&
                             r.cpu_s >= double(cpu_s) - 0.5;
    if (out_of_time)
        throw InputError(path, field,
                         "corrupt VDB file: OpenVDB's reader did not finish it within " +
                             std::to_string(cpu_s) + " CPU-seconds (the limit for a file of " +
                             std::to_string(bytes) + " bytes)");
    if (WIFSIGNALED(r.status))
        throw InputError(path, field,
                         "corrupt VDB file: OpenVDB's reader crashed on it (signal " +
                             std::to_string(WTERMSIG(r.status)) + ")");
    const int code = WIFEXITED(r.status) ? WEXITSTATUS(r.status) : -1;
    if (code == 127) throw std::runtime_error("VDB probe: cannot run '" + exe + "' for " + path);
    if (code == 2) throw InputError(path, field, message(r.out));
    if (code != 0 || !received)
        throw InputError(path, field,
                         "corrupt VDB file: OpenVDB's reader failed on it (exit code " +
                             std::to_string(code) + ")");
}

int run_reader_child(const std::string& path, double cpu_s, uint64_t as_bytes,
                     const std::function<void(FdWriter&)>& send) {
    const rlimit no_core{0, 0};
    setrlimit(RLIMIT_CORE, &no_core);  // a crash must not leave a core file behind
    const rlimit cpu{rlim_t(cpu_s), rlim_t(cpu_s) + 1};
    setrlimit(RLIMIT_CPU, &cpu);
#ifndef __SANITIZE_ADDRESS__  // AddressSanitizer reserves terabytes of address space up front
    const rlimit as{rlim_t(as_bytes), rlim_t(as_bytes)};
    setrlimit(RLIMIT_AS, &as);
#endif
    try {
        openvdb::initialize();
        FdWriter out(STDOUT_FILENO);
        // The result is built before the mark is written: an error before it is a message.
        send(out);
        return 0;
    } catch (const std::bad_alloc&) {
        std::printf(
            "corrupt VDB file: reading it needs more than the %llu MB memory limit for a "
            "%llu-byte file\n",
            static_cast<unsigned long long>(as_bytes >> 20),
            static_cast<unsigned long long>(file_bytes(path)));
    } catch (const InputError& e) {
        std::printf("%s\n", e.reason.c_str());
    } catch (const StreamEnd&) {
        return 3;  // the parent stopped reading
    } catch (const std::exception& e) {
        std::printf("%s\n", vdb_error_reason(e.what()).c_str());
    }
    std::fflush(stdout);
    return 2;
}

void send_result_mark(FdWriter& out) { out.bytes(kResultMark, sizeof kResultMark); }

std::string vdb_error_reason(const std::string& what) {
    const auto has = [&](const char* s) { return what.find(s) != std::string::npos; };
    // OpenVDB's messages start with its exception class ("IoError: ", "RuntimeError: ").
    std::string text = what;
    const size_t colon = text.find(": ");
    if (colon != std::string::npos && colon >= 5 && colon < 20 &&
        text.compare(colon - 5, 5, "Error") == 0)
        text = text.substr(colon + 2);
    if (has("not a VDB file"))
        return "not a VDB file (its first bytes are not OpenVDB's magic number)";
    if (has("decompress") || has("uncompressed chunk") || has("zlib") || has("Blosc"))
        return "corrupt VDB file: a compressed block of voxel data does not decompress to its "
               "stated size";
    if (has("Grid type") && has("not registered"))
        return "corrupt or unsupported VDB file: a grid's type is not one OpenVDB 10 knows";
    if (has("Map") && (has("not registered") || has("KeyError")))
        return "corrupt or unsupported VDB file: a grid's transform type is not one OpenVDB 10 "
               "knows";
    if (has("Metadata") || has("metadata"))
        return "corrupt VDB file: a metadata entry is malformed";
    if (has("singular") || has("ArithmeticError"))
        return "corrupt VDB file: a grid's transform is singular or not finite";
    if (has("max_size") || has("bad_alloc") || has("length_error") || has("too long"))
        return "corrupt VDB file: a size field claims more data than the file holds";
    return "corrupt VDB file (OpenVDB: " + message(text) + ")";
}

}  // namespace fogmap
