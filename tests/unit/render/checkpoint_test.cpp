// Checkpoints (render/checkpoint.h): a hand-built checkpoint survives checkpoint_bytes and
// read_checkpoint unchanged, its bytes are the layout the header states (the FNV-1a checksum
// recomputed here), and what read_checkpoint promises to refuse is refused with an InputError
// naming the file and the checkpoint's field: another fingerprint, a file cut short anywhere, any
// one bit flipped anywhere, not a checkpoint or an older format, another size than the run's,
// and fields (checksum made right again) that disagree with the run or with each other, iteration
// 1's error estimate among them.

#include "render/checkpoint.h"

#include "test_support.h"

#include <gtest/gtest.h>

#include <cstring>
#include <limits>
#include <string>
#include <vector>

namespace fogmap {
namespace {

constexpr uint64_t kFingerprint = 0x0123456789ABCDEFull;
constexpr char kMagic[] = "fogmap checkpoint 7\n";

/// A run of at most 10 iterations, by default 3 x 2, layered and with bias halves.
CheckpointShape shape(bool layered = true, int width = 3, int height = 2, bool bias = true) {
    CheckpointShape s;
    s.fingerprint = kFingerprint;
    s.width = width;
    s.height = height;
    s.layered = layered;
    s.bias = bias;
    s.max_iterations = 10;
    return s;
}

/// 7 iterations (counts[0], as the pipeline keeps it), the other counts distinct, every value
/// distinct with negative ones and extremes among them.
Checkpoint hand_built(bool layered = true, int width = 3, int height = 2, bool bias = true) {
    Checkpoint c;
    c.fingerprint = kFingerprint;
    c.iterations = 7;
    c.counts.resize(kRunCounts);
    for (size_t i = 0; i < kRunCounts; ++i) c.counts[i] = i == 0 ? 7 : int64_t(i) << (3 * i);
    c.sum.width = width;
    c.sum.height = height;
    c.sum.layered = layered;
    c.sum.bias = bias;
    c.sum.values.resize(
        size_t(width * height *
               (3 * (1 + (layered ? kLayerCount : 0) + kBatches + (bias ? 4 : 0)) + kBatches)));
    for (size_t i = 0; i < c.sum.values.size(); ++i)
        c.sum.values[i] =
            int64_t((uint64_t(i) * 0x9E3779B97F4A7C15ull) ^ (i % 3 ? 0 : uint64_t(1) << 63));
    return c;
}

/// An estimate of a `width` x `height` film with every field set, its variance distinct per value.
ErrorEstimate an_estimate(int width = 3, int height = 2) {
    ErrorEstimate e;
    e.valid = true;
    e.batches = 8;
    e.rel_mse = {2.5e-4, 1.5e-4, 4.0e-4};
    e.bias_valid = true;
    e.bias2 = {1e-5, 0.0, 3e-5};
    e.tail_share = 0.625;
    e.tail = true;
    e.top_x = width - 1;
    e.top_y = 0;
    e.dof = std::numeric_limits<double>::infinity();
    e.variance = Image(width, height);
    for (size_t p = 0; p < e.variance.pixels.size(); ++p)
        e.variance.pixels[p] = Color(float(p) * 0.5f, 1e-7f * float(p + 1), 3.0e30f);
    return e;
}

/// hand_built() of one iteration, with iteration 1's estimate.
Checkpoint with_estimate(bool layered = true, int width = 3, int height = 2) {
    Checkpoint c = hand_built(layered, width, height);
    c.iterations = 1;
    c.counts[0] = 1;
    c.first = an_estimate(width, height);
    return c;
}

/// The file's bytes by the header's description: the magic line; fingerprint, iterations,
/// width, height, layered, bias halves, count of counts, counts, count of values, values,
/// little-endian; the FNV-1a checksum of all before it.
std::string expected_bytes(const Checkpoint& c) {
    std::string out = kMagic;
    auto put = [&](uint64_t v) {
        for (int b = 0; b < 8; ++b) out.push_back(char((v >> (8 * b)) & 0xFF));
    };
    put(c.fingerprint);
    put(uint64_t(c.iterations));
    put(uint64_t(c.sum.width));
    put(uint64_t(c.sum.height));
    put(c.sum.layered ? 1 : 0);
    put(c.sum.bias ? 1 : 0);
    put(c.counts.size());
    for (int64_t v : c.counts) put(uint64_t(v));
    put(c.sum.values.size());
    for (int64_t v : c.sum.values) put(uint64_t(v));
    // The estimate's count and values: its fields as error_estimate.h lists them, then each
    // variance pixel's channels, every one a double's bits.
    std::vector<double> first;
    if (c.first) {
        const ErrorEstimate& e = *c.first;
        first = {1.0,
                 double(e.batches),
                 e.rel_mse.value,
                 e.rel_mse.lo,
                 e.rel_mse.hi,
                 1.0,
                 e.bias2.value,
                 e.bias2.lo,
                 e.bias2.hi,
                 e.tail_share,
                 e.tail ? 1.0 : 0.0,
                 double(e.top_x),
                 double(e.top_y),
                 e.dof};
        for (const Color& v : e.variance.pixels)
            for (int k = 0; k < 3; ++k) first.push_back(double(v[k]));
    }
    put(first.size());
    for (double v : first) {
        uint64_t bits;
        std::memcpy(&bits, &v, 8);
        put(bits);
    }
    put(test::fnv1a_64(out));
    return out;
}

TEST(Checkpoint, BytesFollowTheStatedLayout) {
    for (bool layered : {true, false}) {
        const Checkpoint c = hand_built(layered);
        EXPECT_EQ(checkpoint_bytes(c), expected_bytes(c)) << "layered " << layered;
        const Checkpoint first = with_estimate(layered);
        EXPECT_EQ(checkpoint_bytes(first), expected_bytes(first)) << "layered " << layered;
    }
}

TEST(Checkpoint, RoundTripKeepsIterationOnesEstimate) {
    const test::TempDir dir("fogmap_checkpoint");
    const Checkpoint c = with_estimate();
    const Checkpoint r = read_checkpoint(dir.write("run.ckpt", checkpoint_bytes(c)), shape());
    ASSERT_TRUE(r.first.has_value());
    const ErrorEstimate &a = *c.first, &b = *r.first;
    EXPECT_TRUE(b.valid);
    EXPECT_EQ(b.batches, a.batches);
    EXPECT_EQ(b.rel_mse.value, a.rel_mse.value);
    EXPECT_EQ(b.rel_mse.lo, a.rel_mse.lo);
    EXPECT_EQ(b.rel_mse.hi, a.rel_mse.hi);
    EXPECT_TRUE(b.bias_valid);
    EXPECT_EQ(b.bias2.value, a.bias2.value);
    EXPECT_EQ(b.bias2.hi, a.bias2.hi);
    EXPECT_EQ(b.tail_share, a.tail_share);
    EXPECT_TRUE(b.tail);
    EXPECT_EQ(b.top_x, a.top_x);
    EXPECT_EQ(b.top_y, a.top_y);
    EXPECT_EQ(b.dof, a.dof);
    EXPECT_EQ(b.variance.pixels, a.variance.pixels);
    EXPECT_FALSE(read_checkpoint(dir.write("no.ckpt", checkpoint_bytes(hand_built())), shape())
                     .first.has_value());
}

TEST(Checkpoint, RoundTripKeepsEveryField) {
    const test::TempDir dir("fogmap_checkpoint");
    for (bool layered : {true, false}) {
        const Checkpoint c = hand_built(layered);
        const std::string path = dir.write("run.ckpt", checkpoint_bytes(c));
        const Checkpoint r = read_checkpoint(path, shape(layered));
        EXPECT_EQ(r.fingerprint, c.fingerprint);
        EXPECT_EQ(r.iterations, c.iterations);
        EXPECT_EQ(r.counts, c.counts);
        EXPECT_EQ(r.sum.width, c.sum.width);
        EXPECT_EQ(r.sum.height, c.sum.height);
        EXPECT_EQ(r.sum.layered, layered);
        EXPECT_TRUE(r.sum.bias);
        EXPECT_EQ(r.sum.values, c.sum.values);
        EXPECT_EQ(r.sum.clamped, 0u);
    }
}

TEST(Checkpoint, RoundTripOfAFilmSumGivesTheSameMean) {
    Film film(3, 2, false);
    film.beauty.at(1, 0) = Color(0.5f, 1.25f, 3.0f);
    film.beauty.at(2, 1) = Color(7.0f, 0.0f, 0.125f);
    Checkpoint c = hand_built(false, 3, 2, false);
    c.iterations = 2;
    c.counts[0] = 2;
    c.sum = FixedFilm{};
    c.sum.add(film, 1, 4);
    c.sum.add(film, 2, 4);
    const test::TempDir dir("fogmap_checkpoint");
    const Checkpoint r =
        read_checkpoint(dir.write("a.ckpt", checkpoint_bytes(c)), shape(false, 3, 2, false));
    EXPECT_EQ(r.sum.mean(r.iterations, 4).beauty.pixels, film.beauty.pixels);
    EXPECT_EQ(r.sum.mean(r.iterations, 4).samples.at(2, 1), Color(8.0f));  // 4 + 4 spp
}

/// The InputError reading `bytes` as a checkpoint of `s` gives; it must name the file.
InputError refusal(const test::TempDir& dir, const std::string& bytes,
                   const CheckpointShape& s = shape()) {
    const std::string path = dir.write("bad.ckpt", bytes);
    const InputError e = test::catch_input_error([&] { read_checkpoint(path, s); });
    EXPECT_EQ(e.file, path);
    return e;
}

TEST(Checkpoint, AnotherFingerprintIsRefused) {
    const test::TempDir dir("fogmap_checkpoint");
    CheckpointShape other = shape();
    other.fingerprint ^= 1;
    const InputError e = refusal(dir, checkpoint_bytes(hand_built()), other);
    EXPECT_EQ(e.field, "fingerprint") << e.what();
}

// Every byte tried: on the smallest checkpoints, 1 x 1 and unlayered (204 bytes; 340 with an
// estimate).
TEST(Checkpoint, AFileCutShortAnywhereIsRefused) {
    const test::TempDir dir("fogmap_checkpoint");
    for (const Checkpoint& c : {hand_built(false, 1, 1), with_estimate(false, 1, 1)}) {
        const std::string bytes = checkpoint_bytes(c);
        for (size_t n = 0; n < bytes.size(); ++n) {
            SCOPED_TRACE("first " + std::to_string(n) + " of " + std::to_string(bytes.size()) +
                         " bytes");
            refusal(dir, bytes.substr(0, n), shape(false, 1, 1));
        }
    }
}

TEST(Checkpoint, AnyFlippedBitIsRefused) {
    const test::TempDir dir("fogmap_checkpoint");
    for (const Checkpoint& c : {hand_built(false, 1, 1), with_estimate(false, 1, 1)}) {
        const std::string bytes = checkpoint_bytes(c);
        for (size_t at = 0; at < bytes.size(); ++at) {
            std::string flipped = bytes;
            flipped[at] = char(flipped[at] ^ (1 << (at % 8)));
            SCOPED_TRACE("byte " + std::to_string(at));
            refusal(dir, flipped, shape(false, 1, 1));
        }
    }
}

TEST(Checkpoint, NotACheckpointOrAnOlderFormatIsRefused) {
    const test::TempDir dir("fogmap_checkpoint");
    EXPECT_EQ(refusal(dir, "{\"camera\": {}}\n").field, "format");
    std::string older = checkpoint_bytes(hand_built());
    older[std::strlen(kMagic) - 2] = '1';  // "fogmap checkpoint 1"
    const InputError e = refusal(dir, older);
    EXPECT_EQ(e.field, "format");
    EXPECT_NE(e.reason.find("older"), std::string::npos) << e.what();
}

TEST(Checkpoint, AnotherSizeThanTheRunsIsRefused) {
    const test::TempDir dir("fogmap_checkpoint");
    const std::string bytes = checkpoint_bytes(hand_built());
    EXPECT_EQ(refusal(dir, bytes + std::string(8, '\0')).field, "size");
    // An unlayered checkpoint for a layered run, and the other way round; one without bias halves
    // for a run with them.
    EXPECT_EQ(refusal(dir, checkpoint_bytes(hand_built(false))).field, "size");
    EXPECT_EQ(refusal(dir, bytes, shape(false)).field, "size");
    EXPECT_EQ(refusal(dir, checkpoint_bytes(hand_built(true, 3, 2, false))).field, "size");
}

/// hand_built()'s bytes with its 8-byte field number `field` after the magic line set to v and
/// the checksum made right again.
std::string with_field(size_t field, int64_t v) {
    std::string bytes = checkpoint_bytes(hand_built());
    std::memcpy(&bytes[std::strlen(kMagic) + 8 * field], &v, sizeof v);
    const uint64_t sum = test::fnv1a_64(bytes.substr(0, bytes.size() - 8));
    std::memcpy(&bytes[bytes.size() - 8], &sum, sizeof sum);
    return bytes;
}

TEST(Checkpoint, FieldsThatDisagreeAreRefusedByName) {
    const test::TempDir dir("fogmap_checkpoint");
    // Fields: 0 fingerprint, 1 iterations, 2 width, 3 height, 4 layered, 5 bias halves, 6 count
    // of counts, 7 .. 7 + kRunCounts − 1 the counts (the first the iterations again).
    const size_t first_count = 7;
    const struct {
        size_t field;
        int64_t value;
        const char* name;
    } cases[] = {
        {1, 0, "iterations"},
        {1, -3, "iterations"},
        {1, 11, "iterations"},  // more than the run's 10
        {2, 2, "width"},        // the file's size is the run's: the field alone disagrees
        {3, 3, "height"},
        {4, 0, "layers"},
        {5, 0, "bias"},
        {6, int64_t(kRunCounts) - 1, "counts"},
        {6, -1, "counts"},
        {first_count, 6, "counts"},       // not the checkpoint's iterations
        {first_count + 3, -5, "counts"},  // negative
    };
    for (const auto& c : cases) {
        SCOPED_TRACE(std::string(c.name) + " = " + std::to_string(c.value));
        EXPECT_EQ(refusal(dir, with_field(c.field, c.value)).field, c.name);
    }
}

TEST(Checkpoint, ACountOfValuesThatDisagreesIsRefused) {
    // The count of values stands after the counts; the file's size fixes how many there are.
    const test::TempDir dir("fogmap_checkpoint");
    const size_t values_field = 7 + kRunCounts;
    const int64_t values = 3 * 3 * 2 * (1 + kLayerCount + kBatches + 4);
    refusal(dir, with_field(values_field, values - 1));
}

TEST(Checkpoint, AnEstimateOutOfItsRangeIsRefused) {
    const test::TempDir dir("fogmap_checkpoint");
    // The estimate stands after the film's values: its count, then its fields (0 valid, 1
    // batches, 2-4 the relMSE's interval, ...), then the variance's values.
    const std::string good = checkpoint_bytes(with_estimate());
    const size_t count = good.size() - 8 * (2 + estimate_value_count(3, 2));
    const auto with_value = [&](size_t at, double v) {
        std::string bytes = good;
        std::memcpy(&bytes[at], &v, 8);
        const uint64_t sum = test::fnv1a_64(bytes.substr(0, bytes.size() - 8));
        std::memcpy(&bytes[bytes.size() - 8], &sum, sizeof sum);
        return bytes;
    };
    const double nan = std::numeric_limits<double>::quiet_NaN(), inf = 1e300 * 1e300;
    const struct {
        size_t value;  ///< 0: the count; k: the estimate's value k − 1 (field k − 1 to 13)
        double v;
    } cases[] = {{1, 0.0},   {1, 2.0},  {2, 9.0},   {2, 1.5},   {3, nan},  {4, -1e-4},
                 {5, 1e-4},  {6, 0.5},  {9, inf},   {10, 1.5},  {11, 0.5}, {12, 3.0},
                 {13, -2.0}, {14, 0.0}, {16, -1.0}, {20, 1e39}, {17, nan}};
    for (const auto& c : cases) {
        SCOPED_TRACE("value " + std::to_string(c.value) + " = " + std::to_string(c.v));
        EXPECT_EQ(refusal(dir, with_value(count + 8 * c.value, c.v)).field, "estimate");
    }
    // A count of values other than the estimate's (the file's size says it holds one).
    std::string bytes = good;
    const int64_t fewer = int64_t(estimate_value_count(3, 2)) - 1;
    std::memcpy(&bytes[count], &fewer, 8);
    const uint64_t sum = test::fnv1a_64(bytes.substr(0, bytes.size() - 8));
    std::memcpy(&bytes[bytes.size() - 8], &sum, sizeof sum);
    EXPECT_EQ(refusal(dir, bytes).field, "estimate");
}

TEST(Checkpoint, AMissingFileOrAFolderIsRefused) {
    const test::TempDir dir("fogmap_checkpoint");
    const std::string missing = (dir.path() / "absent.ckpt").string();
    EXPECT_EQ(test::catch_input_error([&] { read_checkpoint(missing, shape()); }).file, missing);
    const std::string folder = dir.path().string();
    EXPECT_EQ(test::catch_input_error([&] { read_checkpoint(folder, shape()); }).file, folder);
}

}  // namespace
}  // namespace fogmap
