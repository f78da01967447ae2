#include "render/checkpoint.h"

#include "core/error.h"
#include "core/format_line.h"
#include "core/hash.h"
#include "core/input_file.h"

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <system_error>

namespace fogmap {

namespace {

constexpr char kPrefix[] = "fogmap checkpoint ";
/// The format (its first line's number); older ones are refused by name. What each added: 3 the
/// batches, 4 the bias halves, 5 each pixel's samples, 6 its samples per batch (iterations weighed
/// by them), 7 iteration 1's own error estimate.
constexpr int kFormat = 7;
const std::string kMagic = format_line(kPrefix, kFormat);
/// fingerprint, iterations, width, height, layered, bias halves, count count
constexpr size_t kFields = 7;
constexpr uint64_t kMaxCheckpointBytes = uint64_t(1) << 40;  ///< the size check comes later

template <class T>
void put(std::string* out, const T& v) {
    out->append(reinterpret_cast<const char*>(&v), sizeof v);
}

/// The film values of a checkpoint of `shape`'s run: 3 per pixel, per image.
uint64_t expected_values(const CheckpointShape& shape) {
    return FixedFilm::value_count(shape.width, shape.height, shape.layered, shape.bias);
}

/// The bytes of a checkpoint of `shape`'s run, with iteration 1's estimate or without.
uint64_t expected_bytes(const CheckpointShape& shape, bool first) {
    const uint64_t estimate = first ? estimate_value_count(shape.width, shape.height) : 0;
    return kMagic.size() +
           8 * (kFields + kRunCounts + 1 + expected_values(shape) + 1 + estimate + 1);
}

[[noreturn]] void fail(const std::string& path, const char* field, const std::string& why) {
    throw InputError(path, field, why + "; remove the checkpoint to start again");
}

/// Reads the fields of a checkpoint whose size and checksum are right.
class Fields {
public:
    explicit Fields(const std::string& bytes) : bytes_(bytes) {}
    int64_t next() {
        int64_t v;
        std::memcpy(&v, bytes_.data() + at_, sizeof v);
        at_ += sizeof v;
        return v;
    }
    size_t at() const { return at_; }
    void skip(size_t fields) { at_ += fields * sizeof(int64_t); }

private:
    const std::string& bytes_;
    size_t at_ = kMagic.size();
};

/// Fails naming `field` unless the checkpoint's value equals the run's.
void expect(const std::string& path, const char* field, int64_t found, int64_t wanted,
            const std::string& what) {
    if (found != wanted)
        fail(path, field,
             std::to_string(found) + "; this run's " + what + " is " + std::to_string(wanted));
}

/// The file's first bytes (its header line and fingerprint), checked for its kind and format.
std::string header(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    std::string head(kMagic.size() + 8, '\0');
    in.read(head.data(), std::streamsize(head.size()));
    head.resize(size_t(in.gcount()));
    check_format_line(path, head, kPrefix, kFormat, "a fogmap checkpoint",
                      "remove it to start again");
    return head;
}

/// The fields of a checkpoint of the right size and checksum, each checked against the run;
/// `with_first`: its size is that of one with iteration 1's estimate.
Checkpoint parse(const std::string& path, const std::string& bytes, const CheckpointShape& shape,
                 bool with_first) {
    Fields f(bytes);
    Checkpoint c;
    c.fingerprint = uint64_t(f.next());
    const int64_t iterations = f.next();
    if (iterations < 1 || iterations > shape.max_iterations)
        fail(
            path, "iterations",
            std::to_string(iterations) + "; expected 1 to " + std::to_string(shape.max_iterations));
    expect(path, "width", f.next(), shape.width, "camera width");
    expect(path, "height", f.next(), shape.height, "camera height");
    expect(path, "layers", f.next(), shape.layered ? 1 : 0, "layered film (1 = layers)");
    expect(path, "bias", f.next(), shape.bias ? 1 : 0, "bias halves (1 = kept)");
    expect(path, "counts", f.next(), int64_t(kRunCounts), "number of counts");
    c.counts.resize(kRunCounts);
    for (int64_t& v : c.counts) {
        v = f.next();
        if (v < 0) fail(path, "counts", "a negative count, " + std::to_string(v));
    }
    expect(path, "counts", c.counts[0], iterations, "iteration count (the checkpoint's own)");
    const int64_t values = f.next();
    expect(path, "values", values, int64_t(expected_values(shape)), "film's number of values");
    c.iterations = int(iterations);
    c.sum.width = shape.width;
    c.sum.height = shape.height;
    c.sum.layered = shape.layered;
    c.sum.bias = shape.bias;
    c.sum.values.resize(size_t(values));
    std::memcpy(c.sum.values.data(), bytes.data() + f.at(), size_t(values) * sizeof(int64_t));
    f.skip(size_t(values));
    const size_t estimate = with_first ? estimate_value_count(shape.width, shape.height) : 0;
    expect(path, "estimate", f.next(), int64_t(estimate),
           "number of estimate values (by the file's size)");
    if (!with_first) return c;
    std::vector<int64_t> e(estimate);
    for (int64_t& v : e) v = f.next();
    c.first = estimate_of_values(e, shape.width, shape.height);
    if (!c.first) fail(path, "estimate", "its values are not an error estimate's");
    return c;
}

}  // namespace

std::string checkpoint_bytes(const Checkpoint& c) {
    std::string out(kMagic);
    put(&out, c.fingerprint);
    put(&out, int64_t(c.iterations));
    put(&out, int64_t(c.sum.width));
    put(&out, int64_t(c.sum.height));
    put(&out, int64_t(c.sum.layered ? 1 : 0));
    put(&out, int64_t(c.sum.bias ? 1 : 0));
    put(&out, int64_t(c.counts.size()));
    for (int64_t v : c.counts) put(&out, v);
    put(&out, int64_t(c.sum.values.size()));
    out.append(reinterpret_cast<const char*>(c.sum.values.data()),
               c.sum.values.size() * sizeof(int64_t));
    const std::vector<int64_t> first = estimate_values(c.first);
    put(&out, int64_t(first.size()));
    for (int64_t v : first) put(&out, v);
    put(&out, fnv1a(out));
    return out;
}

Checkpoint read_checkpoint(const std::string& path, const CheckpointShape& shape) {
    std::error_code ec;
    if (std::filesystem::is_directory(path, ec))
        throw InputError(path, "--resume", "is a folder; expected a checkpoint file");
    check_input_file(path, "size", "checkpoint", kMaxCheckpointBytes);
    const std::string head = header(path);
    uint64_t fingerprint = 0;
    if (head.size() == kMagic.size() + 8) std::memcpy(&fingerprint, head.data() + kMagic.size(), 8);
    if (fingerprint != shape.fingerprint)
        fail(path, "fingerprint",
             "written for another scene, other settings or other input files (only "
             "progressive.iterations, progressive.time_budget, progressive.target_relmse and "
             "render.threads may change "
             "between a run and its resumption, and the input files not at all)");
    // Read no more than this run's checkpoint takes: a file of another size is named, not loaded.
    const uint64_t size = std::filesystem::file_size(path, ec);
    const uint64_t without = expected_bytes(shape, false);
    const bool first = size != without;  // the one other size a checkpoint of this run has
    const uint64_t want = first ? expected_bytes(shape, true) : without;
    if (size != want)
        fail(path, "size",
             std::to_string(size) + " bytes; a checkpoint of this run has " +
                 std::to_string(without) + ", or " + std::to_string(want) +
                 " with its first iteration's error estimate");
    const std::string bytes = read_input_file(path, "size", "checkpoint", want);
    uint64_t sum;
    std::memcpy(&sum, bytes.data() + want - 8, 8);
    if (bytes.size() != want || sum != fnv1a(bytes.substr(0, want - 8)))
        fail(path, "checksum", "its contents do not match their checksum: the file is corrupt");
    return parse(path, bytes, shape, first);
}

}  // namespace fogmap
