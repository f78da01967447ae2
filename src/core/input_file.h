#pragma once
// Input files are checked before they are opened: a path must name a regular file (opening a FIFO
// blocks until a writer comes, /dev/zero never ends, a folder has no bytes), and files read whole
// into memory (scene JSON, meshes) have a size cap, so reading has a bound known before it
// starts. Stateless and thread-safe; failures throw InputError{path, field, reason}.

#include "core/error.h"
#include "core/memory_budget.h"

#include <sys/stat.h>

#include <cerrno>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <string>

namespace fogmap {

/// Scene files hold settings and paths (meshes and volumes are separate files): 16 MB is a
/// thousand times the largest bundled scene, and parsing that much JSON takes ~0.3 GB.
inline constexpr uint64_t kMaxSceneFileBytes = uint64_t(16) << 20;
/// OBJ and PLY files are read whole and then parsed into vertex and index arrays (several times
/// the file's size): 1 GB of mesh text is ~100 million triangles.
inline constexpr uint64_t kMaxMeshFileBytes = uint64_t(1) << 30;

namespace detail {

inline const char* file_kind(mode_t mode) {
    if (S_ISDIR(mode)) return "a folder";
    if (S_ISFIFO(mode)) return "a FIFO (named pipe)";
    if (S_ISCHR(mode)) return "a character device";
    if (S_ISBLK(mode)) return "a block device";
    if (S_ISSOCK(mode)) return "a socket";
    return "not a regular file";
}

}  // namespace detail

/// Size in bytes of the regular file `path` (following symbolic links), checked with stat()
/// before anything opens it. `what` names the expected file in messages ("scene file").
/// Throws InputError{path, field, reason} when it is missing, not a regular file, or larger
/// than max_bytes.
inline uint64_t check_input_file(const std::string& path, const std::string& field,
                                 const std::string& what, uint64_t max_bytes = UINT64_MAX) {
    struct stat st {};
    if (::stat(path.c_str(), &st) != 0)
        throw InputError(path, field, std::string("cannot open file: ") + std::strerror(errno));
    if (!S_ISREG(st.st_mode))
        throw InputError(path, field,
                         std::string("is ") + detail::file_kind(st.st_mode) + "; expected a " +
                             what + " (a regular file)");
    const uint64_t size = static_cast<uint64_t>(st.st_size);
    if (size > max_bytes)
        throw InputError(
            path, field,
            "is " + mb_text(size) + "; a " + what + " may be at most " + mb_text(max_bytes));
    return size;
}

/// The whole content of `path` after check_input_file; a file that grows past max_bytes while it
/// is read is refused the same way. Throws InputError.
inline std::string read_input_file(const std::string& path, const std::string& field,
                                   const std::string& what, uint64_t max_bytes) {
    const uint64_t size = check_input_file(path, field, what, max_bytes);
    errno = 0;
    std::ifstream in(path, std::ios::binary);
    if (!in)
        throw InputError(path, field,
                         std::string("cannot open file: ") + std::strerror(errno ? errno : EIO));
    std::string data;
    data.reserve(static_cast<size_t>(size));
    char buf[1 << 16];
    while (in.read(buf, sizeof buf) || in.gcount() > 0) {
        data.append(buf, static_cast<size_t>(in.gcount()));
        if (data.size() > max_bytes)
            throw InputError(path, field,
                             "grew past " + mb_text(max_bytes) + " while being read; a " + what +
                                 " may be at most " + mb_text(max_bytes));
    }
    if (in.bad())
        throw InputError(path, field,
                         std::string("cannot read file: ") + std::strerror(errno ? errno : EIO));
    return data;
}

}  // namespace fogmap
