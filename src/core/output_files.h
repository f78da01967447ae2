#pragma once
// Output files are written whole and together (docs/contributing.md). OutputFiles stages each
// file of a run as "<path>.tmp-<pid>" beside its target and renames the temps over their targets
// only after every one was written completely (each write, the fsync and the close checked), so a
// failed run leaves no half file and destroys no older one. Staged temps sit in a process-wide
// table: the handlers of install_output_signal_handlers() unlink them on SIGINT, SIGTERM, SIGHUP
// and SIGQUIT, then re-raise the signal; SIGXFSZ (a file-size limit) is ignored so that the write
// fails with EFBIG and is reported. SIGKILL cannot be handled: remove_stale_temps() deletes the
// temps of processes that no longer run. The table is locked for registration and read lock-free by
// the handlers (async-signal-safe); one OutputFiles object is used by one thread.

#include "core/error.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <mutex>
#include <stdexcept>
#include <string>
#include <vector>

namespace fogmap {

/// A file of a run: the target path and the temp it is written to first.
struct StagedFile {
    std::string path;  ///< the target, named in messages
    std::string temp;  ///< "<path>.tmp-<pid>"
};

/// "<path>.tmp-<pid>": unique per process, beside the target so that rename() stays atomic.
inline std::string temp_path_for(const std::string& path) {
    return path + ".tmp-" + std::to_string(static_cast<long>(::getpid()));
}

namespace detail {

inline constexpr int kMaxTemps = 32;
inline constexpr size_t kMaxTempPath = 4096;

/// Static storage, zero-initialised before main: the handlers may read it at any time.
struct TempTable {
    std::mutex mutex;
    std::atomic<int> used[kMaxTemps];
    char paths[kMaxTemps][kMaxTempPath];
    std::atomic<long> owner;  ///< pid that installed the handlers (a forked child must not unlink)
};
inline TempTable temp_table;

/// Slot of `temp` in the table, or -1 when it does not fit (the file is still written and
/// cleaned up normally, only not by the signal handlers).
inline int register_temp(const std::string& temp) {
    if (temp.size() >= kMaxTempPath) return -1;
    const std::lock_guard<std::mutex> lock(temp_table.mutex);
    for (int i = 0; i < kMaxTemps; ++i) {
        if (temp_table.used[i].load(std::memory_order_relaxed)) continue;
        std::memcpy(temp_table.paths[i], temp.c_str(), temp.size() + 1);
        temp_table.used[i].store(1, std::memory_order_release);
        return i;
    }
    return -1;
}

inline void unregister_temp(int slot) {
    if (slot < 0) return;
    const std::lock_guard<std::mutex> lock(temp_table.mutex);
    temp_table.used[slot].store(0, std::memory_order_release);
}

/// Unlinks every registered temp (only in the process that installed the handler), then lets
/// the signal do what it would have done. Async-signal-safe: unlink, getpid, sigaction, raise.
inline void on_fatal_signal(int sig) {
    if (temp_table.owner.load() == static_cast<long>(::getpid()))
        for (int i = 0; i < kMaxTemps; ++i)
            if (temp_table.used[i].load(std::memory_order_acquire)) ::unlink(temp_table.paths[i]);
    struct sigaction dfl {};
    dfl.sa_handler = SIG_DFL;
    sigemptyset(&dfl.sa_mask);
    sigaction(sig, &dfl, nullptr);
    raise(sig);  // blocked while the handler runs: delivered, and fatal, when it returns
}

inline std::string errno_text(int err) { return std::strerror(err ? err : EIO); }

}  // namespace detail

/// Installs the handlers described above (once per process, from main, before any output is
/// staged). A signal the parent made the process ignore (nohup: SIGHUP) stays ignored.
inline void install_output_signal_handlers() {
    detail::temp_table.owner.store(static_cast<long>(::getpid()));
    for (const int sig : {SIGINT, SIGTERM, SIGHUP, SIGQUIT}) {
        struct sigaction old {};
        if (sigaction(sig, nullptr, &old) == 0 && old.sa_handler == SIG_IGN) continue;
        struct sigaction sa {};
        sa.sa_handler = detail::on_fatal_signal;
        sigemptyset(&sa.sa_mask);
        sigaction(sig, &sa, nullptr);
    }
    std::signal(SIGXFSZ, SIG_IGN);
}

/// A file being written through a file descriptor. Every write, the fsync and the close are
/// checked and the first error is kept, so a failure inside a library's destructor (which may
/// swallow exceptions) still fails close(). Not thread-safe.
class CheckedFile {
public:
    /// Creates or truncates `file`; `name` is the path named in messages. Throws
    /// std::runtime_error when it cannot be created.
    CheckedFile(const std::string& file, std::string name) : name_(std::move(name)) {
        fd_ = ::open(file.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
        if (fd_ < 0)
            throw std::runtime_error(name_ + ": cannot create file: " + detail::errno_text(errno));
    }
    ~CheckedFile() {
        if (fd_ >= 0) ::close(fd_);
    }
    CheckedFile(const CheckedFile&) = delete;
    CheckedFile& operator=(const CheckedFile&) = delete;

    /// Appends n bytes at the current position; false (and error() set) on failure.
    bool write(const void* data, size_t n) {
        const char* p = static_cast<const char*>(data);
        while (n > 0 && error_ == 0) {
            const ssize_t done = ::write(fd_, p, n);
            if (done < 0 && errno == EINTR) continue;
            if (done <= 0) {
                error_ = done < 0 ? errno : EIO;
                break;
            }
            p += done;
            n -= static_cast<size_t>(done);
        }
        return error_ == 0;
    }
    /// Moves the write position; false (and error() set) on failure.
    bool seek(uint64_t pos) {
        if (error_ == 0 && ::lseek(fd_, static_cast<off_t>(pos), SEEK_SET) < 0) error_ = errno;
        return error_ == 0;
    }
    /// errno of the first failure, 0 if none.
    int error() const { return error_; }
    const std::string& name() const { return name_; }

    /// Flushes to the disk and closes. Throws std::runtime_error "<name>: cannot write <what>:
    /// <reason>" if this or any earlier write failed.
    void close(const std::string& what) {
        if (error_ == 0 && ::fsync(fd_) != 0 && errno != EINVAL) error_ = errno;
        if (::close(fd_) != 0 && error_ == 0) error_ = errno;
        fd_ = -1;
        if (error_ != 0)
            throw std::runtime_error(name_ + ": cannot write " + what + ": " +
                                     detail::errno_text(error_));
    }

private:
    std::string name_;
    int fd_ = -1;
    int error_ = 0;
};

/// Writes `bytes` to to.temp, checked (CheckedFile). Throws std::runtime_error naming to.path.
inline void write_staged_text(const StagedFile& to, const std::string& bytes,
                              const std::string& what = "file") {
    CheckedFile f(to.temp, to.path);
    f.write(bytes.data(), bytes.size());
    f.close(what);
}

/// The output files of one run (see the header comment).
class OutputFiles {
public:
    OutputFiles() = default;
    OutputFiles(const OutputFiles&) = delete;
    OutputFiles& operator=(const OutputFiles&) = delete;
    /// Removes every temp that was staged and not committed.
    ~OutputFiles() {
        for (const Entry& e : entries_) {
            if (e.committed) continue;
            std::remove(e.file.temp.c_str());
            detail::unregister_temp(e.slot);
        }
    }

