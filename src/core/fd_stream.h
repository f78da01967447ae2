#pragma once
// Binary streams over a file descriptor, for what fogmap's VDB reader child sends its parent
// (media/vdb_probe.h): plain values, vectors of them and strings, in the machine's own layout
// (both ends are the same binary). A stream that ends early (the child crashed or was killed while
// writing) throws StreamEnd, for the caller to ask the child's exit status why. Not thread-safe:
// one stream per descriptor.

#include <unistd.h>

#include <cerrno>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

namespace fogmap {

/// The stream ended (or failed) before the value asked for.
struct StreamEnd : std::runtime_error {
    StreamEnd() : std::runtime_error("the stream ended early") {}
};

class FdWriter {
public:
    explicit FdWriter(int fd) : fd_(fd) {}
    void bytes(const void* data, size_t n) {
        const char* p = static_cast<const char*>(data);
        while (n > 0) {
            const ssize_t w = write(fd_, p, n);
            if (w < 0 && errno == EINTR) continue;
            if (w <= 0) throw StreamEnd();
            p += w;
            n -= size_t(w);
        }
    }
    template <class T>
    void value(const T& v) {
        static_assert(std::is_trivially_copyable_v<T>);
        bytes(&v, sizeof v);
    }
    template <class T>
    void values(const std::vector<T>& v) {
        value(uint64_t(v.size()));
        bytes(v.data(), v.size() * sizeof(T));
    }
    void text(const std::string& s) {
        value(uint64_t(s.size()));
        bytes(s.data(), s.size());
    }

private:
    int fd_;
};

class FdReader {
public:
    explicit FdReader(int fd) : fd_(fd) {}
    void bytes(void* data, size_t n) {
        char* p = static_cast<char*>(data);
        while (n > 0) {
            const ssize_t r = read(fd_, p, n);
            if (r < 0 && errno == EINTR) continue;
            if (r <= 0) throw StreamEnd();
            p += r;
            n -= size_t(r);
        }
    }
    template <class T>
    T value() {
        static_assert(std::is_trivially_copyable_v<T>);
        T v;
        bytes(&v, sizeof v);
        return v;
    }
    template <class T>
    void values(std::vector<T>* v) {
        v->resize(value<uint64_t>());
        bytes(v->data(), v->size() * sizeof(T));
    }
    std::string text() {
        std::string s(value<uint64_t>(), '\0');
        bytes(s.data(), s.size());
        return s;
    }

private:
    int fd_;
};

}  // namespace fogmap
