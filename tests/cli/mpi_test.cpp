// mpirun with 1, 2 and 3 ranks (oversubscribed, unbound, allowed as root): a progressive render
// splits its iterations over the ranks, a plain one its photons and tiles, and both give the
// same EXR, bit for bit, as fogmap without mpirun; the photon counts add up to the same totals;
// a crashed rank ends the job without output; `bench --ranks` runs each setting per rank count; bad
// input exits 2 on every rank count with the error said once, also when only one rank cannot read
// a file or another frame group meets a bad frame; warnings are said once; ranks with a time
// budget stop together; a run resumed from its checkpoint (at any rank count, also after a SIGKILL) ends with
// the image of an uninterrupted run.

#include "core/image.h"
#include "core/timer.h"
#include "media/volume_gen.h"
#include "test_support.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <initializer_list>
#include <sstream>
#include <string>
#include <vector>

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
    /// `args` followed by an output path, run at each of `ranks` rank counts: each must exit 0
    /// and write `expected`'s bytes (one process's EXR); `check` (may do nothing) sees each run.
    template <class Check>
    void expect_same_exr(const std::string& args, const std::string& expected,
                         std::initializer_list<int> ranks, Check&& check) {
        const std::string bytes = test::slurp(expected);
        for (int n : ranks) {
            SCOPED_TRACE(std::to_string(n) + " ranks");
            const std::string exr = at("ranks" + std::to_string(n) + ".exr");
            const test::RunResult r = run(args + exr, n);
            ASSERT_EQ(r.code, 0) << r.err;
            EXPECT_TRUE(test::slurp(exr) == bytes) << "the EXR differs from one process's";
            check(r, n);
        }
    }

    test::TempDir tmp_{"fogmap_mpi"};
    const fs::path dir_ = tmp_.path();
};

/// How many times `what` occurs in `text`.
size_t occurrences(const std::string& text, const std::string& what) {
    size_t n = 0;
    for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
    return n;
}

/// The rows of a CSV file without quoted fields, split at commas.
std::vector<std::vector<std::string>> read_csv(const std::string& path) {
    std::vector<std::vector<std::string>> rows;
    std::istringstream in(test::slurp(path));
    for (std::string line; std::getline(in, line);) {
        rows.emplace_back();
        std::istringstream fields(line);
        for (std::string f; std::getline(fields, f, ',');) rows.back().push_back(f);
    }
    return rows;
}

TEST_F(Mpi, ProgressiveIterationsSplitOverRanksGiveTheSameImage) {
    const std::string scene = std::string(FOGMAP_SOURCE_DIR) + "/scenes/fog.json";
    const std::string args = "render -q " + scene +
                             " --set camera.width=32 --set camera.height=18 --set render.spp=2 "
                             "--set photons.volume=5000 --set photons.global=2000 "
                             "--set progressive.iterations=5 -o ";
    const test::RunResult plain = run(args + at("plain.exr"), 0);
    ASSERT_EQ(plain.code, 0) << plain.err;
    expect_same_exr(args, at("plain.exr"), {1, 2, 3}, [&](const test::RunResult& r, int ranks) {
        EXPECT_EQ(test::report_line(r.out, "photons emitted"),
                  test::report_line(plain.out, "photons emitted"));
        EXPECT_EQ(test::report_line(r.out, "samples"), test::report_line(plain.out, "samples"));
        if (ranks > 1) {
            EXPECT_NE(r.out.find(std::to_string(ranks) + " MPI ranks"), std::string::npos) << r.out;
        }
    });
}

