// render/run_setup.h: one resolve step turns the scene's keys into what runs — the method, the
// keys set by rule, the schedule — and the report's settings and the checkpoint fingerprint print
// from it. Expected values come from the rules' own statements (kAutoGatherDepth, twice the
// default k for a peaked phase function, a photon per attempt), not from a run of the code.

#include "render/run_setup.h"

#include "render/film.h"

#include "scene/scene_desc_json.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <string>

namespace fogmap {
namespace {

using nlohmann::json;

SceneDesc scene(const json& doc) {
    SceneDesc desc = scene_desc_from_json(doc, "scene.json");
    validate(desc);
    return desc;
}

/// A VDB cloud (g = 0.85) under sun and sky over a ground, the integrator left to auto, as in
/// bench/scenes/cloud_ground.json.
json sunlit_cloud() {
    return json::parse(R"({
      "camera": {"width": 160, "height": 120},
      "lights": [{"type": "sun", "direction": [-0.5, -0.6, -0.62], "irradiance": 3,
                  "angular_radius_deg": 0.27},
                 {"type": "environment", "radiance": 0.2}],
      "materials": {"ground": {"type": "diffuse", "albedo": 0.4}},
      "shapes": [{"type": "quad", "corner": [-50, 0, -50], "edge_u": [0, 0, 100],
                  "edge_v": [100, 0, 0], "material": "ground"}],
      "media": [{"type": "vdb", "file": "cloud.vdb", "sigma_s": 0.099, "sigma_a": 0.001,
                 "g": 0.85}],
      "render": {"spp": 4}
    })");
}

// Each named integrator is one method; photon splits by where camera paths end.
TEST(RunSetup, NamedIntegratorsAreOneMethodEach) {
    json doc = sunlit_cloud();
    const auto method = [&](const std::string& integrator, int depth) {
        doc["render"]["integrator"] = integrator;
        doc["volume"]["gather_depth"] = depth;
        return resolve_run(scene(doc)).method;
    };
    EXPECT_EQ(method("path", 0), Method::Path);
    EXPECT_EQ(method("guided", 0), Method::Guided);
    EXPECT_EQ(method("photon", 0), Method::Gather);
    EXPECT_EQ(method("photon", 2), Method::MapEnd);
    EXPECT_EQ(resolve_run(scene(doc)).reason, "scene");
}

// auto under sun and sky: photon with camera paths ending in the volume map at
// kAutoGatherDepth, at any sample count (no pilot: docs/measurements.md); the scene's file keeps
// its keys (gather_depth absent). Photon beams, which gather along marched camera rays, keep
// depth 0.
TEST(RunSetup, AutoUnderSunAndSkyEndsPathsInTheMapAtAnySampleCount) {
    json doc = sunlit_cloud();
    for (const int spp : {4, 64, 1024}) {
        doc["render"]["spp"] = spp;
        const SceneDesc file = scene(doc);
        const RunSetup s = resolve_run(file);
        EXPECT_EQ(s.method, Method::MapEnd) << spp;
        EXPECT_EQ(s.run.volume.gather_depth, kAutoGatherDepth);
        EXPECT_EQ(file.volume.gather_depth, 0);
        EXPECT_EQ(file.render.integrator, Integrator::Auto);
        EXPECT_EQ(s.run.render.integrator, Integrator::Photon);
        EXPECT_EQ(s.reason.rfind("auto: media under sun, sky or area lights: photon, camera paths "
                                 "ending in the volume map at vertex 3 (",
                                 0),
                  0u)
            << s.reason;
    }
    doc["volume"]["estimator"] = "photon_beams";
    const RunSetup beams = resolve_run(scene(doc));
    EXPECT_EQ(beams.method, Method::Gather);
    EXPECT_NE(beams.reason.find("photon, with the photon beams the scene asks for"),
              std::string::npos)
        << beams.reason;
}

// The report's settings are what ran: the cloud's g = 0.85 gathers twice the default k with
// paths ending in the map (the moment grid serves |g| <= kMomentGridMaxG only), and the volume
// map's budget is a photon per attempt, a quarter of the camera samples.
TEST(RunSetup, SettingsPrintWhatRanNotWhatTheFileSaid) {
    json doc = sunlit_cloud();
    doc["render"]["spp"] = 64;  // 1.2 M samples: one iteration
    const RunSetup s = resolve_run(scene(doc));
    const json settings = settings_json(s);
    EXPECT_EQ(settings["render"]["integrator"], "photon");
    EXPECT_EQ(settings["volume"]["k"], 2 * kDefaultVolumeK);
    EXPECT_EQ(settings["volume"]["gather_depth"], kAutoGatherDepth);
    const uint64_t samples = 160u * 120u * 64u;
    const uint64_t attempts = std::max<uint64_t>(samples / 4, kDefaultVolumePhotons);
    EXPECT_EQ(s.photons.volume_attempts, attempts);
    EXPECT_EQ(settings["photons"]["volume"], attempts);
    // A k the scene gives is kept.
    json given = sunlit_cloud();
    given["volume"]["k"] = 30;
    EXPECT_EQ(settings_json(resolve_run(scene(given)))["volume"]["k"], 30);
}

// The fingerprint hashes what runs: the same run from a key given or left to its rule has one
// fingerprint; a different budget, another; the iteration count and the threads do not count.
TEST(RunSetup, FingerprintFollowsWhatRuns) {
    json doc = sunlit_cloud();
    doc["render"]["integrator"] = "photon";
    doc["progressive"]["iterations"] = 4;
    const uint64_t left = resumable_fingerprint(resolve_run(scene(doc)));
    json same = doc;  // the rule's own value, given
    same["photons"]["volume"] = resolve_run(scene(doc)).photons.volume;
    EXPECT_EQ(resumable_fingerprint(resolve_run(scene(same))), left);
    json other = doc;
    other["photons"]["volume"] = 12345;
    EXPECT_NE(resumable_fingerprint(resolve_run(scene(other))), left);
    json more = doc;
    more["progressive"]["iterations"] = 40;
    more["render"]["threads"] = 1;
    EXPECT_EQ(resumable_fingerprint(resolve_run(scene(more))), left);
    // With camera paths ending in the map the default budget, given, is not the rule's (a photon
    // per attempt): another run, another fingerprint.
    doc["volume"]["gather_depth"] = 3;
    json given = doc;
    given["photons"]["volume"] = kDefaultVolumePhotons;
    EXPECT_NE(resumable_fingerprint(resolve_run(scene(given))),
              resumable_fingerprint(resolve_run(scene(doc))));
}

// A plain photon render of many samples under the attempts rule runs as iterations: the schedule
// says so in the Plan's integrator line, and render.spp in the settings is an iteration's.
TEST(RunSetup, TheScheduleIsInThePlanAndTheSettings) {
    json doc = sunlit_cloud();
    doc["render"]["integrator"] = "photon";
    doc["volume"]["gather_depth"] = 3;
    doc["render"]["spp"] = 512;  // 160 x 120 x 512 = 9.8 M samples: 9 iterations of 57 spp
    const RunSetup s = resolve_run(scene(doc));
    ASSERT_TRUE(s.progressive);
    EXPECT_EQ(s.run.progressive.iterations, 9);
    EXPECT_EQ(s.run.render.spp, 57);
    EXPECT_NE(s.plan.integrator.reason.find("render.spp 512 as 9 progressive iterations of 57"),
              std::string::npos)
        << s.plan.integrator.reason;
    // The reason set later (resolve_picked: auto's path tracer for a target out of a photon
    // run's reach) keeps the schedule's.
    RunSetup t = s;
    t.set_reason("picked");
    EXPECT_EQ(t.plan.integrator.reason.rfind("picked; " + s.schedule, 0), 0u)
        << t.plan.integrator.reason;
}

// Adaptive sampling (docs/design.md): every integrator, said in the Plan; in a plain render, off
// where it is too small to allocate (a first pass of two of the method's units: strata groups of
// 4, the photon gather's map step spp / map_spp), and for a share of the tiles without ranks to
// exchange its sums with (--part); across a run's iterations; each in the settings that ran.
TEST(RunSetup, AdaptiveSamplingRunsWhereAFirstPassLeavesSamplesToAllocate) {
    json doc = sunlit_cloud();
    doc["render"]["spp"] = 16;
    const auto resolved = [&](const std::string& integrator, int depth) {
        doc["render"]["integrator"] = integrator;
        doc["volume"]["gather_depth"] = depth;
        return resolve_run(scene(doc));
    };
    for (const auto& [integrator, depth] : {std::pair{"path", 0}, std::pair{"guided", 0},
                                            std::pair{"photon", 3}, std::pair{"photon", 0}}) {
        const RunSetup s = resolved(integrator, depth);
        EXPECT_TRUE(s.run.render.adaptive) << integrator;
        EXPECT_TRUE(settings_json(s)["render"]["adaptive"].get<bool>());
        EXPECT_NE(s.plan.integrator.reason.find("adaptive sampling: a first pass of 8 spp"),
                  std::string::npos)
            << s.plan.integrator.reason;
    }
    // Iterations: the first ceil(kAdaptiveMinSpp / spp) measure for every later one, whatever
    // the run's count (a resumed run may have more).
    // Iteration 1 samples as a plain render does, its first pass the measure.
    doc["progressive"]["iterations"] = 4;  // 16 spp an iteration or more: iteration 1 measures
    for (const char* integrator : {"path", "photon"}) {
        const RunSetup s = resolved(integrator, 3);
        EXPECT_TRUE(s.run.render.adaptive) << integrator;
        EXPECT_EQ(s.measured, 1) << integrator;
        const int spp = s.run.render.spp;           // photon's: 64 (at least 2^20 camera samples)
        const int first = spp == 16 ? 8 : spp / 4;  // two strata groups, or a quarter
        EXPECT_NE(s.plan.integrator.reason.find(
                      "adaptive sampling across iterations: iteration 1 takes a first pass of " +
                      std::to_string(first) + " spp, then the rest of its " + std::to_string(spp) +
                      " spp's work where it shows the error, every later one a uniform "
                      "iteration's work where that first pass shows the error"),
                  std::string::npos)
            << s.plan.integrator.reason;
    }
    doc["progressive"]["iterations"] = 1;
    EXPECT_EQ(resolved("path", 0).measured, 1);
    EXPECT_NE(resolved("path", 0).plan.integrator.reason.find(
                  "adaptive sampling: a first pass of 8 spp, then the rest of its 16 spp's work"),
              std::string::npos)
        << resolved("path", 0).plan.integrator.reason;
    doc["render"]["spp"] = 8;  // a first pass would take them all: iteration 1 measures all 8
    doc["progressive"]["iterations"] = 4;
    EXPECT_NE(resolved("path", 0).plan.integrator.reason.find(
                  "adaptive sampling across iterations: iteration 1 takes its 8 spp in every "
                  "pixel, every later one a uniform iteration's work where they show the error"),
              std::string::npos)
        << resolved("path", 0).plan.integrator.reason;
    doc["render"]["spp"] = 4;  // iterations 1 and 2 measure
    EXPECT_EQ(resolved("path", 0).measured, 2);
    EXPECT_TRUE(resolved("path", 0).run.render.adaptive);
    doc["progressive"]["iterations"] = 2;  // measured, both: nothing allocated, and said so
    EXPECT_EQ(resolved("path", 0).measured, 2);
    EXPECT_NE(resolved("path", 0).plan.integrator.reason.find("adaptive sampling: none (2 "
                                                              "iterations, no more than the 2"),
              std::string::npos)
        << resolved("path", 0).plan.integrator.reason;
    doc["render"]["spp"] = 16;
    doc["progressive"]["iterations"] = 0;
    doc["progressive"]["time_budget"] = 10.0;  // no count: the measured ones, then the rest
    EXPECT_EQ(resolved("path", 0).measured, 1);
    doc["render"]["adaptive"] = false;
    EXPECT_EQ(resolved("path", 0).measured, 0);
    doc["render"]["adaptive"] = true;
    doc["progressive"].erase("time_budget");
    doc["progressive"]["iterations"] = 0;
    doc["render"]["adaptive"] = false;
    EXPECT_FALSE(resolved("path", 0).run.render.adaptive);
    doc["render"]["adaptive"] = true;
    doc["render"]["spp"] = kAdaptiveMinSpp - 1;  // too few for a first pass to pay
    EXPECT_FALSE(resolved("path", 0).run.render.adaptive);
    doc["render"]["spp"] = 8;  // a first pass of two strata groups would take them all
    EXPECT_FALSE(resolved("path", 0).run.render.adaptive);
    const RunSetup gather = resolved("photon", 0);  // two map steps of 2 take half
    EXPECT_TRUE(gather.run.render.adaptive);
    EXPECT_NE(gather.plan.integrator.reason.find("a first pass of 4 spp"), std::string::npos)
        << gather.plan.integrator.reason;
    doc["advanced"]["map_spp"] = 0;  // every sample reads the maps: a unit of one
    EXPECT_TRUE(resolved("photon", 0).run.render.adaptive);
    doc["advanced"].erase("map_spp");
    doc["render"]["spp"] = 16;

    RunSetup part = resolved("path", 0);
    part.share_tiles(TileShare{1, 3});
    EXPECT_FALSE(part.run.render.adaptive);
    EXPECT_EQ(part.plan.integrator.reason.find("adaptive"), std::string::npos);
    RunSetup alone = resolved("path", 0);
    alone.share_tiles(TileShare{0, 1});
    EXPECT_TRUE(alone.run.render.adaptive);
}

// A run of iterations that may end after its first (a time budget, one iteration) renders that
// iteration with its maps' noise, whose estimate it then states; every other iteration of a run
// keeps its maps' bias alone, and a plain render both. A photon gather whose maps are not read in
// batches (photon beams) has no iteration estimate to state.
TEST(RunSetup, AFirstIterationThatMayEndTheRunKeepsItsMapsNoise) {
    json doc = sunlit_cloud();
    doc["render"]["integrator"] = "photon";
    doc["volume"]["gather_depth"] = 3;
    const auto resolved = [&](double budget, int iterations) {
        doc["progressive"]["time_budget"] = budget;
        doc["progressive"]["iterations"] = iterations;
        return resolve_run(scene(doc));
    };
    const RunSetup plain = resolve_run(scene(doc));
    ASSERT_FALSE(plain.progressive);
    EXPECT_EQ(plain.photon_parts(1), PhotonParts::NoiseAndBias);
    EXPECT_FALSE(plain.first_iteration_estimate());
    for (const auto& [budget, iterations] : {std::pair{10.0, 0}, std::pair{0.0, 1}}) {
        const RunSetup s = resolved(budget, iterations);
        ASSERT_TRUE(s.progressive);
        EXPECT_TRUE(s.first_iteration_estimate()) << budget;
        EXPECT_EQ(s.photon_parts(1), PhotonParts::NoiseAndBias) << budget;
        EXPECT_EQ(s.photon_parts(2), PhotonParts::Bias) << budget;
    }
    const RunSetup counted = resolved(0.0, 4);
    EXPECT_FALSE(counted.first_iteration_estimate());
    EXPECT_EQ(counted.photon_parts(1), PhotonParts::Bias);
    doc["render"]["integrator"] = "path";
    EXPECT_TRUE(resolved(10.0, 0).first_iteration_estimate());
    EXPECT_EQ(resolved(10.0, 0).photon_parts(1), PhotonParts::None);
    doc["render"]["integrator"] = "photon";
    doc["volume"]["gather_depth"] = 0;
    doc["volume"]["estimator"] = "photon_beams";
    EXPECT_FALSE(resolved(10.0, 0).first_iteration_estimate());
}

}  // namespace
}  // namespace fogmap
