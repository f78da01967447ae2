// `fogmap bench` pieces against hand-made expectations: the cross product of sweeps, medians,
// the Pareto frontier of a hand-made point set, CSV columns, the SVG plot's structure, and a
// tiny end-to-end run of the fogmap binary (8x6 pixels, a few hundred photons) that writes one
// CSV row per run and a plot, reuses its cached reference, and rejects bad input with exit 2
// without touching an existing CSV. No timing appears in any assertion.

#include "bench/bench.h"
#include "bench/svg_plot.h"

#include "core/image.h"
#include "test_support.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace fogmap {
namespace {

namespace fs = std::filesystem;

std::vector<std::string> split(const std::string& s, char sep) {
    std::vector<std::string> out;
    std::string cur;
    std::istringstream in(s);
    while (std::getline(in, cur, sep)) out.push_back(cur);
    if (!s.empty() && s.back() == sep) out.push_back("");
    return out;
}

/// The index of CSV column `name` in `header` (header.size() when absent).
size_t column(const std::vector<std::string>& header, const std::string& name) {
    return static_cast<size_t>(std::find(header.begin(), header.end(), name) - header.begin());
}

size_t count(const std::string& s, const std::string& needle) {
    size_t n = 0;
    for (size_t p = s.find(needle); p != std::string::npos; p = s.find(needle, p + 1)) ++n;
    return n;
}

TEST(SweepRuns, CrossProductInAxisOrder) {
    const std::vector<SweepAxis> axes = {{"photons.volume", {"1000", "2000"}},
                                         {"volume.k", {"20", "50", "100"}}};
    const std::vector<std::vector<std::string>> expected = {
        {"photons.volume=1000", "volume.k=20"},  {"photons.volume=1000", "volume.k=50"},
        {"photons.volume=1000", "volume.k=100"}, {"photons.volume=2000", "volume.k=20"},
        {"photons.volume=2000", "volume.k=50"},  {"photons.volume=2000", "volume.k=100"}};
    EXPECT_EQ(sweep_runs(axes), expected);
}

TEST(SweepRuns, ThreeAxesGiveEveryCombinationOnce) {
    const std::vector<SweepAxis> axes = {{"a", {"1", "2"}}, {"b", {"x"}}, {"c", {"p", "q"}}};
    const std::vector<std::vector<std::string>> expected = {
        {"a=1", "b=x", "c=p"}, {"a=1", "b=x", "c=q"}, {"a=2", "b=x", "c=p"}, {"a=2", "b=x", "c=q"}};
    EXPECT_EQ(sweep_runs(axes), expected);
}

TEST(SweepRuns, NoAxesIsOneRunWithoutOverrides) {
    const std::vector<std::vector<std::string>> expected = {{}};
    EXPECT_EQ(sweep_runs({}), expected);
}

TEST(Median, OddAndEvenCounts) {
    EXPECT_EQ(median({3.0, 1.0, 2.0}), 2.0);
    EXPECT_EQ(median({4.0, 1.0, 3.0, 2.0}), 2.5);
    EXPECT_EQ(median({7.0}), 7.0);
    EXPECT_EQ(median({}), 0.0);
}

TEST(ParetoFrontier, HandMadePointsGiveExpectedSubset) {
    // index:                     0    1    2    3    4    5    6    7
    const std::vector<double> t = {1.0, 2.0, 2.0, 3.0, 4.0, 0.5, 5.0, 4.0};
    const std::vector<double> e = {0.5, 0.6, 0.3, 0.3, 0.1, 0.9, 0.2, 0.1};
    // 1 is beaten by 0 (faster, lower); 3 ties 2's error but is slower; 6 is beaten by 4;
    // 7 duplicates 4 exactly (the first is kept). Frontier sorted by time: 5, 0, 2, 4.
    const std::vector<size_t> expected = {5, 0, 2, 4};
    EXPECT_EQ(pareto_frontier(t, e), expected);
}

TEST(ParetoFrontier, SameTimeKeepsOnlyTheLowerError) {
    const std::vector<size_t> expected = {1};
    EXPECT_EQ(pareto_frontier({2.0, 2.0}, {0.4, 0.2}), expected);
}

TEST(ParetoFrontier, MonotoneTradeOffKeepsEveryPoint) {
    const std::vector<size_t> expected = {2, 0, 1};
    EXPECT_EQ(pareto_frontier({2.0, 3.0, 1.0}, {0.2, 0.1, 0.3}), expected);
    EXPECT_TRUE(pareto_frontier({}, {}).empty());
}

TEST(BenchCsv, HeaderAndRowsHaveTheSameColumns) {
    const std::vector<std::string> keys = {"photons.volume", "volume.k"};
    const std::string header = bench_csv_header(keys);
    // In rows (clang-format would put the 27 names one to a line).
    // clang-format off
    const std::vector<std::string> expected = {
        "method",          "photons.volume", "volume.k",        "spp",
        "repeats",         "ranks",          "threads",         "load_s",
        "photon_pass_s",   "build_global_s", "build_caustic_s", "build_volume_s",
        "precompute_s",    "render_s",       "photon_exchange_s", "reduce_s",
        "total_s",         "stored_global",  "stored_caustic",  "stored_volume",
        "bytes",           "rmse",           "rel_mse",         "bias",
        "est_rel_mse",     "est_lo",         "est_hi"};
    // clang-format on
    ASSERT_EQ(header.back(), '\n');
    EXPECT_EQ(split(header.substr(0, header.size() - 1), ','), expected);

    BenchRow row;
    row.method = "photon";
    row.swept = {"1000", "[1,2]"};  // a JSON value with commas is quoted
    row.spp = 4;
    row.repeats = 3;
    row.stored = {10, 0, 1000};
    row.bytes = 20000;
    row.rel_mse = 0.25;
    const std::string line = bench_csv_row(row);
    EXPECT_EQ(line.substr(0, 31), "photon,1000,\"[1,2]\",4,3,1,0,0,0");
    EXPECT_NE(line.find(",10,0,1000,20000,0,0.25,0,,,\n"), std::string::npos) << line;
    // Without a reference the measured columns are empty, the estimate's filled.
    row.measured = false;
    row.est_valid = true;
    row.est_rel_mse = 0.5;
    row.est_lo = 0.25;
    row.est_hi = 0.75;
    EXPECT_NE(bench_csv_row(row).find(",20000,,,,0.5,0.25,0.75\n"), std::string::npos)
        << bench_csv_row(row);
    EXPECT_EQ(row.error(), 0.5);
}

TEST(SvgPlot, FrontierIsAPolylineAndTheDocumentIsClosed) {
    LogLogPlot plot;
    plot.title = "a < b & c";
    plot.series.push_back({"runs",
                           "#000",
                           PlotMarker::Circle,
                           PlotLine::None,
                           {{0.5, 0.1}, {2.0, 0.01}, {0.0, 1.0}, {1.0, -1.0}}});
    plot.series.push_back(
        {"frontier", "#f00", PlotMarker::None, PlotLine::Step, {{0.5, 0.1}, {2.0, 0.01}}});
    const std::string svg = svg_log_log(plot);
    EXPECT_EQ(svg.rfind("<svg", 0), 0u);
    EXPECT_EQ(svg.substr(svg.size() - 7), "</svg>\n");
    EXPECT_EQ(count(svg, "<polyline"), 1u);
    EXPECT_EQ(count(svg, "</polyline>"), 1u);
    // Step line through 2 points: start, corner, end, and the extension to the right edge.
    const size_t points = svg.find("points=\"", svg.find("<polyline"));
    const std::string list = svg.substr(points + 8, svg.find('"', points + 8) - points - 8);
    EXPECT_EQ(split(list, ' ').size(), 4u) << list;
    // Two drawable markers plus the legend's; non-positive points are left out.
    EXPECT_EQ(count(svg, "<circle"), 3u);
    EXPECT_NE(svg.find("a &lt; b &amp; c"), std::string::npos);
    EXPECT_EQ(count(svg, "<g"), count(svg, "</g>"));
    EXPECT_EQ(count(svg, "<text"), count(svg, "</text>"));
}

// ---- The fogmap binary on a tiny scene ---------------------------------------------------------

using test::RunResult;
using test::slurp;

class BenchCommand : public ::testing::Test {
protected:
    void SetUp() override {
        // 8x6 pixels, a sun over a ground quad in a homogeneous fog box; a few hundred photons.
        std::ofstream(dir_ / "tiny.json") << R"({
  "camera": {"position": [0, 1, 4], "look_at": [0, 0.5, 0], "width": 8, "height": 6},
  "lights": [{"type": "sun", "direction": [0.3, -1, 0.2], "irradiance": 3},
             {"type": "environment", "radiance": 0.1}],
  "materials": {"ground": {"type": "diffuse", "albedo": 0.5}},
  "shapes": [{"type": "quad", "corner": [-5, 0, -5], "edge_u": [0, 0, 10], "edge_v": [10, 0, 0],
              "material": "ground"}],
  "media": [{"type": "homogeneous", "bounds": {"min": [-1, 0, -1], "max": [1, 1.5, 1]},
             "sigma_s": 0.8, "sigma_a": 0.1, "g": 0.2}],
  "photons": {"global": 200, "caustic": 0, "volume": 300},
  "march": {"step_world": 0.1},
  "render": {"integrator": "photon", "spp": 2, "max_depth": 8, "threads": 1}
})";
    }

    RunResult run(const std::string& args) {
        return test::run_fogmap("bench " + (dir_ / "tiny.json").string() + " " + args, dir_);
    }

    std::string outputs() const {
        return " --csv " + (dir_ / "out" / "b.csv").string() + " --plot " +
               (dir_ / "out" / "b.svg").string();
    }

    test::TempDir tmp_{"fogmap_bench"};
    const fs::path dir_ = tmp_.path();
};