TEST_F(Mpi, ATargetStopsAtTheSameIterationOnEveryRankCount) {
    // The looks at 8, 16, 32 iterations decide from the sums of exactly those iterations: the
    // stop, the image and its variance layer are those of one process at 1, 2 and 3 ranks.
    const std::string scene = std::string(FOGMAP_SOURCE_DIR) + "/scenes/smoke.json";
    const std::string args = "render -q " + scene +
                             " --set camera.width=32 --set camera.height=18 --set render.spp=2 "
                             "--set render.integrator=path --target-relmse 0.005 -o ";
    const test::RunResult plain = run(args + at("plain.exr"), 0);
    ASSERT_EQ(plain.code, 0) << plain.err;
    const std::string reached = test::report_line(plain.out, "error estimate: target");
    ASSERT_NE(reached.find("reached after 16 iterations"), std::string::npos) << plain.out;
    expect_same_exr(args, at("plain.exr"), {1, 2, 3}, [&](const test::RunResult& r, int) {
        EXPECT_EQ(test::report_line(r.out, "error estimate: target"), reached);
    });
}

TEST_F(Mpi, AutosSwitchToThePathTracerIsTheSameOnEveryRankCount) {
    // A target the photon run's bias² puts out of reach (eight times smoke.json's volume radius):
    // every rank learns it at the look and renders with the path tracer; the image is one
    // process's at 2 and 3 ranks.
    const std::string scene = std::string(FOGMAP_SOURCE_DIR) + "/scenes/smoke.json";
    const std::string args = "render -q " + scene +
                             " --set camera.width=80 --set camera.height=45 --set render.spp=4 "
                             "--set render.integrator=auto --set volume.radius=0.688 "
                             "--set progressive.iterations=16 --target-relmse 1e-7 -o ";
    const test::RunResult plain = run(args + at("plain.exr"), 0);
    ASSERT_EQ(plain.code, 0) << plain.err;
    ASSERT_NE(plain.out.find("integrator: path (auto: photon mapping's bias² alone"),
              std::string::npos)
        << plain.out;
    expect_same_exr(args, at("plain.exr"), {2, 3}, [](const test::RunResult&, int) {});
}

TEST_F(Mpi, PlainRendersAreSharedOverRanksAndGiveTheSameImage) {
    // Every rank traces every n-th chunk of each photon round and renders every n-th tile; the
    // EXR is that of one process, for the photon maps (with points and with photon beams, which
    // the ranks exchange beside the photons; seen from camera rays and ending camera paths), the
    // guided and the path tracer; and the photon gather at 8 spp, whose adaptive sampling
    // exchanges the image-wide sums between its passes.
    const std::string scene = std::string(FOGMAP_SOURCE_DIR) + "/scenes/fog.json";
    for (const char* integrator :
         {"photon", "photon --set volume.estimator=photon_beams",
          "photon --set volume.gather_depth=2", "guided", "path", "photon --set render.spp=8"}) {
        const std::string args = "render -q " + scene +
                                 " --set camera.width=40 --set camera.height=24 --set "
                                 "render.spp=2 --set photons.volume=8000 --set "
                                 "photons.global=3000 --set render.integrator=" +
                                 integrator + " -o ";
        const test::RunResult plain = run(args + at("plain.exr"), 0);
        ASSERT_EQ(plain.code, 0) << plain.err;
        SCOPED_TRACE(integrator);
        expect_same_exr(args, at("plain.exr"), {1, 2, 3}, [&](const test::RunResult& r, int) {
            for (const char* line : {"photons emitted", "samples", "rays"})
                EXPECT_EQ(test::report_line(r.out, line), test::report_line(plain.out, line));
        });
    }
}

