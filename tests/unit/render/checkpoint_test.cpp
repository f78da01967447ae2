// Checkpoints (render/checkpoint.h): a hand-built checkpoint survives checkpoint_bytes and
// read_checkpoint unchanged, its bytes are the layout the header states (the FNV-1a checksum
// recomputed here), and what read_checkpoint promises to refuse is refused with an InputError
// naming the file and the checkpoint's field: another fingerprint, a file cut short anywhere, any
// one bit flipped anywhere, not a checkpoint or an older format, another size than the run's,
// and fields (checksum made right again) that disagree with the run or with each other.

#include "render/checkpoint.h"

#include "test_support.h"

#include <gtest/gtest.h>

#include <cstring>
#include <string>

namespace fogmap {
namespace {

constexpr uint64_t kFingerprint = 0x0123456789ABCDEFull;
constexpr char kMagic[] = "fogmap checkpoint 6\n";

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
    put(test::fnv1a_64(out));
    return out;
}

TEST(Checkpoint, BytesFollowTheStatedLayout) {
    for (bool layered : {true, false}) {
        const Checkpoint c = hand_built(layered);
        EXPECT_EQ(checkpoint_bytes(c), expected_bytes(c)) << "layered " << layered;
    }
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

// Every byte tried: on the smallest checkpoint, 1 x 1 and unlayered (196 bytes).
TEST(Checkpoint, AFileCutShortAnywhereIsRefused) {
    const test::TempDir dir("fogmap_checkpoint");
    const std::string bytes = checkpoint_bytes(hand_built(false, 1, 1));
    for (size_t n = 0; n < bytes.size(); ++n) {
        SCOPED_TRACE("first " + std::to_string(n) + " of " + std::to_string(bytes.size()) +
                     " bytes");
        refusal(dir, bytes.substr(0, n), shape(false, 1, 1));
    }
}

TEST(Checkpoint, AnyFlippedBitIsRefused) {
    const test::TempDir dir("fogmap_checkpoint");
    const std::string bytes = checkpoint_bytes(hand_built(false, 1, 1));
    for (size_t at = 0; at < bytes.size(); ++at) {
        std::string flipped = bytes;
        flipped[at] = char(flipped[at] ^ (1 << (at % 8)));
        SCOPED_TRACE("byte " + std::to_string(at));
        refusal(dir, flipped, shape(false, 1, 1));
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

TEST(Checkpoint, AMissingFileOrAFolderIsRefused) {
    const test::TempDir dir("fogmap_checkpoint");
    const std::string missing = (dir.path() / "absent.ckpt").string();
    EXPECT_EQ(test::catch_input_error([&] { read_checkpoint(missing, shape()); }).file, missing);
    const std::string folder = dir.path().string();
    EXPECT_EQ(test::catch_input_error([&] { read_checkpoint(folder, shape()); }).file, folder);
}

}  // namespace
}  // namespace fogmap