TEST_F(BenchCommand, TinyRunWritesOneCsvRowPerRunAndAPlot) {
    const std::string args =
        "--reference-spp 4 --sweep photons.volume=100,300 --sweep volume.k=5,10 --repeat 2" +
        outputs();
    const RunResult r = run(args + " --path-spp 1,2");
    ASSERT_EQ(r.code, 0) << r.err;

    const std::vector<std::string> lines = split(slurp(dir_ / "out" / "b.csv"), '\n');
    // Header, 2 x 2 photon runs, 2 path runs, and the empty string after the final newline.
    ASSERT_EQ(lines.size(), 8u);
    EXPECT_EQ(lines.back(), "");
    const std::vector<std::string> header = split(lines[0], ',');
    ASSERT_EQ(header.size(), 27u);
    EXPECT_EQ(header[1], "photons.volume");
    EXPECT_EQ(header[2], "volume.k");
    const std::vector<std::vector<std::string>> expected = {
        {"photon", "100", "5"},  {"photon", "100", "10"}, {"photon", "300", "5"},
        {"photon", "300", "10"}, {"path", "", ""},        {"path", "", ""}};
    const auto col = [&](const char* name) { return column(header, name); };
    for (size_t i = 0; i < expected.size(); ++i) {
        const std::vector<std::string> f = split(lines[i + 1], ',');
        ASSERT_EQ(f.size(), header.size()) << lines[i + 1];
        EXPECT_EQ(std::vector<std::string>(f.begin(), f.begin() + 3), expected[i]);
        EXPECT_EQ(f[4], "2");  // repeats
        // Every column holds a value; the estimate's not at 1 sample a pixel (path spp 1).
        for (size_t c = 5; c < f.size(); ++c)
            EXPECT_EQ(f[c].empty(), f[3] == "1" && header[c].rfind("est_", 0) == 0) << header[c];
        EXPECT_EQ(f[col("ranks")], "1");
        const double rel_mse = std::stod(f[col("rel_mse")]);
        EXPECT_TRUE(rel_mse > 0.0 && std::isfinite(rel_mse)) << lines[i + 1];
        if (f[0] == "photon") {
            // the volume map filled its budget; the photon pass was timed
            EXPECT_GE(std::stoi(f[col("stored_volume")]), std::stoi(f[1]));
            EXPECT_GT(std::stod(f[col("photon_pass_s")]), 0.0);
        }
    }
    EXPECT_EQ(split(lines[5], ',')[3], "1");  // path spp
    EXPECT_EQ(split(lines[6], ',')[3], "2");

    const std::string svg = slurp(dir_ / "out" / "b.svg");
    EXPECT_EQ(svg.rfind("<svg", 0), 0u);
    EXPECT_NE(svg.find("</svg>"), std::string::npos);
    EXPECT_GE(count(svg, "<polyline"), 2u);  // frontier and path tracer curve
    EXPECT_NE(svg.find("Pareto frontier"), std::string::npos);
    EXPECT_NE(r.out.find("Pareto frontier"), std::string::npos) << r.out;

    // The cached reference sits beside the CSV and a second run reuses it.
    int cached = 0;
    for (const auto& entry : fs::directory_iterator(dir_ / "out"))
        if (entry.path().extension() == ".exr") ++cached;
    EXPECT_EQ(cached, 1);
    const RunResult again = run(args + " --path-spp none");
    ASSERT_EQ(again.code, 0) << again.err;
    EXPECT_NE(again.err.find("reusing"), std::string::npos) << again.err;
    EXPECT_EQ(split(slurp(dir_ / "out" / "b.csv"), '\n').size(), 6u);
}