// Films are reduced in chunks (MPI counts are ints); with FOGMAP_MPI_CHUNK the chunk is made
// small and uneven against the film, so a 2- and 3-rank render of a layered film spans many
// chunks and a short last one, and must still give one process's EXR bit for bit (plain renders
// reduce the films' bits; progressive runs their fixed-point sums).
TEST_F(Mpi, FilmsReducedInManyChunksGiveOneProcesssImage) {
    const std::string scene = std::string(FOGMAP_SOURCE_DIR) + "/scenes/fog.json";
    for (const char* run_kind : {"--spp 2", "--iterations 3"}) {
        const std::string args = "render -q " + scene +
                                 " --set camera.width=40 --set camera.height=24 --set "
                                 "photons.volume=8000 --set photons.global=3000 " +
                                 run_kind + " -o ";
        const test::RunResult plain = run(args + at("one.exr"), 0);
        ASSERT_EQ(plain.code, 0) << plain.err;
        for (int ranks : {2, 3}) {
            SCOPED_TRACE(std::string(run_kind) + ", " + std::to_string(ranks) + " ranks");
            const std::string exr = at("chunked" + std::to_string(ranks) + ".exr");
            const test::RunResult r = test::run_fogmap(
                args + exr, dir_,
                "FOGMAP_MPI_CHUNK=997 mpirun --allow-run-as-root --oversubscribe --bind-to none "
                "-x FOGMAP_MPI_CHUNK -np " +
                    std::to_string(ranks) + " ");
            ASSERT_EQ(r.code, 0) << r.err;
            EXPECT_TRUE(test::slurp(exr) == test::slurp(at("one.exr")))
                << "the EXR differs from one process's";
        }
    }
}

// Ranks that disagree at start-up end together with one error: a scene missing on rank 1 only
// (named with its rank), other --iterations on rank 1, or another file behind the same relative
// path (each rank in its own folder) — never a hang, never one image mixed from two renders.
TEST_F(Mpi, RanksThatDisagreeAtStartUpEndTogetherWithOneError) {
    ASSERT_EQ(test::run_fogmap("volume plume --resolution 12 -o " + at("a/p.vdb"), dir_).code, 0);
    ASSERT_EQ(
        test::run_fogmap("volume plume --resolution 12 --seed 2 -o " + at("b/p.vdb"), dir_).code,
        0);
    const std::string scene = R"({
      "camera": {"position": [0, 1, 5], "look_at": [0, 1, 0], "width": 8, "height": 6},
      "lights": [{"type": "point", "intensity": 20, "position": [0, 4, 2]}],
      "media": [{"type": "vdb", "file": "p.vdb", "sigma_s": 5, "sigma_a": 0.5}],
      "render": {"integrator": "photon", "spp": 2}, "photons": {"volume": 2000}})";
    tmp_.write("a/s.json", scene);
    tmp_.write("b/s.json", scene);
    // Rank 1 runs its own command line (sh picks it by Open MPI's rank variable).
    const auto per_rank = [&](const std::string& rank0, const std::string& rank1) {
        const std::string script =
            "if [ \"$OMPI_COMM_WORLD_RANK\" = 1 ]; then " + rank1 + "; else " + rank0 + "; fi";
        tmp_.write("ranks.sh", script);
        // run_fogmap appends the binary's path (the script ignores it) and the redirections.
        return test::run_fogmap("", dir_,
                                "timeout 120 mpirun --allow-run-as-root --oversubscribe "
                                "--bind-to none -np 2 sh " +
                                    at("ranks.sh") + " ");
    };
    const std::string fogmap = FOGMAP_BINARY;
    const std::string render = fogmap + " render -q --progressive --iterations 2 ";
    struct Case {
        const char* what;
        std::string rank0, rank1, error;
    };
    const Case cases[] = {
        {"scene missing on rank 1", render + at("a/s.json") + " -o " + at("o1.exr"),
         render + at("a/gone.json") + " -o " + at("o1.exr"), "(on MPI rank 1)"},
        {"other iterations", render + at("a/s.json") + " -o " + at("o2.exr"),
         fogmap + " render -q --progressive --iterations 3 " + at("a/s.json") + " -o " +
             at("o2.exr"),
         "MPI rank 1 was given another render than rank 0"},
        {"another file behind the path",
         "cd " + at("a") + " && " + render + "s.json -o " + at("o3.exr"),
         "cd " + at("b") + " && " + render + "s.json -o " + at("o3.exr"),
         "MPI rank 1 was given another render than rank 0"},
    };
    for (const Case& c : cases) {
        SCOPED_TRACE(c.what);
        const test::RunResult r = per_rank(c.rank0, c.rank1);
        EXPECT_EQ(r.code, 2) << r.err;
        EXPECT_NE(r.err.find(c.error), std::string::npos) << r.err;
        EXPECT_EQ(occurrences(r.err, "fogmap: error:"), 1u) << r.err;
    }
    EXPECT_FALSE(fs::exists(at("o1.exr")) || fs::exists(at("o2.exr")) || fs::exists(at("o3.exr")));
}