    /// Registers `path` (its temp is removed by the signal handlers and by the destructor unless
    /// committed) and returns where to write it.
    StagedFile stage(const std::string& path) {
        Entry e{{path, temp_path_for(path)}, -1, false};
        e.slot = detail::register_temp(e.file.temp);
        entries_.push_back(e);
        return e.file;
    }

    /// Renames every staged temp over its path, in staging order. Throws std::runtime_error
    /// naming the path that failed; temps not renamed yet are removed (files renamed before it
    /// stay: check_output_path() before the work makes this a failure of the file system itself).
    void commit() {
        for (Entry& e : entries_) {
            if (std::rename(e.file.temp.c_str(), e.file.path.c_str()) != 0) {
                const int err = errno;
                throw std::runtime_error(e.file.path +
                                         ": cannot replace the file with the finished temporary " +
                                         e.file.temp + ": " + detail::errno_text(err));
            }
            e.committed = true;
            detail::unregister_temp(e.slot);
        }
    }

private:
    struct Entry {
        StagedFile file;
        int slot;
        bool committed;
    };
    std::vector<Entry> entries_;
};

/// Deletes "<path>.tmp-<pid>" files beside `path` whose process no longer runs (left by a
/// SIGKILL or a crash). Silent: a temp that cannot be removed stays.
inline void remove_stale_temps(const std::string& path) {
    namespace fs = std::filesystem;
    const fs::path target(path);
    const fs::path dir = target.has_parent_path() ? target.parent_path() : fs::path(".");
    const std::string prefix = target.filename().string() + ".tmp-";
    std::error_code ec;
    for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
        const std::string name = it->path().filename().string();
        if (name.compare(0, prefix.size(), prefix) != 0) continue;
        const std::string digits = name.substr(prefix.size());
        if (digits.empty() || digits.size() > 9 ||
            digits.find_first_not_of("0123456789") != std::string::npos)
            continue;
        const long pid = std::stol(digits);
        if (pid <= 0 || pid == static_cast<long>(::getpid())) continue;
        if (::kill(static_cast<pid_t>(pid), 0) == 0 || errno != ESRCH) continue;  // still runs
        std::error_code rm;
        fs::remove(it->path(), rm);
    }
}

/// Checks before any work, creating nothing, that `path` can be written as an output of the
/// option `option` ("-o", "--png", "--csv"): not a folder; its folder, or the nearest existing
/// folder above it, writable; every missing folder name and the temp file's name within the
/// file system's name length. Where the folder exists the temp file is created and removed,
/// which finds read-only file systems too. Removes stale temps beside it. Throws
/// InputError{path, option, reason}.
inline void check_output_path(const std::string& path, const std::string& option) {
    namespace fs = std::filesystem;
    std::error_code ec;
    if (fs::is_directory(path, ec))
        throw InputError(path, option, "is a folder; expected a file path");
    const fs::path target = fs::absolute(fs::path(path), ec);
    fs::path existing = target.parent_path();
    std::vector<std::string> missing{temp_path_for(target.filename().string())};
    while (!existing.empty() && !fs::exists(existing, ec) && existing != existing.root_path()) {
        missing.push_back(existing.filename().string());
        existing = existing.parent_path();
    }
    if (!fs::is_directory(existing, ec))
        throw InputError(
            path, option,
            "'" + existing.string() + "' is a file; expected a folder above the output");
    const long name_max = ::pathconf(existing.c_str(), _PC_NAME_MAX);
    for (const std::string& name : missing)
        if (name_max > 0 && static_cast<long>(name.size()) > name_max)
            throw InputError(path, option,
                             "the name '" + name + "' is " + std::to_string(name.size()) +
                                 " bytes; this file system allows " + std::to_string(name_max));
    if (::access(existing.c_str(), W_OK | X_OK) != 0)
        throw InputError(
            path, option,
            "cannot write in folder '" + existing.string() + "': " + detail::errno_text(errno));
    if (missing.size() > 1) return;  // the folders are made when the outputs are written
    remove_stale_temps(path);
    const std::string temp = temp_path_for(path);
    const int fd = ::open(temp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd < 0) {
        const int err = errno;
        if (err == EEXIST) return;  // this process's own temp: it can be written
        throw InputError(
            path, option,
            "cannot write here (its temporary file cannot be created): " + detail::errno_text(err));
    }
    ::close(fd);
    ::unlink(temp.c_str());
}

/// Creates the folder of `path` when missing. Throws std::runtime_error naming it.
inline void create_output_folder(const std::string& path) {
    namespace fs = std::filesystem;
    const fs::path parent = fs::path(path).parent_path();
    std::error_code ec;
    if (!parent.empty()) fs::create_directories(parent, ec);
    if (ec)
        throw std::runtime_error(path + ": cannot create folder '" + parent.string() +
                                 "': " + ec.message());
}

/// True when a and b name the same file (both exist and are one inode, or their absolute,
/// normalised paths are equal).
inline bool same_file(const std::string& a, const std::string& b) {
    namespace fs = std::filesystem;
    std::error_code ec;
    if (fs::equivalent(a, b, ec) && !ec) return true;
    const fs::path pa = fs::weakly_canonical(fs::absolute(a), ec);
    const fs::path pb = fs::weakly_canonical(fs::absolute(b), ec);
    return pa == pb;
}

}  // namespace fogmap
