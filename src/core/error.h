#pragma once
// Error vocabulary. InputError is bad input (file, JSON-pointer field, reason): thrown by scene/,
// app/ and file readers only, caught in main, printed as "fogmap: error: FILE: FIELD: REASON",
// exit code 2. OutOfMemory is an allocation that failed for a known need: printed as
// "fogmap: error: FILE: out of memory (needed about N MB)", exit code 1. FOGMAP_ASSERT is for
// bugs: always on, prints file:line and exits 1.

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string>

namespace fogmap {

struct InputError : std::runtime_error {
    std::string file;    ///< path of the offending file ("" for command-line input)
    std::string field;   ///< JSON pointer such as "/media/0/sigma_s", or "" for the whole file
    std::string reason;  ///< what was found and what was expected
    InputError(std::string file_, std::string field_, std::string reason_)
        : std::runtime_error(format(file_, field_, reason_)),
          file(std::move(file_)),
          field(std::move(field_)),
          reason(std::move(reason_)) {}

    /// One bounded line: each part is cut to a few kilobytes, so no input, however long, is
    /// echoed whole (the members keep the parts uncut).
    static std::string format(const std::string& file, const std::string& field,
                              const std::string& reason) {
        std::string s = file.empty() ? std::string("<command line>") : clip(file, 1024);
        if (!field.empty()) s += ": " + clip(field, 256);
        return s + ": " + clip(reason, 4096);
    }
    static std::string clip(const std::string& text, size_t max) {
        if (text.size() <= max) return text;
        return text.substr(0, max) + "... (" + std::to_string(text.size() - max) + " more bytes)";
    }
};

/// An allocation failed (std::bad_alloc) while doing something whose memory was estimated: the
/// file being processed ("" for none) and the estimate, for the one-line message.
struct OutOfMemory : std::runtime_error {
    std::string file;           ///< the file whose processing ran out of memory, or ""
    uint64_t needed_bytes = 0;  ///< estimate of what the work needed
    OutOfMemory(std::string file_, uint64_t needed_bytes_)
        : std::runtime_error(format(file_, needed_bytes_)),
          file(std::move(file_)),
          needed_bytes(needed_bytes_) {}

    static std::string format(const std::string& file, uint64_t needed_bytes) {
        const std::string mb = std::to_string((needed_bytes + (1u << 20) - 1) >> 20);
        return (file.empty() ? std::string() : file + ": ") + "out of memory (needed about " + mb +
               " MB)";
    }
};

}  // namespace fogmap

#define FOGMAP_ASSERT(cond, msg)                                                                 \
    do {                                                                                         \
        if (!(cond)) {                                                                           \
            std::fprintf(stderr, "fogmap: internal error: %s:%d: %s (%s)\n", __FILE__, __LINE__, \
                         msg, #cond);                                                            \
            std::exit(1);                                                                        \
        }                                                                                        \
    } while (0)

#ifndef NDEBUG
#define FOGMAP_DASSERT(cond, msg) FOGMAP_ASSERT(cond, msg)
#else
#define FOGMAP_DASSERT(cond, msg) ((void)0)
#endif
