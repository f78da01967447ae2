// Checkpoints are checked before they are trusted (render/checkpoint.h): each field against the
// run and against the file itself, a checksum of the payload, and the input files behind the
// scene's paths. A corrupt or foreign checkpoint is one line `CHECKPOINT: FIELD: REASON`, exit 2,
// and the older output is left as it was. The file layout is the one checkpoint.h states; the
// checksum is recomputed here with an independent FNV-1a, so each field's own check is reached.

#include "test_support.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <string>

namespace fogmap {
namespace {

namespace fs = std::filesystem;

// The layout of "fogmap checkpoint 7": the header line, then 8-byte fields (fingerprint,
// iterations, width, height, layered, bias halves, count of counts, counts, ...).
constexpr size_t kHeader = 20;  // "fogmap checkpoint 7\n"
constexpr size_t kIterations = kHeader + 8, kWidth = kHeader + 16, kBias = kHeader + 40,
                 kCounts = kHeader + 48, kFirstCount = kHeader + 56;

uint64_t fnv1a_64(const std::string& s) {
    uint64_t h = 14695981039346656037ull;
    for (unsigned char c : s) h = (h ^ c) * 1099511628211ull;
    return h;
}

int64_t field(const std::string& bytes, size_t at) {
    int64_t v;
    std::memcpy(&v, bytes.data() + at, 8);
    return v;
}

// `bytes` with the field at `at` set to `v` and the checksum made right again.
std::string with_field(std::string bytes, size_t at, int64_t v) {
    std::memcpy(bytes.data() + at, &v, 8);
    const uint64_t sum = fnv1a_64(bytes.substr(0, bytes.size() - 8));
    std::memcpy(bytes.data() + bytes.size() - 8, &sum, 8);
    return bytes;
}

class Checkpoints : public ::testing::Test {
protected:
    void SetUp() override {
        // A VDB of the test's own, so that it can change behind the scene's path.
        ASSERT_EQ(
            test::run_fogmap("volume plume -o " + at("p.vdb") + " --resolution 16", dir_).code, 0);
        tmp_.write("s.json", R"({
          "camera": {"position": [0, 1, 5], "look_at": [0, 1, 0], "width": 8, "height": 6},
          "lights": [{"type": "point", "intensity": 20, "position": [0, 4, 2]}],
          "media": [{"type": "vdb", "file": "p.vdb", "sigma_s": 5, "sigma_a": 0.5}],
          "render": {"integrator": "photon", "spp": 2},
          "photons": {"volume": 2000, "global": 0, "caustic": 0}
        })");
        const test::RunResult r = resume(2, "--checkpoint-every 1000");
        ASSERT_EQ(r.code, 0) << r.err;
        good_ = test::slurp(at("c.exr.checkpoint"));
        exr_ = test::slurp(at("c.exr"));
        ASSERT_GT(good_.size(), kFirstCount + 11 * 8);
    }
    std::string at(const std::string& name) const { return (dir_ / name).string(); }
    test::RunResult resume(int iterations, const std::string& extra = "--resume") {
        return test::run_fogmap("render -q " + at("s.json") + " --iterations " +
                                    std::to_string(iterations) + " " + extra + " -o " + at("c.exr"),
                                dir_);
    }
    // Resuming from `bytes` fails naming the checkpoint and `field`, and leaves the output.
    void expect_refused(const std::string& bytes, const std::string& field) {
        SCOPED_TRACE(field);
        tmp_.write("c.exr.checkpoint", bytes);
        const test::RunResult r = resume(4);
        EXPECT_EQ(r.code, 2) << r.err;
        EXPECT_NE(r.err.find("fogmap: error: " + at("c.exr.checkpoint") + ": " + field + ": "),
                  std::string::npos)
            << r.err;
        EXPECT_EQ(r.err.find("fogmap: error:"), r.err.rfind("fogmap: error:")) << r.err;
        EXPECT_TRUE(test::slurp(at("c.exr")) == exr_);
    }

