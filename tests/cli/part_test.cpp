// A run split by `fogmap render --part I/N` over processes that never talk, put together by
// `fogmap merge`: the EXR is the bytes one process writes, and those of `mpirun -np N` — for the
// photon gather, camera paths ending in the volume map (with the map's noise and bias in the
// estimate), the path tracer, progressive iterations (one iteration's own estimate, carried by the
// part that ran it) and a sequence's frames
// — whatever order the parts are given in, and the report counts every part's samples. Parts of
// another run (seed, settings, N), a missing, repeated, corrupt or cut part, and options a part
// cannot take are refused with one line naming the file and field, exit 2, nothing written.

#include "test_support.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <utility>

namespace fogmap {
namespace {

namespace fs = std::filesystem;

class Parts : public ::testing::Test {
protected:
    test::RunResult run(const std::string& args, const std::string& prefix = "") {
        return test::run_fogmap(args, dir_, prefix);
    }
    std::string at(const std::string& name) const { return (dir_ / name).string(); }
    /// Renders `args` in parts 1..n to part<k>.fogpart (prefix `name`) and merges them, given
    /// last to first, to `name`.exr; returns the merge's result.
    test::RunResult render_in_parts(const std::string& args, int n, const std::string& name) {
        std::string parts;
        for (int k = n; k >= 1; --k) {
            const std::string part = at(name + std::to_string(k) + ".fogpart");
            const test::RunResult r = run(args + " --part " + std::to_string(k) + "/" +
                                          std::to_string(n) + " -o " + part);
            EXPECT_EQ(r.code, 0) << r.err;
            parts += " " + part;
        }
        return run("merge" + parts + " -o " + at(name + ".exr"));
    }