TEST_F(Mpi, ACrashedRankEndsTheJobAndLeavesNoOutput) {
    // Rank 1 of a 60 s run gets SIGSEGV once it is under way: the job must end (well before the
    // budget) with a failure, and rank 0 must leave neither the image nor a temp file behind.
    const std::string scene = std::string(FOGMAP_SOURCE_DIR) + "/scenes/fog.json";
    const std::string exr = at("crash.exr");
    const std::string cmd =
        "cd " + dir_.string() +
        " && (timeout 100 mpirun --allow-run-as-root --oversubscribe --bind-to none -np 2 " +
        FOGMAP_BINARY + " render -q " + scene +
        " --set camera.width=64 --set camera.height=36 --progressive --time-budget 60 -o " + exr +
        " >out.txt 2>err.txt & m=$!; "
        // rank 1: the process whose command line names this output and whose environment
        // says OMPI_COMM_WORLD_RANK=1 (procps may be missing: /proc is read directly)
        "for i in $(seq 300); do for e in /proc/[0-9]*/environ; do "
        "if tr '\\0' '\\n' <$e 2>/dev/null | grep -qx OMPI_COMM_WORLD_RANK=1 && "
        "tr '\\0' ' ' <${e%environ}cmdline 2>/dev/null | grep -q " +
        exr +
        "; then "
        "d=${e%/environ}; sleep 2; kill -SEGV ${d#/proc/}; break 2; fi; done 2>/dev/null; sleep "
        "0.1; done; "
        "wait $m; echo $? >rc.txt)";
    const Timer timer;
    ASSERT_EQ(std::system(cmd.c_str()), 0);
    const double seconds = timer.seconds();
    const int rc = std::stoi(test::slurp(at("rc.txt")));
    EXPECT_NE(rc, 0) << test::slurp(at("err.txt"));
    EXPECT_NE(rc, 124) << "the job did not end after the crash";
    EXPECT_LT(seconds, 50.0) << "the job ran on after the crash";
    for (const auto& entry : fs::directory_iterator(dir_))
        EXPECT_EQ(entry.path().filename().string().rfind("crash", 0), std::string::npos)
            << "left behind: " << entry.path();
}

TEST_F(Mpi, BenchComparesRankCountsOnTheSameImages) {
    // `mpirun -np 2 fogmap bench --ranks 1,2`: every setting at 1 rank (rank 1 sleeping) and at
    // 2; the images are the same, so are their errors; the threads per rank share the cores.
    const std::string scene = std::string(FOGMAP_SOURCE_DIR) + "/scenes/fog.json";
    const std::string bench = "bench -q " + scene +
                              " --set camera.width=24 --set camera.height=16 --set render.spp=1 "
                              "--sweep photons.volume=3000 --set photons.global=1000 "
                              "--path-spp 2 --reference-spp 4 --csv " +
                              at("b/b.csv") + " --plot " + at("b/b.svg");
    const test::RunResult r = run(bench + " --ranks 1,2", 2);
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_NE(r.out.find("Across rank counts"), std::string::npos) << r.out;
    const std::vector<std::vector<std::string>> rows = read_csv(at("b/b.csv"));
    ASSERT_EQ(rows.size(), 5u);  // header, photon at 1 and 2 ranks, path at 1 and 2 ranks
    const std::vector<std::string>& h = rows[0];
    auto col = [&](const char* name) { return std::find(h.begin(), h.end(), name) - h.begin(); };
    for (size_t i : {1, 3}) {
        EXPECT_EQ(rows[i][col("ranks")], "1");
        EXPECT_EQ(rows[i + 1][col("ranks")], "2");
        EXPECT_GE(std::stoi(rows[i][col("threads")]), std::stoi(rows[i + 1][col("threads")]));
        EXPECT_EQ(rows[i][col("rel_mse")], rows[i + 1][col("rel_mse")]) << "row " << i;
        EXPECT_GT(std::stod(rows[i + 1][col("reduce_s")]), 0.0);
    }
    const test::RunResult too_many = run(bench + " --ranks 3", 2);
    EXPECT_EQ(too_many.code, 2);
    EXPECT_NE(too_many.err.find("--ranks: '3' in '3': this job has 2 ranks"), std::string::npos)
        << too_many.err;
    const test::RunResult alone = run(bench + " --ranks 2", 0);
    EXPECT_EQ(alone.code, 2);
    EXPECT_NE(alone.err.find("mpirun -np 2"), std::string::npos) << alone.err;
}

