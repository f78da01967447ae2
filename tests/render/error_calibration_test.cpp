// Calibration of the error estimate (render/error_estimate.h) against references: each run's
// true relMSE against a high-sample path-traced reference of the same scene (less the
// reference's own estimated relMSE, which adds to it), beside its estimate
// and 95% interval; over seeds, how often the interval's upper bound holds the truth and the
// median ratio estimate / truth. The default tests take one small case; the study
// (ErrorCalibrationHeavy, label heavy) takes four scenes x two integrators x three sample counts
// x 20 seeds and writes its table (CSV) and plot (SVG) to the working folder
// (docs/error-estimate.md shows them).

#include "bench/svg_plot.h"
#include "render/metrics.h"
#include "render/pipeline.h"
#include "scene/scene_desc_json.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <string>
#include <vector>

namespace fogmap {
namespace {

struct Case {
    std::string scene;          ///< under the source folder
    int width = 0, height = 0;  ///< 0: the scene's
    int reference_spp = 0;
    std::vector<std::string> runs;  ///< settings of the calibrated runs (not the reference's)
};

struct Run {
    double truth = 0.0, estimate = 0.0, hi = 0.0;
    bool tail = false;
};

struct Row {
    std::string scene, integrator;
    int spp = 0, runs = 0, covered = 0, tails = 0;
    /// Runs whose reference's own error is above a quarter of the error measured against it: the
    /// reference cannot tell their truth (fog.json's photon gather against 4096 spp of the path
    /// tracer, whose fireflies are most of the error measured from 16 spp on).
    int unresolved = 0;
    double median_ratio = 0.0;
    std::vector<Run> points;
};

std::vector<std::string> size_overrides(const Case& c) {
    if (c.width == 0) return {};
    return {"camera.width=" + std::to_string(c.width), "camera.height=" + std::to_string(c.height)};
}

/// A reference image and its own estimated relMSE, which adds to every error measured against
/// it (its noise is independent of the runs').
struct Reference {
    Image image;
    double own = 0.0;
};

/// The path-traced reference of `c`, rendered once per test program.
const Reference& reference(const Case& c) {
    static std::map<std::string, Reference> made;
    const std::string key =
        c.scene + " " + std::to_string(c.width) + " " + std::to_string(c.reference_spp);
    if (made.count(key)) return made[key];
    std::vector<std::string> o = size_overrides(c);
    o.push_back("render.integrator=\"path\"");
    o.push_back("render.spp=" + std::to_string(c.reference_spp));
    o.push_back("render.seed=987654321");
    const std::string path = std::string(FOGMAP_SOURCE_DIR) + "/" + c.scene;
    const PipelineResult r = run_pipeline(load_scene_desc(path, o), true);
    return made[key] = Reference{r.film.beauty, r.report.error.rel_mse};
}

/// `seeds` runs of `integrator` ("" = the scene's) at `spp` against `ref`: the truth is the
/// relMSE against it less its own.
Row calibrate(const Case& c, const Reference& ref, const std::string& integrator, int spp,
              int seeds) {
    Row row{c.scene, integrator.empty() ? "default" : integrator, spp};
    std::vector<double> ratios;
    for (int seed = 1; seed <= seeds; ++seed) {
        std::vector<std::string> o = size_overrides(c);
        o.insert(o.end(), c.runs.begin(), c.runs.end());
        if (!integrator.empty()) o.push_back("render.integrator=\"" + integrator + "\"");
        o.push_back("render.spp=" + std::to_string(spp));
        o.push_back("render.seed=" + std::to_string(seed));
        const std::string path = std::string(FOGMAP_SOURCE_DIR) + "/" + c.scene;
        const PipelineResult r = run_pipeline(load_scene_desc(path, o), true);
        const ErrorReport& e = r.report.error;
        EXPECT_TRUE(e.valid) << c.scene << " " << spp << " spp";
        const double measured = image_error(r.film.beauty, ref.image).rel_mse;
        const Run run{measured - ref.own, e.rel_mse, e.hi, e.tail};
        row.unresolved += ref.own > 0.25 * measured;
        row.covered += run.truth <= run.hi;
        row.tails += run.tail;
        ratios.push_back(run.estimate / run.truth);
        row.points.push_back(run);
        ++row.runs;
    }
    std::sort(ratios.begin(), ratios.end());
    row.median_ratio = 0.5 * (ratios[(ratios.size() - 1) / 2] + ratios[ratios.size() / 2]);
    std::printf(
        "%s %s %d spp: truth below the upper bound in %d / %d, median estimate / truth "
        "%.3f, tail flag in %d, the reference's own error above a quarter of the measured in %d\n",
        row.scene.c_str(), row.integrator.c_str(), spp, row.covered, row.runs, row.median_ratio,
        row.tails, row.unresolved);
    return row;
}

const Case kSmoke{"scenes/smoke.json", 160, 90, 1024};

TEST(ErrorCalibration, SmokeOfThePathTracerAndTheDefaultAt8Spp) {
    const Case& smoke = kSmoke;
    const Reference& ref = reference(smoke);
    for (const std::string integrator : {"path", ""}) {
        const Row row = calibrate(smoke, ref, integrator, 8, 20);
        EXPECT_GE(row.covered, 18) << row.integrator;
        EXPECT_GE(row.median_ratio, 0.8) << row.integrator;
        EXPECT_LE(row.median_ratio, 1.25) << row.integrator;
    }
}

// A run of iterations that allocate their samples adaptively (16 spp each: iteration 1 measures,
// the 7 others take its counts): the sum weighs each iteration's pixel by its samples there, and
// its estimate from the iterations' batches holds the truth as a plain render's does.
/// smoke.json at 160 x 90 with `runs`, 10 seeds of `integrator` at `spp`: the truth below the
/// upper bound in at least 8, the median estimate / truth within [0.75, 1.33].
void expect_smoke_calibrated(std::vector<std::string> runs, const std::string& integrator,
                             int spp) {
    Case c = kSmoke;
    c.runs = std::move(runs);
    const Row row = calibrate(c, reference(kSmoke), integrator, spp, 10);
    EXPECT_GE(row.covered, 8);
    EXPECT_EQ(row.unresolved, 0);
    EXPECT_GE(row.median_ratio, 0.75);
    EXPECT_LE(row.median_ratio, 1.33);
}

TEST(ErrorCalibration, IterationsThatAllocateTheirSamplesAreCalibrated) {
    expect_smoke_calibrated({"progressive.iterations=8"}, "path", 16);
}

// A run of iterations that ends after its first (a time budget's may) has one batch of
// iterations; it states that iteration's own estimate, from its sample batches and, for the
// default's camera paths ending in the volume map, its map's noise and bias (RunSetup::
// first_iteration_estimate), and that holds the truth as a plain render's does.
TEST(ErrorCalibration, ARunThatEndsAfterItsFirstIterationStatesThatIterationsEstimate) {
    expect_smoke_calibrated({"progressive.iterations=1"}, "", 16);
}

/// smoke.json at 160 x 90 with `settings`: its default's bias² is not flagged (the interval holds
/// 0), four times its (first iteration's) volume radius is (the interval lies above 0).
void expect_four_times_the_radius_flagged(std::vector<std::string> settings, const char* what) {
    const std::string path = std::string(FOGMAP_SOURCE_DIR) + "/" + kSmoke.scene;
    std::vector<std::string> o = size_overrides(kSmoke);
    o.insert(o.end(), settings.begin(), settings.end());
    const PipelineResult plain = run_pipeline(load_scene_desc(path, o), true);
    const ErrorReport& e = plain.report.error;
    ASSERT_TRUE(e.bias_valid);
    EXPECT_EQ(e.bias_lo, 0.0) << e.bias2;
    const float radius = plain.report.iterations.at(0).radii.volume;
    ASSERT_GT(radius, 0.0f);
    o.push_back("volume.radius=" + std::to_string(4.0f * radius));
    const ErrorReport wide = run_pipeline(load_scene_desc(path, o), true).report.error;
    ASSERT_TRUE(wide.bias_valid);
    EXPECT_GT(wide.bias_lo, 0.0) << wide.bias2;
    std::printf("%s bias²: default %.3g [%.3g, %.3g], four times the radius %.3g [%.3g, %.3g]\n",
                what, e.bias2, e.bias_lo, e.bias_hi, wide.bias2, wide.bias_lo, wide.bias_hi);
}

// The volume map's bias (render/volume_map_end.h, RadiusBias): smoke.json's default at 8 spp is
// not flagged (its bias² interval holds 0; the study's references put its bias² at 1-3% of the
// error, docs/error-estimate.md), and with four times its volume radius it is.
TEST(ErrorCalibration, AFourTimesWiderVolumeRadiusIsFlaggedAsBiasedAndTheDefaultIsNot) {
    expect_four_times_the_radius_flagged({"render.spp=8"}, "plain");
}

// The same in a progressive run (8 iterations of 4 spp), whose sum keeps each iteration's bias
// halves by its parity (render/film.h, FixedFilm); the wider radius shrinks as the default's does.
TEST(ErrorCalibration, AProgressiveRunsWiderVolumeRadiusIsFlaggedAsBiasedAndTheDefaultIsNot) {
    expect_four_times_the_radius_flagged({"render.spp=4", "progressive.iterations=8"},
                                         "progressive");
}

/// smoke.json's overrides for 160 x 90, 4 spp an iteration and four times its first iteration's
/// volume radius (a bias² of about 8e-6 after 8 iterations: the test above), then `more`.
std::vector<std::string> wide_progressive_smoke(const std::vector<std::string>& more) {
    const std::string path = std::string(FOGMAP_SOURCE_DIR) + "/" + kSmoke.scene;
    std::vector<std::string> o = size_overrides(kSmoke);
    o.push_back("render.spp=4");
    o.push_back("progressive.iterations=1");
    const float radius =
        run_pipeline(load_scene_desc(path, o), true).report.iterations.at(0).radii.volume;
    o.back() = "volume.radius=" + std::to_string(4.0f * radius);
    o.insert(o.end(), more.begin(), more.end());
    return o;
}

// A target under the maps' bias² alone: a target of 1e-8 would take that bias², shrinking as the
// discs' fastest, some 10⁵ iterations, beyond the 4096 a target alone may run: the run stops at
// the first look, not reached, and says why.
TEST(ErrorCalibration, ATargetUnderTheMapsBiasStopsAndSaysSo) {
    const std::string path = std::string(FOGMAP_SOURCE_DIR) + "/" + kSmoke.scene;
    const double target = 1e-8;
    const std::vector<std::string> o = wide_progressive_smoke({"progressive.target_relmse=1e-8"});
    const ErrorReport e = run_pipeline(load_scene_desc(path, o), true).report.error;
    EXPECT_FALSE(e.reached);
    EXPECT_EQ(e.iterations, 8);
    ASSERT_TRUE(e.bias_valid);
    EXPECT_GT(8.0 * std::pow(e.bias_lo / target, 1.5), double(kTargetIterations)) << e.bias_lo;
    EXPECT_NE(e.unreached.find("bias² alone"), std::string::npos) << e.unreached;
}

// auto uses it: the same wide radius under auto with a target (progressive photon mapping) of
// 1e-6 within 16 iterations: the photon run's bias² is out of reach, so the path tracer renders
// it instead, from its first iteration: the image is a path-traced target run's of the same
// settings, and the report says why.
TEST(ErrorCalibration, UnderAutoATargetTheBiasPutsOutOfReachGoesToThePathTracer) {
    const std::string path = std::string(FOGMAP_SOURCE_DIR) + "/" + kSmoke.scene;
    const std::vector<std::string> o =
        wide_progressive_smoke({"progressive.iterations=16", "progressive.target_relmse=1e-6"});
    std::vector<std::string> as_auto = o, as_path = o;
    as_auto.push_back("render.integrator=\"auto\"");
    as_path.push_back("render.integrator=\"path\"");
    const PipelineResult run = run_pipeline(load_scene_desc(path, as_auto), true);
    EXPECT_EQ(run.setup.method, Method::Path);
    EXPECT_NE(run.setup.reason.find("bias² alone"), std::string::npos) << run.setup.reason;
    const auto& w = run.report.warnings;
    EXPECT_TRUE(std::any_of(w.begin(), w.end(), [](const std::string& s) {
        return s.find("the path tracer, unbiased, renders it instead") != std::string::npos;
    }));
    const PipelineResult direct = run_pipeline(load_scene_desc(path, as_path), true);
    EXPECT_EQ(run.film.beauty.pixels, direct.film.beauty.pixels);
    EXPECT_EQ(run.report.error.iterations, direct.report.error.iterations);
}

// The photon gather's maps' bias (photon/estimators.h, BatchSums::bias): fog.json's gather with
// sixteen times the global map's k (its discs four times as wide over the floor's lit ellipse,
// whose edge they blur) is flagged, and above the default's estimate. (The default's own bias is
// within its reference's noise: docs/error-estimate.md.)
TEST(ErrorCalibration, TheGathersWiderDiscsAreFlaggedAsBiased) {
    const Case fog{"scenes/fog.json", 160, 90, 0};
    const std::string path = std::string(FOGMAP_SOURCE_DIR) + "/" + fog.scene;
    std::vector<std::string> o = size_overrides(fog);
    o.push_back("render.spp=8");
    const ErrorReport plain = run_pipeline(load_scene_desc(path, o), true).report.error;
    o.push_back("global.k=1600");
    const ErrorReport wide = run_pipeline(load_scene_desc(path, o), true).report.error;
    ASSERT_TRUE(plain.bias_valid);
    ASSERT_TRUE(wide.bias_valid);
    EXPECT_GT(wide.bias_lo, 0.0) << wide.bias2;
    EXPECT_GT(wide.bias2, plain.bias2);
    std::printf("bias²: default %.3g [%.3g, %.3g], global.k x 16 %.3g [%.3g, %.3g]\n", plain.bias2,
                plain.bias_lo, plain.bias_hi, wide.bias2, wide.bias_lo, wide.bias_hi);
}

/// The path tracer on smoke.json at 2 spp an iteration, with `extra` overrides.
PipelineResult path_run(const std::vector<std::string>& extra) {
    std::vector<std::string> o = size_overrides(kSmoke);
    o.push_back("render.integrator=\"path\"");
    o.push_back("render.spp=2");
    o.insert(o.end(), extra.begin(), extra.end());
    return run_pipeline(load_scene_desc(std::string(FOGMAP_SOURCE_DIR) + "/" + kSmoke.scene, o),
                        true);
}

TEST(ErrorCalibration, ATargetStopsAtTheFirstLookBelowItAndTheTruthIsBelowToo) {
    const Reference& ref = reference(kSmoke);
    const double target = 0.002;
    const PipelineResult run = path_run({"progressive.target_relmse=0.002"});
    const ErrorReport& e = run.report.error;
    ASSERT_TRUE(e.reached);
    EXPECT_LE(e.hi, target);
    EXPECT_LE(image_error(run.film.beauty, ref.image).rel_mse - ref.own, target);
    // Looks at 8, 16, 32, ... iterations: it stopped at one, the look before it had not reached.
    const int n = e.iterations;
    ASSERT_GE(n, 16);
    EXPECT_EQ(n & (n - 1), 0) << n;
    const PipelineResult before = path_run({"progressive.iterations=" + std::to_string(n / 2)});
    EXPECT_GT(before.report.error.hi, target);
    // The target's image is that of the same iterations run by count.
    const PipelineResult same = path_run({"progressive.iterations=" + std::to_string(n)});
    EXPECT_EQ(same.film.beauty.pixels, run.film.beauty.pixels);
}

void write_study(const std::vector<Row>& rows) {
    std::ofstream csv("error_calibration.csv");
    csv << "scene,integrator,spp,runs,covered,median_ratio,tail_flags,unresolved\n";
    LogLogPlot plot;
    plot.title = "Estimated against true relMSE, 20 seeds each";
    plot.x_label = "true relMSE (against a path-traced reference)";
    plot.y_label = "estimated relMSE";
    const char* colors[] = {"#1f77b4", "#ff7f0e", "#2ca02c", "#d62728",
                            "#9467bd", "#8c564b", "#e377c2", "#7f7f7f"};
    double lo = 1e30, hi = 0.0;
    size_t series = 0;
    for (const Row& r : rows) {
        csv << r.scene << "," << r.integrator << "," << r.spp << "," << r.runs << "," << r.covered
            << "," << r.median_ratio << "," << r.tails << "," << r.unresolved << "\n";
        if (plot.series.empty() || plot.series.back().label != r.scene + " " + r.integrator)
            plot.series.push_back({r.scene + " " + r.integrator,
                                   colors[series++ % 8],
                                   r.integrator == "path" ? PlotMarker::Square : PlotMarker::Circle,
                                   PlotLine::None,
                                   {}});
        for (const Run& p : r.points) {
            plot.series.back().points.push_back({p.truth, p.estimate});
            lo = std::min(lo, p.truth);
            hi = std::max(hi, p.truth);
        }
    }
    plot.series.push_back({"estimate = truth",
                           "#000000",
                           PlotMarker::None,
                           PlotLine::Straight,
                           {{lo, lo}, {hi, hi}}});
    std::ofstream("error_calibration.svg") << svg_log_log(plot);
}

TEST(ErrorCalibrationHeavy, FourScenesTwoIntegratorsThreeSampleCounts) {
    const Case cases[] = {{"scenes/smoke.json", 160, 90, 4096},
                          {"scenes/fog.json", 160, 90, 4096},
                          {"bench/scenes/smoke1_ground.json", 0, 0, 8192},
                          {"bench/scenes/cloud_ground.json", 0, 0, 8192}};
    std::vector<Row> rows;
    for (const Case& c : cases) {
        const Reference& ref = reference(c);
        for (const std::string integrator : {"", "path"})
            for (int spp : {4, 16, 64}) rows.push_back(calibrate(c, ref, integrator, spp, 20));
    }
    write_study(rows);
    for (const Row& r : rows) {
        const std::string what = r.scene + " " + r.integrator + " " + std::to_string(r.spp);
        if (r.unresolved > r.runs / 2) continue;  // the reference cannot judge this row
        EXPECT_GE(r.covered, 18) << what;
        EXPECT_GE(r.median_ratio, 0.8) << what;
        // fog.json's photon gather errs high at 4 spp (2.3x against a 65 536-spp reference): the
        // spot light seen in the fog, a few pixels brighter than their neighbours say and too
        // noisy to say it themselves (docs/error-estimate.md).
        if (r.scene != "scenes/fog.json" || r.integrator == "path")
            EXPECT_LE(r.median_ratio, 1.25) << what;
    }
}

}  // namespace
}  // namespace fogmap
