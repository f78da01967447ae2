#include "media/vdb_probe.h"

#include "core/error.h"

#include <openvdb/openvdb.h>

#include <fcntl.h>
#include <poll.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <mutex>
#include <new>
#include <set>
#include <stdexcept>

extern char** environ;

namespace fogmap {

namespace {

// Child address-space limit: 2 GiB for the process itself (libraries, thread stacks, malloc
// arenas) plus 64 bytes per file byte for the grids. A float leaf (2 KB in memory) costs at least
// ~130 bytes in the file (value masks, chunk header), so real files stay below ~20x; a small
// crafted file asking for 4 GB gets std::bad_alloc instead.
constexpr uint64_t kBaseBytes = uint64_t(2) << 30;
constexpr uint64_t kBytesPerFileByte = 64;
// Time limit: 60 s plus 1 s per 10 MB (the shared volumes read at ~30 MB/s including start-up).
constexpr double kBaseTimeout_s = 60.0;
constexpr double kFileBytesPerSecond = 10e6;
constexpr size_t kMaxMessageBytes = 300;

struct ProbeState {
    std::mutex mutex;
    std::string self_exe;          ///< "" = probe off
    std::set<std::string> passed;  ///< paths whose probe exited 0
};

ProbeState& probe_state() {
    static ProbeState state;
    return state;
}

uint64_t file_bytes(const std::string& path) {
    std::error_code ec;
    const uintmax_t bytes = std::filesystem::file_size(path, ec);
    return ec ? 0 : bytes;
}

struct ChildResult {
    int status = 0;
    bool timed_out = false;
    std::string out;  ///< the child's stdout, first bytes only
};

/// Appends what `fd` has to `out` (bounded); false at end of file.
bool read_some(int fd, std::string& out) {
    char buf[4096];
    const ssize_t n = read(fd, buf, sizeof buf);
    if (n > 0 && out.size() < 64 * 1024) out.append(buf, static_cast<size_t>(n));
    return n > 0 || (n < 0 && errno == EINTR);
}

/// Runs `exe __probe-vdb -- path` (no shell), stdout piped back, stdin and stderr /dev/null;
/// SIGKILL after `timeout_s`.
ChildResult run_child(const std::string& exe, const std::string& path, double timeout_s) {
    int fds[2];
    if (pipe2(fds, O_CLOEXEC) != 0)
        throw std::runtime_error(std::string("VDB probe: pipe: ") + std::strerror(errno));
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
    posix_spawn_file_actions_adddup2(&actions, fds[1], STDOUT_FILENO);
    posix_spawn_file_actions_addopen(&actions, STDERR_FILENO, "/dev/null", O_WRONLY, 0);
    std::string args[] = {"fogmap", "__probe-vdb", "--", path};
    char* argv[] = {args[0].data(), args[1].data(), args[2].data(), args[3].data(), nullptr};
    pid_t pid = 0;
    const int err = posix_spawn(&pid, exe.c_str(), &actions, nullptr, argv, environ);
    posix_spawn_file_actions_destroy(&actions);
    close(fds[1]);
    if (err != 0) {
        close(fds[0]);
        throw std::runtime_error("VDB probe: cannot run '" + exe + "': " + std::strerror(err));
    }

    ChildResult r;
    const auto deadline =
        std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    bool open = true;
    for (;;) {
        const pid_t done = waitpid(pid, &r.status, WNOHANG);
        if (done == pid) break;
        if (done < 0 && errno != EINTR) {
            close(fds[0]);
            throw std::runtime_error(std::string("VDB probe: waitpid: ") + std::strerror(errno));
        }
        if (std::chrono::steady_clock::now() >= deadline) {
            kill(pid, SIGKILL);
            waitpid(pid, &r.status, 0);
            r.timed_out = true;
            break;
        }
        // Wakes on output or end of file; after that, short sleeps until the child is reaped.
        pollfd p{fds[0], POLLIN, 0};
        if (poll(&p, open ? 1 : 0, open ? 100 : 1) > 0) open = read_some(fds[0], r.out);
    }
    while (open && !r.timed_out) open = read_some(fds[0], r.out);  // the child has exited
    close(fds[0]);
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

}  // namespace

void enable_vdb_probe(std::string self_exe) {
    ProbeState& state = probe_state();
    const std::lock_guard<std::mutex> lock(state.mutex);
    state.self_exe = std::move(self_exe);
}

void probe_vdb(const std::string& path, const std::string& field) {
    ProbeState& state = probe_state();
    const std::lock_guard<std::mutex> lock(state.mutex);
    if (state.self_exe.empty() || state.passed.count(path)) return;
    const double timeout_s = kBaseTimeout_s + file_bytes(path) / kFileBytesPerSecond;
    const ChildResult r = run_child(state.self_exe, path, timeout_s);
    if (r.timed_out)
        throw InputError(path, field,
                         "corrupt VDB file: OpenVDB's reader did not finish it within " +
                             std::to_string(static_cast<int>(timeout_s)) + " s");
    if (WIFSIGNALED(r.status))
        throw InputError(path, field,
                         "corrupt VDB file: OpenVDB's reader crashed on it (signal " +
                             std::to_string(WTERMSIG(r.status)) + ")");
    const int code = WIFEXITED(r.status) ? WEXITSTATUS(r.status) : -1;
    if (code == 2) throw InputError(path, field, "cannot read VDB file: " + message(r.out));
    if (code != 0)
        throw InputError(path, field,
                         "corrupt VDB file: OpenVDB's reader failed on it (exit code " +
                             std::to_string(code) + ")");
    state.passed.insert(path);
}

int run_vdb_probe_child(const std::string& path) {
    const uint64_t bytes = file_bytes(path);
    const rlimit no_core{0, 0};
    setrlimit(RLIMIT_CORE, &no_core);  // a crash must not leave a core file behind
    const rlim_t as_bytes = kBaseBytes + kBytesPerFileByte * bytes;
#ifndef __SANITIZE_ADDRESS__  // AddressSanitizer reserves terabytes of address space up front
    const rlimit as{as_bytes, as_bytes};
    setrlimit(RLIMIT_AS, &as);
#endif
    try {
        openvdb::initialize();
        openvdb::io::File file(path);
        file.open(/*delayLoad=*/false);
        for (auto it = file.beginName(); it != file.endName(); ++it) file.readGrid(*it);
        file.close();
        return 0;
    } catch (const std::bad_alloc&) {
        std::printf("reading it needs more than the %llu MB memory limit for a %llu-byte file\n",
                    static_cast<unsigned long long>(as_bytes >> 20),
                    static_cast<unsigned long long>(bytes));
    } catch (const std::exception& e) {
        std::printf("%s\n", e.what());
    }
    return 2;
}

}  // namespace fogmap