TEST_F(Mpi, BadInputExitsTwoOnEveryRankCountAndIsSaidOnce) {
    const std::string bad = tmp_.write("bad.json", R"({"render": {"spp": -1}})");
    for (int ranks : {1, 2, 3}) {
        SCOPED_TRACE(std::to_string(ranks) + " ranks");
        const test::RunResult r = run("render -q " + bad + " -o " + at("x.exr"), ranks);
        EXPECT_EQ(r.code, 2) << r.err;
        EXPECT_EQ(occurrences(r.err, "fogmap: error:"), 1u) << r.err;
        EXPECT_NE(r.err.find("/render/spp: spp must be >= 1"), std::string::npos) << r.err;
        EXPECT_FALSE(fs::exists(at("x.exr")));
    }
}

TEST_F(Mpi, WarningsAreSaidOnce) {
    // A grid with negative densities: loading sets them to 0 and warns, on every rank, but the
    // warning is printed by rank 0 alone.
    const std::string vdb = at("neg.vdb");
    write_float_grid(
        vdb, "density", 8, 8, 8, [](int x, int, int) { return x == 0 ? -1.0f : 1.0f; }, Vec3(0.1f));
    const std::string scene = tmp_.write("neg.json", R"({
  "camera": {"position": [0.4, 0.4, 3], "look_at": [0.4, 0.4, 0], "width": 8, "height": 6},
  "lights": [{"type": "sun", "direction": [0, -1, 0], "irradiance": 1}],
  "media": [{"type": "vdb", "file": "neg.vdb", "sigma_s": 5, "sigma_a": 1}],
  "render": {"integrator": "path", "spp": 1}
})");
    for (int ranks : {0, 2, 3}) {
        SCOPED_TRACE(std::to_string(ranks) + " ranks");
        const test::RunResult r = run("render -q " + scene + " -o " + at("neg.exr"), ranks);
        ASSERT_EQ(r.code, 0) << r.err;
        EXPECT_EQ(occurrences(r.err, "64 negative"), 1u) << r.err;
    }
}

TEST_F(Mpi, InputOneRankCannotReadEndsEveryRank) {
    // Rank 1 starts in a folder without the scene's VDB file (a file missing on one machine):
    // every rank exits with 2 and the error, naming the rank, is said once; no hang, no output.
    test::write_plume_sequence(dir_, 1);
    fs::create_directories(at("other/vol"));
    fs::copy_file(at("s.json"), at("other/s.json"));
    const std::string pattern = "vol/p.####.vdb";
    std::string json = test::slurp(at("s.json"));
    json.replace(json.find(pattern), pattern.size(), "vol/p.0001.vdb");
    test::spit(at("s.json"), json);
    test::spit(at("other/s.json"), json);
    const std::string cmd =
        "timeout 100 mpirun --allow-run-as-root --oversubscribe --bind-to none -np 2 sh -c "
        "'if [ \"$OMPI_COMM_WORLD_RANK\" = 1 ]; then cd " +
        at("other") + "; else cd " + dir_.string() + "; fi; exec " + FOGMAP_BINARY +
        " render -q s.json -o " + at("d.exr") + "' >" + at("out.txt") + " 2>" + at("err.txt");
    const int status = std::system(cmd.c_str());
    ASSERT_TRUE(WIFEXITED(status));
    EXPECT_EQ(WEXITSTATUS(status), 2);
    const std::string err = test::slurp(at("err.txt"));
    EXPECT_EQ(err.find("fogmap: error:"), err.rfind("fogmap: error:")) << err;
    EXPECT_NE(err.find("vol/p.0001.vdb"), std::string::npos) << err;
    EXPECT_NE(err.find("(on MPI rank 1)"), std::string::npos) << err;
    EXPECT_FALSE(fs::exists(at("d.exr")));
}

