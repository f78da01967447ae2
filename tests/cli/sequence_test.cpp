// Frame sequences on the command line: a generated, time-varying plume sequence rendered one image
// per frame, --resume skipping finished frames to the same images, and the errors a sequence can
// meet (a missing frame file names its frame; patterns and --frames go together).

#include "core/image.h"
#include "test_support.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <string>

namespace fogmap {
namespace {

namespace fs = std::filesystem;

class Sequence : public ::testing::Test {
protected:
    test::RunResult run(const std::string& args) { return test::run_fogmap(args, dir_); }
    std::string at(const std::string& name) const { return (dir_ / name).string(); }

    void make_sequence(int n) { test::write_plume_sequence(dir_, n); }

    test::TempDir tmp_{"fogmap_sequence"};
    const fs::path dir_ = tmp_.path();
};

bool same_pixels(const Image& a, const Image& b) {
    return a.width == b.width && a.height == b.height && a.pixels == b.pixels;
}

TEST_F(Sequence, EveryFrameRendersFromItsOwnFileAndResumeSkipsFinishedOnes) {
    make_sequence(3);
    for (int f = 1; f <= 3; ++f)
        EXPECT_TRUE(fs::exists(at("vol/p.000" + std::to_string(f) + ".vdb")));
    const std::string render =
        "render -q " + at("s.json") + " --frames 1-3 -o " + at("out/f.####.exr");
    test::RunResult r = run(render);
    ASSERT_EQ(r.code, 0) << r.err;
    Image frames[3];
    for (int f = 1; f <= 3; ++f) {
        const std::string exr = at("out/f.000" + std::to_string(f) + ".exr");
        ASSERT_TRUE(fs::exists(exr)) << exr;
        EXPECT_TRUE(fs::exists(at("out/f.000" + std::to_string(f) + ".png")));
        frames[f - 1] = read_exr(exr);
    }
    // The plume moves: each frame is its own image.
    EXPECT_FALSE(same_pixels(frames[0], frames[1]));
    EXPECT_FALSE(same_pixels(frames[1], frames[2]));

    // Frame 2 lost: --resume renders it alone, to the same image, and leaves the others alone.
    fs::remove(at("out/f.0002.exr"));
    const auto frame1_time = fs::last_write_time(at("out/f.0001.exr"));
    r = run(render + " --resume");
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_EQ(fs::last_write_time(at("out/f.0001.exr")), frame1_time);
    EXPECT_TRUE(same_pixels(read_exr(at("out/f.0002.exr")), frames[1]));
    EXPECT_EQ(r.out.find("frame 1\n"), std::string::npos) << "frame 1 was not rendered again";
    EXPECT_NE(r.out.find("frame 2\n"), std::string::npos) << r.out;
}

TEST_F(Sequence, AMissingFrameFileNamesTheFrameBeforeAnyWork) {
    make_sequence(3);
    const test::RunResult r =
        run("render -q " + at("s.json") + " --frames 1-4 -o " + at("out/f.####.exr"));
    EXPECT_EQ(r.code, 2) << r.err;
    EXPECT_NE(r.err.find("p.0004.vdb: /media/0/file: frame 4 of --frames 1-4: no such file"),
              std::string::npos)
        << r.err;
    EXPECT_FALSE(fs::exists(at("out/f.0001.exr"))) << "nothing rendered";
}

TEST_F(Sequence, PatternsAndFramesGoTogether) {
    make_sequence(1);
    test::RunResult r = run("render -q " + at("s.json") + " -o " + at("one.exr"));
    EXPECT_EQ(r.code, 2);
    EXPECT_NE(r.err.find("/media/0/file: 'vol/p.####.vdb' holds a frame pattern"),
              std::string::npos)
        << r.err;
    r = run("render -q " + at("s.json") + " --frames 1-2 -o " + at("one.exr"));
    EXPECT_EQ(r.code, 2);
    EXPECT_NE(r.err.find("-o: '" + at("one.exr") + "' has no frame pattern"), std::string::npos)
        << r.err;
    r = run("render -q " + at("s.json") + " --frames 2-1 -o " + at("f.####.exr"));
    EXPECT_EQ(r.code, 2);
    EXPECT_NE(r.err.find("--frames: found '2-1'"), std::string::npos) << r.err;
    r = run("volume plume -o " + at("p.####.vdb"));
    EXPECT_EQ(r.code, 2);
    EXPECT_NE(r.err.find("holds a frame pattern; expected --frames"), std::string::npos) << r.err;
}

// Absurd frame counts and pattern widths fail at once, naming the number, and write nothing; a
// sequence states its frames before it starts.
TEST_F(Sequence, AbsurdFrameCountsAndPatternsFailBeforeAnyWork) {
    test::write_plume_sequence(dir_, 2);
    test::RunResult r =
        run("render -q " + at("s.json") + " --frames 1-99999999 -o " + at("out/f.####.exr"));
    EXPECT_EQ(r.code, 2);
    EXPECT_NE(r.err.find("99999999 frames; at most 100000"), std::string::npos) << r.err;
    r = run("render -q " + at("s.json") + " --frames 1-2 -o '" + at("out/o.$F999999999.exr") + "'");
    EXPECT_EQ(r.code, 2);
    EXPECT_NE(r.err.find("more than 9 digits"), std::string::npos) << r.err;
    EXPECT_LT(r.err.size(), 4096u);
    r = run("volume plume --resolution 8 --frames 1-99999999 -o " + at("gen/p.####.vdb"));
    EXPECT_EQ(r.code, 2);
    EXPECT_NE(r.err.find("99999999 frames"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(at("gen")));
    EXPECT_FALSE(fs::exists(at("out")));
    r = run("render " + at("s.json") + " --frames 1-2 -o " + at("out/f.####.exr"));
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_NE(r.err.find("render: 2 frames, 1 to 2"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace fogmap
