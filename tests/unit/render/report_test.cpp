// The run report (render/report.h) of a Report built by hand: add_phase sums repeated phases and
// keeps first-seen order; report_json carries every field with its value (rates, totals and bytes
// per photon worked out here); report_text names every phase, map, iteration, warning and output.

#include "render/report.h"

#include <gtest/gtest.h>

#include <string>

namespace fogmap {
namespace {

TEST(Report, AddPhaseSumsRepeatsAndKeepsFirstSeenOrder) {
    Report r;
    add_phase(&r, "load", 0.5);
    add_phase(&r, "photons", 1.25);
    add_phase(&r, "render", 2.0);
    add_phase(&r, "photons", 0.75);
    add_phase(&r, "load", 0.25);
    ASSERT_EQ(r.phases_s.size(), 3u);
    EXPECT_EQ(r.phases_s[0].first, "load");
    EXPECT_EQ(r.phases_s[0].second, 0.75);
    EXPECT_EQ(r.phases_s[1].first, "photons");
    EXPECT_EQ(r.phases_s[1].second, 2.0);
    EXPECT_EQ(r.phases_s[2].first, "render");
    EXPECT_EQ(r.phases_s[2].second, 2.0);
}

/// Every field set, to values that are exact in binary where the JSON holds a quotient.
Report hand_built() {
    Report r;
    r.scene = "scenes/fog.json";
    r.settings = {{"render", {{"spp", 16}}}};
    add_phase(&r, "load", 0.5);
    add_phase(&r, "render", 4.0);
    add_phase(&r, "write", 0.25);
    r.width = 64;
    r.height = 48;
    r.spp = 16;
    r.threads = 2;
    r.ranks = 3;
    r.samples = 49152;
    r.rays = 1000000;
    r.nonfinite = 7;
    r.steps = 11;
    r.lookups = 12;
    r.photon_steps = 13;
    r.photon_interactions = 14;
    r.gathered = 15;
    r.precompute_nodes = 16;
    r.estimate_events = 17;
    r.render_s = 4.0;
    r.outputs = {"out.exr", "out.png"};
    r.plan_text = "integrator: photon\n";
    r.plan = {{"integrator", "photon"}};
    MapReport volume;
    volume.name = "volume";
    volume.stored = 1000;
    volume.emitted = 4000;
    volume.bytes = 36000;
    volume.build_s = 0.125;
    volume.stopped = "closed by rule";
    volume.beams = 9;
    MapReport global;
    global.name = "global";  // empty: 0 bytes per photon
    r.maps = {volume, global};
    r.streams =
        nlohmann::json::array({{{"name", "sun"},
                                {"attempts", 5000},
                                {"photons", 4000},
                                {"media_share", 0.25},
                                {"stored", {{"global", 1}, {"caustic", 2}, {"volume", 3}}}}});
    r.photons_emitted = 4000;
    r.depth_capped = 2;
    r.photons_capped = 3;
    r.photons_capped_power = 0.0625;
    IterationReport it;
    it.index = 1;
    it.elapsed_s = 2.5;
    it.radii = {0.5f, 0.25f, 0.125f};
    it.rel_mse = 0.03125;
    it.photon_bytes = 36000;
    r.iterations = {it};
    r.warnings = {"first warning", "second warning"};
    r.mean = 0.375;
    r.reference = "ref.exr";
    r.rmse = 0.1;
    r.rel_mse = 0.2;
    r.bias = -0.05;
    r.error.valid = true;
    r.error.rel_mse = 0.0125;
    r.error.lo = 0.01;
    r.error.hi = 0.015;
    r.error.batches = 8;
    r.error.batched_by = "samples";
    r.error.tail_share = 0.625;
    r.error.tail = true;
    r.error.top_x = 7;
    r.error.top_y = 3;
    r.error.excludes = "the bias";
    return r;
}

TEST(Report, JsonCarriesEveryField) {
    const nlohmann::json j = report_json(hand_built());
    EXPECT_EQ(j["scene"], "scenes/fog.json");
    EXPECT_EQ(j["settings"]["render"]["spp"], 16);
    EXPECT_EQ(j["width"], 64);
    EXPECT_EQ(j["height"], 48);
    EXPECT_EQ(j["spp"], 16);
    EXPECT_EQ(j["threads"], 2);
    EXPECT_EQ(j["ranks"], 3);
    // Phases, in seconds, and their total 0.5 + 4 + 0.25.
    EXPECT_EQ(j["time_s"]["load"], 0.5);
    EXPECT_EQ(j["time_s"]["render"], 4.0);
    EXPECT_EQ(j["time_s"]["write"], 0.25);
    EXPECT_EQ(j["time_s"]["total"], 4.75);
    EXPECT_EQ(j["time_s"].size(), 4u);
    EXPECT_EQ(j["samples"], 49152);
    EXPECT_EQ(j["samples_per_s"], 12288.0);  // 49152 / 4 s
    EXPECT_EQ(j["rays"], 1000000);
    EXPECT_EQ(j["rays_per_s"], 250000.0);
    EXPECT_EQ(j["nonfinite_samples"], 7);
    const nlohmann::json& work = j["work"];
    EXPECT_EQ(work["steps"], 11);
    EXPECT_EQ(work["lookups"], 12);
    EXPECT_EQ(work["photon_steps"], 13);
    EXPECT_EQ(work["photon_interactions"], 14);
    EXPECT_EQ(work["gathered"], 15);
    EXPECT_EQ(work["precompute_nodes"], 16);
    EXPECT_EQ(work["estimate_events"], 17);
    EXPECT_EQ(j["outputs"], nlohmann::json::array({"out.exr", "out.png"}));
    EXPECT_EQ(j["plan"]["integrator"], "photon");
    EXPECT_EQ(j["photons_emitted"], 4000);
    EXPECT_EQ(j["capped"]["samples_by_max_depth"], 2);
    EXPECT_EQ(j["capped"]["photon_paths_by_max_bounces"], 3);
    EXPECT_EQ(j["capped"]["photon_power_fraction"], 0.0625);
    const nlohmann::json& volume = j["maps"]["volume"];
    EXPECT_EQ(volume["stored"], 1000);
    EXPECT_EQ(volume["emitted"], 4000);
    EXPECT_EQ(volume["bytes"], 36000);
    EXPECT_EQ(volume["bytes_per_photon"], 36.0);
    EXPECT_EQ(volume["build_s"], 0.125);
    EXPECT_EQ(volume["stopped"], "closed by rule");
    EXPECT_EQ(volume["beams"], 9);
    EXPECT_EQ(j["maps"]["global"]["bytes_per_photon"], 0.0);
    EXPECT_EQ(j["maps"].size(), 2u);
    EXPECT_EQ(j["streams"][0]["name"], "sun");
    EXPECT_EQ(j["streams"][0]["stored"]["volume"], 3);
    EXPECT_EQ(j["mean"], 0.375);
    ASSERT_EQ(j["iterations"].size(), 1u);
    const nlohmann::json& it = j["iterations"][0];
    EXPECT_EQ(it["index"], 1);
    EXPECT_EQ(it["elapsed_s"], 2.5);
    EXPECT_EQ(it["radii"], nlohmann::json::array({0.5, 0.25, 0.125}));
    EXPECT_EQ(it["rel_mse"], 0.03125);
    EXPECT_EQ(it["photon_bytes"], 36000);
    EXPECT_EQ(j["warnings"], nlohmann::json::array({"first warning", "second warning"}));
    EXPECT_EQ(j["reference"]["file"], "ref.exr");
    EXPECT_EQ(j["reference"]["rmse"], 0.1);
    EXPECT_EQ(j["reference"]["rel_mse"], 0.2);
    EXPECT_EQ(j["reference"]["bias"], -0.05);
    const nlohmann::json& e = j["error_estimate"];
    EXPECT_EQ(e["valid"], true);
    EXPECT_EQ(e["rel_mse"], 0.0125);
    EXPECT_EQ(e["lo"], 0.01);
    EXPECT_EQ(e["hi"], 0.015);
    EXPECT_EQ(e["confidence"], 0.95);
    EXPECT_EQ(e["batches"], 8);
    EXPECT_EQ(e["batched_by"], "samples");
    EXPECT_EQ(e["tail_share"], 0.625);
    EXPECT_EQ(e["tail"], true);
    EXPECT_EQ(e["top_pixel"], nlohmann::json({7, 3}));
    EXPECT_EQ(e["excludes"], "the bias");
    EXPECT_TRUE(e["dof"].is_null());  // the normal's quantile
}

// The interval's degrees of freedom: in the JSON, and said in the text where few (a few blocks
// carry the error, so the interval is wide), not where many.
TEST(Report, FewDegreesOfFreedomAreSaid) {
    Report r = hand_built();
    const std::string few = "a few blocks of the image carry it";
    EXPECT_EQ(report_text(r).find(few), std::string::npos);
    r.error.dof = 40.0;
    EXPECT_EQ(report_text(r).find(few), std::string::npos);
    r.error.dof = 3.25;
    EXPECT_NE(report_text(r).find(few + " (3.2 degrees of freedom)"), std::string::npos)
        << report_text(r);
    EXPECT_EQ(report_json(r)["error_estimate"]["dof"], 3.25);
}

// A target not reached: by default the budget or the cap ended the run; where the run stopped on
// the maps' bias, the text and the JSON say that instead.
TEST(Report, AnUnreachedTargetSaysWhy) {
    Report r = hand_built();
    r.error.target = 0.001;
    r.error.iterations = 8;
    EXPECT_NE(report_text(r).find("not reached in 8 iterations: the time budget or the iteration "
                                  "cap ended the run"),
              std::string::npos);
    EXPECT_TRUE(report_json(r)["error_estimate"]["unreached"].is_null());
    r.error.unreached = "the maps' bias² alone is above the target";
    EXPECT_NE(report_text(r).find("not reached in 8 iterations: the maps' bias² alone is above the "
                                  "target\n"),
              std::string::npos)
        << report_text(r);
    EXPECT_EQ(report_json(r)["error_estimate"]["unreached"], r.error.unreached);
}

TEST(Report, TheVolumeMapsBiasIsFlaggedOnlyWhenItsIntervalExcludesZero) {
    // Three estimates of the bias²: measurable (its interval above 0), within its noise (the
    // interval holds 0), below 0 (noise about a small bias: only its upper bound is said).
    Report r;
    ErrorReport& e = r.error;
    e.valid = true;
    e.rel_mse = 0.001;
    e.lo = 0.0008;
    e.hi = 0.0012;
    e.batches = 8;
    e.batched_by = "samples";
    e.bias_valid = true;
    e.bias_of = "the volume map's";
    e.bias_remedy = "a smaller volume.radius lowers it";
    const std::string flag =
        "error estimate: the volume map's bias is measurable: a smaller volume.radius lowers it";
    e.bias2 = 0.000125, e.bias_lo = 0.0000625, e.bias_hi = 0.00025;
    std::string t = report_text(r);
    EXPECT_NE(t.find("of which the volume map's bias² 0.000125 [6.25e-05, 0.00025] (95%)"),
              std::string::npos)
        << t;
    EXPECT_NE(t.find(flag), std::string::npos) << t;
    nlohmann::json j = report_json(r)["error_estimate"]["bias2"];
    EXPECT_EQ(j["value"], 0.000125);
    EXPECT_EQ(j["lo"], 0.0000625);
    EXPECT_EQ(j["hi"], 0.00025);
    e.bias_lo = -0.0000625;
    t = report_text(r);
    EXPECT_NE(t.find("bias² 0.000125 [-6.25e-05, 0.00025]"), std::string::npos) << t;
    EXPECT_EQ(t.find(flag), std::string::npos) << t;
    e.bias2 = -0.000125;
    t = report_text(r);
    EXPECT_NE(t.find("bias²: too small to measure here (95% upper bound 0.00025)"),
              std::string::npos)
        << t;
    EXPECT_EQ(t.find(flag), std::string::npos) << t;
    e.bias_valid = false;
    EXPECT_TRUE(report_json(r)["error_estimate"]["bias2"].is_null());
    EXPECT_EQ(report_text(r).find("bias²"), std::string::npos);
}

TEST(Report, JsonOfAnEmptyReportHasNoReferenceAndZeroRates) {
    const nlohmann::json j = report_json(Report{});
    EXPECT_TRUE(j["reference"].is_null());
    EXPECT_EQ(j["samples_per_s"], 0.0);  // render_s 0: no rate
    EXPECT_EQ(j["rays_per_s"], 0.0);
    EXPECT_EQ(j["time_s"]["total"], 0.0);
    EXPECT_EQ(j["time_s"].size(), 1u);
    EXPECT_EQ(j["ranks"], 1);
    EXPECT_TRUE(j["maps"].empty());
    EXPECT_TRUE(j["iterations"].empty());
    EXPECT_EQ(j["error_estimate"]["valid"], false);
}

bool has_line(const std::string& text, const std::string& line) {
    return ("\n" + text).find("\n" + line + "\n") != std::string::npos;
}

TEST(Report, TextNamesThePhasesAndEverythingElse) {
    const std::string t = report_text(hand_built());
    EXPECT_TRUE(has_line(t, "scene: scenes/fog.json")) << t;
    EXPECT_TRUE(has_line(t, "integrator: photon")) << t;  // the plan's lines
    EXPECT_TRUE(has_line(t, "time load: 0.500 s")) << t;
    EXPECT_TRUE(has_line(t, "time render: 4.000 s")) << t;
    EXPECT_TRUE(has_line(t, "time write: 0.250 s")) << t;
    EXPECT_TRUE(has_line(t, "time total: 4.750 s")) << t;
    // Phases in their order.
    EXPECT_LT(t.find("time load"), t.find("time render"));
    EXPECT_LT(t.find("time render"), t.find("time write"));
    EXPECT_TRUE(has_line(t, "image: 64 x 48, 16 spp, 2 threads per rank, 3 MPI ranks")) << t;
    EXPECT_TRUE(has_line(t, "samples: 49152 (12288 per second)")) << t;
    EXPECT_TRUE(has_line(t, "rays: 1000000 (250000 per second)")) << t;
    EXPECT_TRUE(has_line(t, "non-finite samples dropped: 7")) << t;
    EXPECT_TRUE(has_line(t, "samples cut by render.max_depth: 2")) << t;
    EXPECT_TRUE(has_line(t,
                         "volume map: 1000 photons (4000 emitted), 36000 bytes, 36.0 bytes/photon, "
                         "tree built in 0.125 s; 9 photon beams; closed by rule"))
        << t;
    EXPECT_TRUE(has_line(t, "photons emitted: 4000")) << t;
    EXPECT_TRUE(has_line(t,
                         "photon paths cut by photons.max_bounces: 3 (6.250% of the emitted "
                         "power)"))
        << t;
    EXPECT_NE(t.find("stream sun: 5000 attempts, 4000 photons, 25.0% reach the media"),
              std::string::npos)
        << t;
    EXPECT_NE(t.find("iteration 1: 2.50 s, radii [0.5,0.25,0.125]"), std::string::npos) << t;
    EXPECT_TRUE(has_line(t, "warning: first warning")) << t;
    EXPECT_TRUE(has_line(t, "warning: second warning")) << t;
    EXPECT_TRUE(has_line(t, "image mean: 0.375")) << t;
    EXPECT_NE(t.find("error vs ref.exr: rmse 0.1, relmse 0.2, bias -0.05"), std::string::npos) << t;
    EXPECT_TRUE(has_line(t, "wrote: out.exr")) << t;
    EXPECT_TRUE(has_line(t, "wrote: out.png")) << t;
    EXPECT_TRUE(has_line(t,
                         "error estimate: relMSE 0.0125 [0.01, 0.015] (95%), from 8 batches of "
                         "samples"))
        << t;
    EXPECT_TRUE(has_line(t, "error estimate: not in it: the bias")) << t;
    EXPECT_NE(t.find("error estimate: 0.1% of the pixels carry 62% of it (the most: pixel (7, 3))"),
              std::string::npos)
        << t;
}

TEST(Report, TextSaysWhyThereIsNoEstimate) {
    Report r;
    r.error.why = "needs at least 2 samples per pixel";
    EXPECT_TRUE(
        has_line(report_text(r), "error estimate: none (needs at least 2 samples per pixel)"));
}

TEST(Report, TextOfOneRankSaysNothingOfRanks) {
    Report r = hand_built();
    r.ranks = 1;
    r.reference.clear();
    const std::string t = report_text(r);
    EXPECT_TRUE(has_line(t, "image: 64 x 48, 16 spp, 2 threads")) << t;
    EXPECT_EQ(t.find("MPI"), std::string::npos);
    EXPECT_EQ(t.find("error vs"), std::string::npos);
}

}  // namespace
}  // namespace fogmap