TEST_F(BenchCommand, WithoutAReferenceTheRunsOwnEstimatesArePlotted) {
    const RunResult r = run("--sweep photons.volume=100,300 --path-spp 2" + outputs());
    ASSERT_EQ(r.code, 0) << r.err;
    const std::vector<std::string> lines = split(slurp(dir_ / "out" / "b.csv"), '\n');
    ASSERT_EQ(lines.size(), 5u);  // header, 2 photon runs, 1 path run, ""
    const std::vector<std::string> header = split(lines[0], ',');
    for (int i = 1; i <= 3; ++i) {
        const std::vector<std::string> f = split(lines[i], ',');
        ASSERT_EQ(f.size(), header.size()) << lines[i];
        EXPECT_TRUE(f[column(header, "rel_mse")].empty()) << lines[i];
        const double est = std::stod(f[column(header, "est_rel_mse")]);
        EXPECT_GT(est, 0.0) << lines[i];
        EXPECT_LE(std::stod(f[column(header, "est_lo")]), est);
        EXPECT_GE(std::stod(f[column(header, "est_hi")]), est);
    }
    EXPECT_NE(slurp(dir_ / "out" / "b.svg").find("estimated relMSE, no reference"),
              std::string::npos);
    EXPECT_NE(r.out.find("no reference: relMSE is each run's own estimate"), std::string::npos)
        << r.out;
}

