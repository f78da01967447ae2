// mpirun with 1, 2 and 3 ranks (oversubscribed, unbound, allowed as root): a progressive render
// splits its iterations over the ranks and gives the same EXR, bit for bit, as fogmap without
// mpirun; the photon counts add up to the same totals; bad input exits 2 on every rank count with
// the error said once; ranks with a time budget stop together; a run resumed from its checkpoint
// (at any rank count, also after a SIGKILL) ends with the image of an uninterrupted run.

#include "test_support.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

namespace fogmap {
namespace {

namespace fs = std::filesystem;

class Mpi : public ::testing::Test {
protected:
    void SetUp() override {
        ASSERT_EQ(std::system("command -v mpirun >/dev/null"), 0)
            << "mpirun not found: scripts/debian-packages installs openmpi-bin";
    }
    test::RunResult run(const std::string& args, int ranks) {
        const std::string mpirun =
            "mpirun --allow-run-as-root --oversubscribe --bind-to none -np " +
            std::to_string(ranks) + " ";
        return test::run_fogmap(args, dir_, ranks > 0 ? mpirun : "");
    }
    std::string at(const std::string& name) const { return (dir_ / name).string(); }

    test::TempDir tmp_{"fogmap_mpi"};
    const fs::path dir_ = tmp_.path();
};

/// The line of a text report that starts with `key`, up to its rate in parentheses.
std::string report_line(const std::string& out, const std::string& key) {
    const size_t at = out.find("\n" + key);
    if (at == std::string::npos) return "";
    const std::string line = out.substr(at + 1, out.find('\n', at + 1) - at - 1);
    return line.substr(0, line.find(" ("));
}

TEST_F(Mpi, ProgressiveIterationsSplitOverRanksGiveTheSameImage) {
    const std::string scene = std::string(FOGMAP_SOURCE_DIR) + "/scenes/fog.json";
    const std::string args = "render -q " + scene +
                             " --set camera.width=32 --set camera.height=18 --set render.spp=2 "
                             "--set photons.volume=5000 --set photons.global=2000 "
                             "--set progressive.iterations=5 -o ";
    const test::RunResult plain = run(args + at("plain.exr"), 0);
    ASSERT_EQ(plain.code, 0) << plain.err;
    const std::string expected = test::slurp(at("plain.exr"));
    for (int ranks : {1, 2, 3}) {
        SCOPED_TRACE(std::to_string(ranks) + " ranks");
        const std::string exr = at("r" + std::to_string(ranks) + ".exr");
        const test::RunResult r = run(args + exr, ranks);
        ASSERT_EQ(r.code, 0) << r.err;
        EXPECT_TRUE(test::slurp(exr) == expected) << "the EXR differs from the run without MPI";
        EXPECT_EQ(report_line(r.out, "photons emitted"), report_line(plain.out, "photons emitted"));
        EXPECT_EQ(report_line(r.out, "samples"), report_line(plain.out, "samples"));
        if (ranks > 1) {
            EXPECT_NE(r.out.find(std::to_string(ranks) + " MPI ranks"), std::string::npos) << r.out;
        }
    }
}

TEST_F(Mpi, BadInputExitsTwoOnEveryRankCountAndIsSaidOnce) {
    const std::string bad = tmp_.write("bad.json", R"({"render": {"spp": -1}})");
    for (int ranks : {1, 2, 3}) {
        SCOPED_TRACE(std::to_string(ranks) + " ranks");
        const test::RunResult r = run("render -q " + bad + " -o " + at("x.exr"), ranks);
        EXPECT_EQ(r.code, 2) << r.err;
        size_t said = 0;
        for (size_t at = r.err.find("fogmap: error:"); at != std::string::npos;
             at = r.err.find("fogmap: error:", at + 1))
            ++said;
        EXPECT_EQ(said, 1u) << r.err;
        EXPECT_NE(r.err.find("/render/spp: spp must be >= 1"), std::string::npos) << r.err;
        EXPECT_FALSE(fs::exists(at("x.exr")));
    }
}

TEST_F(Mpi, RanksWithATimeBudgetStopTogether) {
    const std::string scene = std::string(FOGMAP_SOURCE_DIR) + "/scenes/fog.json";
    const test::RunResult r =
        run("render -q " + scene +
                " --set camera.width=16 --set camera.height=9 --set render.spp=1 "
                "--set photons.volume=2000 --set photons.global=1000 --time-budget 0.5 -o " +
                at("t.exr"),
            2);
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_TRUE(fs::exists(at("t.exr")));
    EXPECT_NE(r.out.find("2 MPI ranks"), std::string::npos) << r.out;
}

TEST_F(Mpi, AResumedRunEndsWithTheImageOfAnUninterruptedOne) {
    // 16 iterations at once; 6 with checkpoints, then resumed to 16 — at 1 rank, and at 2 ranks
    // resumed at 3; and a run killed (SIGKILL: no clean-up at all) while it writes a checkpoint
    // after every round, resumed.
    const std::string scene = std::string(FOGMAP_SOURCE_DIR) + "/scenes/fog.json";
    const std::string args = "render -q " + scene +
                             " --set camera.width=32 --set camera.height=18 --set render.spp=2 "
                             "--set photons.volume=5000 --set photons.global=2000 -o ";
    ASSERT_EQ(run(args + at("whole.exr") + " --iterations 16", 0).code, 0);
    const std::string expected = test::slurp(at("whole.exr"));
    for (const auto& [first, then] : {std::pair{0, 0}, std::pair{2, 3}}) {
        SCOPED_TRACE(std::to_string(first) + " then " + std::to_string(then) + " ranks");
        const std::string exr = at("r" + std::to_string(first) + ".exr");
        ASSERT_EQ(run(args + exr + " --iterations 6 --checkpoint-every 1000", first).code, 0);
        ASSERT_TRUE(fs::exists(exr + ".checkpoint"));
        EXPECT_FALSE(test::slurp(exr) == expected) << "6 iterations are not 16";
        const test::RunResult r = run(args + exr + " --iterations 16 --resume", then);
        ASSERT_EQ(r.code, 0) << r.err;
        EXPECT_TRUE(test::slurp(exr) == expected) << "the resumed image differs";
    }
    // Killed part way through 48 iterations (about 4 s; the kill comes at 1.5 s, whatever
    // iteration or checkpoint write is under way).
    ASSERT_EQ(run(args + at("whole48.exr") + " --iterations 48", 0).code, 0);
    const std::string exr = at("killed.exr");
    test::run_fogmap(args + exr + " --iterations 48 --checkpoint-every 1e-6", dir_,
                     "timeout -s KILL 1.5 ");
    std::printf("after the kill: checkpoint %s, output %s\n",
                fs::exists(exr + ".checkpoint") ? "yes" : "no", fs::exists(exr) ? "yes" : "no");
    const test::RunResult r = run(args + exr + " --iterations 48 --resume", 0);
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_TRUE(test::slurp(exr) == test::slurp(at("whole48.exr")))
        << "the image resumed after the kill differs";
}

TEST_F(Mpi, SequenceFramesAreDealtToRankGroups) {
    // 3 frames over 2 ranks: the groups {0} and {1} take frames 1, 3 and 2; the images are those
    // of the run without MPI.
    test::write_plume_sequence(dir_, 3);
    const std::string render = "render -q " + at("s.json") + " --frames 1-3 -o ";
    ASSERT_EQ(run(render + at("plain/f.####.exr"), 0).code, 0);
    const test::RunResult r = run(render + at("mpi/f.####.exr"), 2);
    ASSERT_EQ(r.code, 0) << r.err;
    for (const char* f : {"f.0001.exr", "f.0002.exr", "f.0003.exr"}) {
        ASSERT_TRUE(fs::exists(at(std::string("mpi/") + f))) << f;
        EXPECT_TRUE(test::slurp(at(std::string("mpi/") + f)) ==
                    test::slurp(at(std::string("plain/") + f)))
            << f;
    }
}

TEST_F(Mpi, ACheckpointOfOtherSettingsIsRefused) {
    const std::string scene = std::string(FOGMAP_SOURCE_DIR) + "/scenes/fog.json";
    const std::string exr = at("c.exr");
    tmp_.write("c.exr.checkpoint", "fogmap checkpoint 1\n" + std::string(80, '\x01'));
    const test::RunResult r = run("render -q " + scene +
                                      " --set camera.width=8 --set camera.height=6 "
                                      "--set progressive.iterations=2 --resume -o " +
                                      exr,
                                  0);
    EXPECT_EQ(r.code, 2);
    EXPECT_NE(r.err.find("c.exr.checkpoint: --resume: written for another scene"),
              std::string::npos)
        << r.err;
    EXPECT_FALSE(fs::exists(exr));
}

}  // namespace
}  // namespace fogmap