    test::TempDir tmp_{"fogmap_parts"};
    const fs::path dir_ = tmp_.path();
};

TEST_F(Parts, MergedPartsAreTheImageOfOneProcess) {
    const std::string fog = std::string(FOGMAP_SOURCE_DIR) + "/scenes/fog.json",
                      smoke = std::string(FOGMAP_SOURCE_DIR) + "/scenes/smoke.json";
    const std::string small = " --set camera.width=40 --set camera.height=24 ";
    // The parts of a plain render sample every pixel alike (adaptive sampling's image-wide sums
    // need the whole image between its passes): one process's image without it. Those of a
    // progressive run allocate across iterations as one process does: each measures every
    // measured iteration, its own or not (iterations 1-4 of 2 spp here, for the fifth).
    const std::string uniform = " --set render.adaptive=false";
    const std::pair<std::string, std::string> cases[] = {
        {fog + small + "--spp 2 --set photons.volume=8000 --set photons.global=3000", uniform},
        {fog + small +
             "--spp 2 --set photons.volume=5000 --iterations 5 "
             "--set advanced.iteration_spp=2",
         ""},
        {smoke + small + "--spp 4", uniform},  // the map's noise and bias halves in the film
        {smoke + small + "--spp 4 --set render.integrator=path", uniform},
        // One iteration: its own estimate, from its batches of samples, carried by its part.
        {smoke + small + "--spp 16 --iterations 1", ""},
    };
    int n = 2;
    for (const auto& [c, alike] : cases) {
        SCOPED_TRACE(c);
        const std::string args = "render -q " + c;
        const test::RunResult one = run(args + alike + " -o " + at("one.exr"));
        ASSERT_EQ(one.code, 0) << one.err;
        const test::RunResult merged = render_in_parts(args, n, "m");
        ASSERT_EQ(merged.code, 0) << merged.err;
        EXPECT_TRUE(test::slurp(at("m.exr")) == test::slurp(at("one.exr")))
            << "the merged EXR differs from one process's";
        for (const char* key : {"samples", "rays", "photons emitted", "error estimate:"})
            EXPECT_EQ(test::report_line(merged.out, key), test::report_line(one.out, key)) << key;
        EXPECT_NE(test::report_line(merged.out, "error estimate:").find("relMSE"),
                  std::string::npos)
            << merged.out;
        EXPECT_NE(merged.out.find(std::to_string(n) + " parts merged"), std::string::npos)
            << merged.out;
        n = n % 4 + 2;  // 2, 3, 4 parts
    }
}

TEST_F(Parts, MergedPartsAreTheImageOfMpirun) {
    ASSERT_EQ(std::system("command -v mpirun >/dev/null"), 0)
        << "mpirun not found: scripts/debian-packages installs openmpi-bin";
    const std::string args = "render -q " + std::string(FOGMAP_SOURCE_DIR) +
                             "/scenes/fog.json --set camera.width=32 --set camera.height=18 "
                             "--set photons.volume=5000 ";
    // A plain render, iterations, and iterations that allocate their own samples (path, 16 spp).
    for (const std::string& c : {std::string("--spp 2"), std::string("--spp 2 --iterations 4"),
                                 std::string("--spp 16 --iterations 3 --set "
                                             "render.integrator=\"path\"")}) {
        SCOPED_TRACE(c);
        const test::RunResult mpi =
            run(args + c + " -o " + at("mpi.exr"),
                "mpirun --allow-run-as-root --oversubscribe --bind-to none -np 3 ");
        ASSERT_EQ(mpi.code, 0) << mpi.err;
        const test::RunResult merged = render_in_parts(args + c, 3, "m");
        ASSERT_EQ(merged.code, 0) << merged.err;
        EXPECT_TRUE(test::slurp(at("m.exr")) == test::slurp(at("mpi.exr")))
            << "the merged EXR differs from mpirun's";
    }
}

TEST_F(Parts, ASequenceIsRenderedInPartsFrameByFrame) {
    test::write_plume_sequence(dir_, 2);
    const std::string args = "render -q " + at("s.json") + " --frames 1-2";
    ASSERT_EQ(run(args + " -o " + at("one.####.exr")).code, 0);
    for (int k = 1; k <= 2; ++k) {
        const test::RunResult r = run(args + " --part " + std::to_string(k) + "/2 -o " +
                                      at("p" + std::to_string(k) + ".####.fogpart"));
        ASSERT_EQ(r.code, 0) << r.err;
    }
    for (const char* f : {"0001", "0002"}) {
        SCOPED_TRACE(f);
        const std::string frame = std::string(".") + f;
        const test::RunResult m =
            run("merge " + at("p2" + frame + ".fogpart") + " " + at("p1" + frame + ".fogpart") +
                " -o " + at("m" + frame + ".exr"));
        ASSERT_EQ(m.code, 0) << m.err;
        EXPECT_TRUE(test::slurp(at("m" + frame + ".exr")) ==
                    test::slurp(at("one" + frame + ".exr")));
    }
}

TEST_F(Parts, PartsOfAnotherRunOrMissingRepeatedOrCorruptAreRefusedByName) {
    const std::string args = "render -q " + std::string(FOGMAP_SOURCE_DIR) +
                             "/scenes/fog.json --set camera.width=32 --set camera.height=18 "
                             "--set render.spp=2 --set photons.volume=3000 --part ";
    const auto part = [&](const std::string& what, const std::string& name) {
        const test::RunResult r = run(args + what + " -o " + at(name));
        EXPECT_EQ(r.code, 0) << r.err;
        return at(name);
    };
    const std::string p1 = part("1/2", "a1.fogpart"), p2 = part("2/2", "a2.fogpart"),
                      seed = part("2/2 --seed 9", "seed.fogpart"),
                      spp = part("2/2 --spp 3", "spp.fogpart"),
                      three = part("2/3", "three.fogpart");
    const std::string good = test::slurp(p2);
    std::string flipped = good;
    flipped[flipped.size() - 100] ^= 0x10;  // in the film
    const std::string corrupt = tmp_.write("corrupt.fogpart", flipped),
                      cut = tmp_.write("cut.fogpart", good.substr(0, good.size() / 2)),
                      format1 = tmp_.write("f1.fogpart", "fogmap part 1\n" + good.substr(14)),
                      format2 = tmp_.write("f2.fogpart", "fogmap part 2\n" + good.substr(14)),
                      old = tmp_.write("m.exr", "an older image");
    struct Case {
        std::string parts, file, field;
    };
    const Case cases[] = {
        {p1, p1, "parts"},                   // part 2 missing
        {p1 + " " + seed, seed, "seed"},     // another seed
        {p1 + " " + spp, spp, "settings"},   // another spp
        {p1 + " " + three, three, "parts"},  // a part of 3
        {p1 + " " + p1, p1, "part"},         // part 1 twice
        {p1 + " " + corrupt, corrupt, "checksum"},
        {p1 + " " + cut, cut, "checksum"},
        {p1 + " " + format1, format1, "format"},  // an older fogmap's
        {p1 + " " + format2, format2, "format"},
        {p1 + " " + at("s.json"), at("s.json"), "size"},  // no such file
        {p1 + " " + std::string(FOGMAP_SOURCE_DIR) + "/scenes/fog.json",
         std::string(FOGMAP_SOURCE_DIR) + "/scenes/fog.json", "format"},
    };
    for (const Case& c : cases) {
        SCOPED_TRACE(c.parts);
        const test::RunResult r = run("merge " + c.parts + " -o " + old);
        EXPECT_EQ(r.code, 2) << r.err;
        EXPECT_NE(r.err.find("fogmap: error: " + c.file + ": " + c.field + ": "), std::string::npos)
            << r.err;
        EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
        EXPECT_EQ(test::slurp(old), "an older image");
        EXPECT_FALSE(fs::exists(at("m.png")));
    }
    const test::RunResult r = run("merge " + p2 + " " + p1 + " -o " + old);
    EXPECT_EQ(r.code, 0) << r.err;
}

TEST_F(Parts, WhatAPartCannotTakeIsRefusedBeforeAnyWork) {
    const std::string args = "render -q " + std::string(FOGMAP_SOURCE_DIR) +
                             "/scenes/fog.json --set camera.width=32 --set camera.height=18 ";
    const std::string part = " -o " + at("p.fogpart");
    const std::pair<std::string, std::string> cases[] = {
        {"--part 0/3", "--part"},
        {"--part 4/3", "--part"},
        {"--part 3", "--part"},
        {"--part 1/x", "--part"},
        {"--part 1/2 -o " + at("x.exr"), "-o"},
        {"--part 1/2 --png " + at("x.png"), "--png"},
        {"--part 1/2 --time-budget 5", "/progressive/time_budget"},
        {"--part 1/2 --target-relmse 0.01", "/progressive/target_relmse"},
        {"--part 1/2 --iterations 3 --checkpoint-every 5", "--checkpoint-every"},
    };
    for (const auto& [options, field] : cases) {
        SCOPED_TRACE(options);
        const bool own_output = options.find(" -o ") != std::string::npos;
        const test::RunResult r = run(args + options + (own_output ? "" : part));
        EXPECT_EQ(r.code, 2) << r.err;
        EXPECT_NE(r.err.find(field + ": "), std::string::npos) << r.err;
        EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    }
    for (const char* name : {"p.fogpart", "x.exr", "x.png"}) EXPECT_FALSE(fs::exists(at(name)));
}

}  // namespace
}  // namespace fogmap