TEST_F(BenchCommand, ProgressiveIterationsAreASweepSetting) {
    const RunResult r =
        run("--reference-spp 256 --sweep progressive.iterations=0,1,8 --path-spp none" + outputs());
    ASSERT_EQ(r.code, 0) << r.err;
    const std::vector<std::string> lines = split(slurp(dir_ / "out" / "b.csv"), '\n');
    ASSERT_EQ(lines.size(), 5u);  // header, 3 runs, ""
    const std::vector<std::string> header = split(lines[0], ',');
    EXPECT_EQ(header[1], "progressive.iterations");
    const size_t stored = column(header, "stored_volume"), error = column(header, "rel_mse");
    ASSERT_LT(error, header.size());
    std::vector<double> rel_mse;
    for (int i = 1; i <= 3; ++i) {
        const std::vector<std::string> f = split(lines[i], ',');
        ASSERT_EQ(f.size(), header.size()) << lines[i];
        EXPECT_GE(std::stoi(f[stored]), 300) << lines[i];  // one iteration's volume map
        rel_mse.push_back(std::stod(f[error]));
    }
    // The mean of 8 independent iterations with shrinking radii is closer to the reference than
    // one iteration (the first iteration gathers with fixed radii, not k nearest).
    EXPECT_LT(rel_mse[2], 0.5 * rel_mse[1]);
}