    test::TempDir tmp_{"fogmap_checkpoint"};
    const fs::path dir_ = tmp_.path();
    std::string good_, exr_;
};

TEST_F(Checkpoints, AnIntactCheckpointResumes) {
    const test::RunResult r = resume(4);
    EXPECT_EQ(r.code, 0) << r.err;
}

TEST_F(Checkpoints, CorruptOrForeignFieldsAreRefusedByName) {
    std::string flipped = good_;
    flipped[flipped.size() / 2] ^= 0x10;  // a bit of the payload
    expect_refused(flipped, "checksum");
    expect_refused(good_.substr(0, good_.size() - 8), "size");
    expect_refused(good_ + std::string(8, '\0'), "size");
    expect_refused(with_field(good_, kIterations, int64_t(1) << 31), "iterations");
    expect_refused(with_field(good_, kIterations, -3), "iterations");
    expect_refused(with_field(good_, kWidth, 1), "width");
    expect_refused(with_field(good_, kCounts, 0), "counts");
    expect_refused(with_field(good_, kFirstCount, 7), "counts");        // its own iterations: 2
    expect_refused(with_field(good_, kFirstCount + 16, -1), "counts");  // a negative count
    expect_refused("fogmap checkpoint 1\n" + good_.substr(kHeader), "format");
    expect_refused("fogmap checkpoint 2\n" + good_.substr(kHeader), "format");
    expect_refused("fogmap checkpoint 3\n" + good_.substr(kHeader), "format");
    expect_refused("fogmap checkpoint 4\n" + good_.substr(kHeader), "format");
    expect_refused("fogmap checkpoint 5\n" + good_.substr(kHeader), "format");
    expect_refused("fogmap checkpoint 6\n" + good_.substr(kHeader), "format");
    expect_refused(with_field(good_, kBias, 1 - field(good_, kBias)), "bias");
    expect_refused("not a checkpoint", "format");
    expect_refused(with_field(good_, kHeader, 12345), "fingerprint");
    EXPECT_EQ(field(good_, kFirstCount), 2);
}

// A run of one iteration states that iteration's estimate from its batches of samples; resumed
// from its checkpoint (a farm's task run again), it states the same one, where the checkpoint's
// sum of one iteration has a single batch of iterations.
TEST_F(Checkpoints, AResumedRunOfOneIterationStatesThatIterationsEstimate) {
    const std::string args = "render -q " + at("s.json") +
                             " --iterations 1 --set render.spp=16 -o " + at("one.exr") + " ";
    const test::RunResult run = test::run_fogmap(args + "--checkpoint-every 1000", dir_);
    ASSERT_EQ(run.code, 0) << run.err;
    const std::string exr = test::slurp(at("one.exr"));
    const test::RunResult resumed = test::run_fogmap(args + "--resume", dir_);
    ASSERT_EQ(resumed.code, 0) << resumed.err;
    const std::string line = test::report_line(run.out, "error estimate:");
    EXPECT_NE(line.find("relMSE"), std::string::npos) << run.out;
    EXPECT_EQ(test::report_line(resumed.out, "error estimate:"), line);
    EXPECT_TRUE(test::slurp(at("one.exr")) == exr) << "the resumed run's EXR differs";
}

// The VDB behind the scene's path changed (its modification time): another run's checkpoint.
TEST_F(Checkpoints, AChangedInputFileIsNoticed) {
    fs::last_write_time(at("p.vdb"), fs::last_write_time(at("p.vdb")) + std::chrono::hours(1));
    expect_refused(good_, "fingerprint");
}

// A folder where the checkpoint goes is found before any work, with --checkpoint-every too.
TEST_F(Checkpoints, AFolderAtTheCheckpointPathIsFoundFirst) {
    fs::remove(at("c.exr.checkpoint"));
    fs::create_directory(at("c.exr.checkpoint"));
    for (const char* option : {"--resume", "--checkpoint-every 1"}) {
        SCOPED_TRACE(option);
        const test::RunResult r = resume(4, option);
        EXPECT_EQ(r.code, 2) << r.err;
        EXPECT_NE(r.err.find(at("c.exr.checkpoint") + ": "), std::string::npos) << r.err;
        EXPECT_NE(r.err.find("is a folder"), std::string::npos) << r.err;
        EXPECT_EQ(r.err.find("photon pass"), std::string::npos) << r.err;
        EXPECT_TRUE(test::slurp(at("c.exr")) == exr_);
    }
}

}  // namespace
}  // namespace fogmap