TEST_F(Mpi, ABadFrameOfAnotherGroupEndsTheJob) {
    // 3 frames on 2 ranks: frame 2 (group {1}) is a truncated VDB. Its group says so once and
    // ends the job with 2 (MPI_Abort), while group {0} was rendering frames 1 and 3.
    test::write_plume_sequence(dir_, 3);
    const std::string whole = test::slurp(at("vol/p.0002.vdb"));
    test::spit(at("vol/p.0002.vdb"), whole.substr(0, 300));
    const test::RunResult r =
        run("render -q " + at("s.json") + " --frames 1-3 -o " + at("out/f.####.exr"), 2);
    EXPECT_EQ(r.code, 2) << r.err;
    EXPECT_EQ(r.err.find("fogmap: error:"), r.err.rfind("fogmap: error:")) << r.err;
    EXPECT_NE(r.err.find("truncated VDB file"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("(frame 2)"), std::string::npos) << r.err;
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

TEST_F(Mpi, IterationsAllocatingTheirOwnSamplesGiveTheSameImageAtAnyRankCount) {
    // Camera paths ending in the volume map, 16 spp an iteration: iteration 1 allocates its own
    // samples (a rank runs it whole) and its first pass measures for the later ones, whose counts
    // every rank takes from that measure, so the ranks' sum is the lone process's, and its
    // samples layer adds each pixel's counts.
    const std::string args = "render -q --json " + std::string(FOGMAP_SOURCE_DIR) +
                             "/scenes/smoke.json --set camera.width=32 --set camera.height=18 "
                             "--set render.spp=16 --set render.integrator=\"photon\" "
                             "--set volume.gather_depth=3 --set photons.volume=5000 "
                             "--set progressive.iterations=3 -o ";
    const test::RunResult plain = run(args + at("plain.exr"), 0);
    ASSERT_EQ(plain.code, 0) << plain.err;
    EXPECT_TRUE(nlohmann::json::parse(plain.out)["settings"]["render"]["adaptive"].get<bool>());
    const Image samples = read_exr(at("plain.exr"), "samples");
    const auto [least, most] =
        std::minmax_element(samples.pixels.begin(), samples.pixels.end(),
                            [](const Color& a, const Color& b) { return a.x < b.x; });
    EXPECT_LT(least->x, most->x) << "every pixel took the same samples";
    EXPECT_GE(least->x, 8.0f + 2.0f * 4.0f);  // iteration 1's first pass, then a unit (4) each
    expect_same_exr(args, at("plain.exr"), {2, 3}, [](const test::RunResult&, int) {});
}

TEST_F(Mpi, AResumedRunEndsWithTheImageOfAnUninterruptedOne) {
    // 16 iterations at once; 6 with checkpoints, then resumed to 16 — at 1 rank, and at 2 ranks
    // resumed at 3; and a run killed (SIGKILL: no clean-up at all) while it writes a checkpoint
    // after every round, resumed. The resumed runs' error estimates, their bias part from the
    // checkpoint's bias halves, are the uninterrupted run's too.
    const std::string scene = std::string(FOGMAP_SOURCE_DIR) + "/scenes/fog.json";
    const std::string args = "render -q " + scene +
                             " --set camera.width=32 --set camera.height=18 --set render.spp=2 "
                             "--set photons.volume=5000 --set photons.global=2000 -o ";
    const auto estimate = [](const test::RunResult& r) {
        return nlohmann::json::parse(r.out)["error_estimate"].dump();
    };
    const test::RunResult whole = run(args + at("whole.exr") + " --iterations 16 --json", 0);
    ASSERT_EQ(whole.code, 0) << whole.err;
    const std::string expected = test::slurp(at("whole.exr"));
    const std::string expected_estimate = estimate(whole);
    EXPECT_NE(expected_estimate.find("\"bias2\":{"), std::string::npos) << expected_estimate;
    for (const auto& [first, then] : {std::pair{0, 0}, std::pair{2, 3}}) {
        SCOPED_TRACE(std::to_string(first) + " then " + std::to_string(then) + " ranks");
        const std::string exr = at("r" + std::to_string(first) + ".exr");
        ASSERT_EQ(run(args + exr + " --iterations 6 --checkpoint-every 1000", first).code, 0);
        ASSERT_TRUE(fs::exists(exr + ".checkpoint"));
        EXPECT_FALSE(test::slurp(exr) == expected) << "6 iterations are not 16";
        const test::RunResult r = run(args + exr + " --iterations 16 --resume --json", then);
        ASSERT_EQ(r.code, 0) << r.err;
        EXPECT_TRUE(test::slurp(exr) == expected) << "the resumed image differs";
        EXPECT_EQ(estimate(r), expected_estimate);
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
    // 3 frames over 1, 2 and 3 ranks: the groups ({0, 1, 2}; {0}, {1}; {0}, {1}, {2}) take the
    // frames round-robin, a group of several ranks shares each of its frames; the images are
    // those of the run without MPI. A missing frame file is named once, exit 2, on any count.
    test::write_plume_sequence(dir_, 3);
    const std::string render = "render -q " + at("s.json") + " --frames 1-3 -o ";
    ASSERT_EQ(run(render + at("plain/f.####.exr"), 0).code, 0);
    for (int ranks : {1, 2, 3}) {
        SCOPED_TRACE(std::to_string(ranks) + " ranks");
        const std::string out = "mpi" + std::to_string(ranks) + "/";
        const test::RunResult r = run(render + at(out + "f.####.exr"), ranks);
        ASSERT_EQ(r.code, 0) << r.err;
        for (const char* f : {"f.0001.exr", "f.0002.exr", "f.0003.exr"}) {
            ASSERT_TRUE(fs::exists(at(out + f))) << f;
            EXPECT_TRUE(test::slurp(at(out + f)) == test::slurp(at(std::string("plain/") + f)))
                << f;
        }
    }
    fs::remove(at("vol/p.0002.vdb"));
    for (int ranks : {2, 3}) {
        SCOPED_TRACE(std::to_string(ranks) + " ranks, frame 2 missing");
        const test::RunResult r = run(render + at("gone/f.####.exr"), ranks);
        EXPECT_EQ(r.code, 2);
        EXPECT_NE(r.err.find("frame 2 of --frames 1-3"), std::string::npos) << r.err;
        EXPECT_EQ(r.err.find("fogmap: error:"), r.err.rfind("fogmap: error:")) << r.err;
        EXPECT_FALSE(fs::exists(at("gone")));
    }
}

TEST_F(Mpi, ACheckpointOfOtherSettingsIsRefused) {
    const std::string scene = std::string(FOGMAP_SOURCE_DIR) + "/scenes/fog.json";
    const std::string exr = at("c.exr");
    tmp_.write("c.exr.checkpoint", "fogmap checkpoint 7\n" + std::string(80, '\x01'));
    const test::RunResult r = run("render -q " + scene +
                                      " --set camera.width=8 --set camera.height=6 "
                                      "--set progressive.iterations=2 --resume -o " +
                                      exr,
                                  0);
    EXPECT_EQ(r.code, 2);
    EXPECT_NE(r.err.find("c.exr.checkpoint: fingerprint: written for another scene"),
              std::string::npos)
        << r.err;
    EXPECT_FALSE(fs::exists(exr));
}

}  // namespace
}  // namespace fogmap