TEST_F(BenchCommand, SweptRunsOfAnAutoSceneUseThePhotonMaps) {
    // Without render.integrator (a sun over a medium) the swept runs measure the photon maps, as
    // the bench's summary says they do, unless they name auto.
    std::string scene = slurp(dir_ / "tiny.json");
    const std::string named = R"("integrator": "photon", )";
    ASSERT_NE(scene.find(named), std::string::npos);
    scene.erase(scene.find(named), named.size());
    std::ofstream(dir_ / "tiny.json") << scene;
    const RunResult r =
        run("--reference-spp 4 --sweep photons.volume=300 --path-spp 1" + outputs());
    ASSERT_EQ(r.code, 0) << r.err;
    const std::vector<std::string> lines = split(slurp(dir_ / "out" / "b.csv"), '\n');
    ASSERT_EQ(lines.size(), 4u);  // header, the swept run, the path run, ""
    const std::vector<std::string> header = split(lines[0], ',');
    const size_t stored = column(header, "stored_volume");
    ASSERT_LT(stored, header.size());
    EXPECT_EQ(split(lines[1], ',')[0], "photon");
    // Closed after 300 attempts (96 camera samples: the rule's floor, its budget) below 300.
    EXPECT_GT(std::stoi(split(lines[1], ',')[stored]), 0);
    EXPECT_EQ(split(lines[2], ',')[0], "path");

    // Named, auto runs as `fogmap render` runs it: here the photon integrator with camera paths
    // ending in the volume map at auto's depth, as the unnamed run above took it (the same map);
    // photon named is the photon gather.
    const RunResult a =
        run("--reference-spp 4 --sweep render.integrator=auto,photon --path-spp none" + outputs());
    ASSERT_EQ(a.code, 0) << a.err;
    const std::vector<std::string> rows = split(slurp(dir_ / "out" / "b.csv"), '\n');
    ASSERT_EQ(rows.size(), 4u);  // header, auto, photon, ""
    EXPECT_EQ(split(rows[1], ',')[0], "photon");
    EXPECT_EQ(split(rows[2], ',')[0], "photon");
    const size_t stored_a = column(split(rows[0], ','), "stored_volume");
    ASSERT_LT(stored_a, split(rows[0], ',').size());
    EXPECT_EQ(split(rows[1], ',')[stored_a], split(lines[1], ',')[stored]);
}

TEST_F(BenchCommand, SceneNamedWithoutAFolderCachesItsReference) {
    // `fogmap bench tiny.json` from the scene's own folder: the reference's cache name hashes
    // the absolute folder, which must not fail for the empty folder of a bare file name.
    const RunResult r = test::run_fogmap(
        "bench tiny.json --reference-spp 4 --sweep volume.k=5 --path-spp none --csv out/c.csv "
        "--plot out/c.svg -q",
        dir_, "cd " + dir_.string() + " && ");
    EXPECT_EQ(r.code, 0) << r.err;
    EXPECT_TRUE(fs::exists(dir_ / "out" / "c.csv"));
}

TEST_F(BenchCommand, BadInputExitsTwoAndLeavesTheOldCsv) {
    fs::create_directories(dir_ / "out");
    std::ofstream(dir_ / "out" / "b.csv") << "old\n";
    const std::vector<std::pair<std::string, std::string>> cases = {
        {"--sweep volume.k", "expected KEY=V1,V2"},
        {"--sweep volume.k=5,,10", "empty value"},
        {"--sweep volume.kk=5", "kk"},
        {"--sweep volume.k=-3", "-3 (from --sweep 'volume.k=-3')"},
        {"--sweep volume.k=5 --sweep volume.k=6", "swept twice"},
        {"--sweep volume.k=5 --path-spp 0", "--path-spp"},
    };
    for (const auto& [args, message] : cases) {
        const RunResult r = run("--reference-spp 4 " + args + outputs());
        EXPECT_EQ(r.code, 2) << args;
        EXPECT_NE(r.err.find("fogmap: error:"), std::string::npos) << r.err;
        EXPECT_NE(r.err.find(message), std::string::npos) << args << ": " << r.err;
    }
    // A reference of the wrong size, a missing one, an output that cannot be written.
    write_exr((dir_ / "small.exr").string(), Image(4, 4));
    const std::vector<std::pair<std::string, std::string>> more = {
        {"--reference " + (dir_ / "small.exr").string() + " --sweep volume.k=5" + outputs(),
         "reference is 4x4"},
        {"--reference " + (dir_ / "missing.exr").string() + " --sweep volume.k=5" + outputs(),
         "missing.exr"},
        {"--reference-spp 4 --sweep volume.k=5 --csv " + (dir_ / "tiny.json" / "b.csv").string() +
             " --plot " + (dir_ / "out" / "b.svg").string(),
         "--csv"},
    };
    for (const auto& [args, message] : more) {
        const RunResult r = run(args);
        EXPECT_EQ(r.code, 2) << args;
        EXPECT_NE(r.err.find(message), std::string::npos) << args << ": " << r.err;
    }
    EXPECT_EQ(slurp(dir_ / "out" / "b.csv"), "old\n");
    EXPECT_FALSE(fs::exists(dir_ / "out" / "b.svg"));
}

}  // namespace
}  // namespace fogmap
