#pragma once
// The first line of fogmap's own binary files (checkpoints, part files): a prefix naming the
// kind and the format's number, "fogmap part 4\n". The number rises whenever the layout changes,
// so that a file an older fogmap wrote is refused by name, never misread.

#include "core/error.h"

#include <string>

namespace fogmap {

/// The first line of format `format` of the files whose lines start with `prefix`.
inline std::string format_line(const std::string& prefix, int format) {
    return prefix + std::to_string(format) + "\n";
}

/// Fails naming `path`'s "format" unless `head` (the file's first bytes) starts with format
/// `format`'s first line: a first line of an older format (1 .. format − 1) as an older fogmap's,
/// with `remedy`; any other as not `kind`'s.
inline void check_format_line(const std::string& path, const std::string& head,
                              const std::string& prefix, int format, const std::string& kind,
                              const std::string& remedy) {
    if (head.rfind(format_line(prefix, format), 0) == 0) return;
    for (int old = 1; old < format; ++old)
        if (head.rfind(format_line(prefix, old), 0) == 0)
            throw InputError(
                path, "format",
                "written by an older fogmap (format " + std::to_string(old) + "); " + remedy);
    throw InputError(
        path, "format",
        "not " + kind + " (its first line is not \"" + prefix + std::to_string(format) + "\")");
}

}  // namespace fogmap
