#include "render/checkpoint.h"

#include "core/error.h"
#include "core/input_file.h"

#include <cstring>

namespace fogmap {

namespace {

constexpr char kMagic[] = "fogmap checkpoint 1\n";

template <class T>
void put(std::string* out, const T& v) {
    out->append(reinterpret_cast<const char*>(&v), sizeof v);
}

}  // namespace

std::string checkpoint_bytes(const Checkpoint& c) {
    std::string out(kMagic);
    put(&out, c.fingerprint);
    put(&out, int64_t(c.iterations));
    put(&out, int64_t(c.sum.width));
    put(&out, int64_t(c.sum.height));
    put(&out, int64_t(c.sum.layered ? 1 : 0));
    put(&out, int64_t(c.counts.size()));
    for (int64_t v : c.counts) put(&out, v);
    put(&out, int64_t(c.sum.values.size()));
    out.append(reinterpret_cast<const char*>(c.sum.values.data()),
               c.sum.values.size() * sizeof(int64_t));
    return out;
}

Checkpoint read_checkpoint(const std::string& path, const std::string& option,
                           uint64_t fingerprint) {
    constexpr uint64_t kMaxBytes = uint64_t(1) << 36;
    const std::string bytes = read_input_file(path, option, "checkpoint", kMaxBytes);
    const auto fail = [&](const std::string& why) { throw InputError(path, option, why); };
    const size_t magic = std::strlen(kMagic);
    if (bytes.compare(0, magic, kMagic) != 0)
        fail("not a fogmap checkpoint (its first line is not \"fogmap checkpoint 1\")");
    size_t at = magic;
    const auto get = [&](auto* v) {
        if (bytes.size() - at < sizeof *v) fail("cut short: the file ends inside its fields");
        std::memcpy(v, bytes.data() + at, sizeof *v);
        at += sizeof *v;
    };
    Checkpoint c;
    get(&c.fingerprint);
    if (c.fingerprint != fingerprint)
        fail(
            "written for another scene or other settings (only progressive.iterations, "
            "progressive.time_budget and render.threads may change between a run and its "
            "resumption); remove it to start again");
    int64_t iterations, width, height, layered, n_counts, n_values;
    get(&iterations);
    get(&width);
    get(&height);
    get(&layered);
    get(&n_counts);
    if (n_counts < 0 || n_counts > 64) fail("corrupt: " + std::to_string(n_counts) + " counts");
    c.counts.resize(size_t(n_counts));
    for (int64_t& v : c.counts) get(&v);
    get(&n_values);
    const int64_t expected = 3 * width * height * (layered ? 1 + kLayerCount : 1);
    if (iterations < 1 || width < 1 || height < 1 || n_values != expected ||
        bytes.size() - at != uint64_t(n_values) * sizeof(int64_t))
        fail("corrupt: its image size and values do not agree");
    c.iterations = int(iterations);
    c.sum.width = int(width);
    c.sum.height = int(height);
    c.sum.layered = layered != 0;
    c.sum.values.resize(size_t(n_values));
    std::memcpy(c.sum.values.data(), bytes.data() + at, size_t(n_values) * sizeof(int64_t));
    return c;
}

}  // namespace fogmap
