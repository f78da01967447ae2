#include "render/run_setup.h"

#include "scene/scene_desc_json.h"

#include <gtest/gtest.h>

#include <sstream>
#include <string>
#include <vector>

namespace fogmap {
namespace {

using nlohmann::json;

/// A validated description from scene-file text (no file is opened: the plan needs none). The
/// map rules below are the photon integrator's: a scene that names no integrator gets "photon".
SceneDesc scene(json doc) {
    if (!doc.contains("render") || !doc["render"].contains("integrator"))
        doc["render"]["integrator"] = "photon";
    SceneDesc desc = scene_desc_from_json(doc, "scene.json");
    validate(desc);
    return desc;
}

/// The full scene of the tests below: a floor, a glass sphere, fog and a point light.
json glass_floor_fog() {
    return json::parse(R"({
      "lights": [{"type": "point", "intensity": 50, "position": [0, 4, 0]}],
      "materials": {"floor": {"type": "diffuse", "albedo": 0.7},
                    "glass": {"type": "glass", "ior": 1.5}},
      "shapes": [
        {"type": "quad", "material": "floor", "corner": [-5, 0, -5], "edge_u": [10, 0, 0],
         "edge_v": [0, 0, 10]},
        {"type": "sphere", "material": "glass", "center": [0, 1, 0], "radius": 0.5}
      ],
      "media": [{"type": "homogeneous", "bounds": {"min": [-5, 0, -5], "max": [5, 3, 5]},
                 "sigma_s": 0.05, "sigma_a": 0.01}]
    })");
}

/// A VDB smoke lit by one point light; no surfaces at all.
json smoke_only() {
    return json::parse(R"({
      "lights": [{"type": "point", "intensity": 20, "position": [0, 4, 0]}],
      "media": [{"type": "vdb", "file": "smoke.vdb", "sigma_s": [1, 1, 1], "sigma_a": 0.1}]
    })");
}

std::vector<std::string> lines(const std::string& text) {
    std::vector<std::string> out;
    std::istringstream in(text);
    for (std::string line; std::getline(in, line);) out.push_back(line);
    return out;
}

/// plan_text's line for one item; the order is fixed: integrator, Embree, marching, volume light,
/// volume map, global, caustic.
enum Line { kIntegrator = 0, kEmbree, kMarching, kVolumeLight, kVolume, kGlobal, kCaustic };
std::string line(const Plan& plan, Line which) {
    const std::vector<std::string> all = lines(plan_text(plan));
    return all.size() == 7 ? all[size_t(which)] : "plan_text has " + std::to_string(all.size());
}

TEST(Plan, SmokeOnlyHasNoSurfaceMapsAndNoEmbreeScene) {
    const Plan p = make_plan(scene(smoke_only()));
    EXPECT_FALSE(p.embree_scene.on);
    EXPECT_EQ(line(p, kEmbree), "Embree scene: skipped (no surfaces)");
    EXPECT_TRUE(p.ray_marching.on);
    EXPECT_EQ(line(p, kMarching),
              "ray marching: used (1 medium; camera rays and photon free paths march)");
    EXPECT_TRUE(p.volume_map.on);
    EXPECT_EQ(line(p, kVolume), "volume map: built (1 scattering medium, budget 100000 photons)");
    EXPECT_FALSE(p.global_map.on);
    EXPECT_EQ(line(p, kGlobal), "global map: skipped (no diffuse surface)");
    EXPECT_FALSE(p.caustic_map.on);
    EXPECT_EQ(line(p, kCaustic), "caustic map: skipped (no specular surface)");
}

TEST(Plan, NoGlassOrMirrorMeansNoCausticMap) {
    json doc = glass_floor_fog();
    doc["shapes"].erase(1);
    doc["materials"].erase("glass");
    const Plan p = make_plan(scene(doc));
    EXPECT_FALSE(p.caustic_map.on);
    EXPECT_FALSE(bool(p.caustic_map));  // passes write `if (!plan.caustic_map) return;`
    EXPECT_EQ(line(p, kCaustic), "caustic map: skipped (no specular surface)");
    EXPECT_TRUE(p.global_map.on);
    EXPECT_EQ(line(p, kGlobal), "global map: built (1 diffuse shape, budget 100000 photons)");

    // A mirror that reflects nothing is not specular either.
    doc["materials"]["black_mirror"] = json::parse(R"({"type": "mirror", "albedo": 0})");
    doc["shapes"].push_back(json::parse(R"({"type": "sphere", "material": "black_mirror"})"));
    EXPECT_EQ(line(make_plan(scene(doc)), kCaustic), "caustic map: skipped (no specular surface)");
    doc["materials"]["black_mirror"]["albedo"] = json::array({0, 0, 0.5});
    EXPECT_EQ(line(make_plan(scene(doc)), kCaustic),
              "caustic map: built (1 specular shape, 1 diffuse receiver, budget 50000 photons)");
}

TEST(Plan, SpecularSurfaceWithoutDiffuseReceiverHasNoCausticMap) {
    json doc = glass_floor_fog();
    doc["materials"]["floor"]["albedo"] = 0;  // a black floor receives nothing
    const Plan p = make_plan(scene(doc));
    EXPECT_FALSE(p.caustic_map.on);
    EXPECT_EQ(line(p, kCaustic), "caustic map: skipped (no diffuse surface to receive caustics)");
    EXPECT_FALSE(p.global_map.on);
    EXPECT_EQ(line(p, kGlobal), "global map: skipped (no diffuse surface)");
    EXPECT_TRUE(p.embree_scene.on);  // the surfaces are still there to be hit
}

TEST(Plan, ZeroVolumeBudgetSkipsTheVolumeMap) {
    json doc = glass_floor_fog();
    doc["photons"] = json{{"volume", 0}};
    const Plan p = make_plan(scene(doc));
    EXPECT_FALSE(p.volume_map.on);
    EXPECT_EQ(line(p, kVolume), "volume map: skipped (photons.volume = 0)");
    EXPECT_TRUE(p.ray_marching.on);  // camera rays still march through the fog
    EXPECT_TRUE(p.global_map.on);
    EXPECT_TRUE(p.caustic_map.on);

    doc["photons"] = json{{"global", 0}, {"caustic", 0}};
    const Plan q = make_plan(scene(doc));
    EXPECT_TRUE(q.volume_map.on);
    EXPECT_EQ(line(q, kGlobal), "global map: skipped (photons.global = 0)");
    EXPECT_EQ(line(q, kCaustic), "caustic map: skipped (photons.caustic = 0)");
}

TEST(Plan, MediaThatDoNotScatterGetNoVolumeMap) {
    json doc = glass_floor_fog();
    doc["media"][0]["sigma_s"] = 0;  // absorbing only
    Plan p = make_plan(scene(doc));
    EXPECT_FALSE(p.volume_map.on);
    EXPECT_EQ(line(p, kVolume), "volume map: skipped (media do not scatter)");
    EXPECT_TRUE(p.ray_marching.on);

    doc["media"][0]["sigma_s"] = 0.05;
    doc["media"][0]["density_scale"] = 0;
    p = make_plan(scene(doc));
    EXPECT_EQ(line(p, kVolume), "volume map: skipped (media do not scatter)");

    doc.erase("media");
    p = make_plan(scene(doc));
    EXPECT_FALSE(p.volume_map.on);
    EXPECT_EQ(line(p, kVolume), "volume map: skipped (no participating medium)");
    EXPECT_FALSE(p.ray_marching.on);
    EXPECT_EQ(line(p, kMarching), "ray marching: skipped (no medium)");
}

TEST(Plan, FireAloneLightsTheMaps) {
    // No light at all: an emitting medium is a light source of its own, for every map.
    json doc = glass_floor_fog();
    doc["lights"] = json::array();
    doc["media"][0]["emission"] = json::parse(R"({"color": [1, 0.5, 0.1]})");
    const Plan p = make_plan(scene(doc));
    EXPECT_EQ(line(p, kVolumeLight), "volume light: built (1 emissive medium)");
    EXPECT_TRUE(p.volume_map.on) << p.volume_map.reason;
    EXPECT_TRUE(p.global_map.on) << p.global_map.reason;
    EXPECT_TRUE(p.caustic_map.on) << p.caustic_map.reason;
}

TEST(Plan, EmissionWithoutStrengthIsNoVolumeLight) {
    json doc = glass_floor_fog();
    doc["lights"] = json::array();
    for (const char* e : {R"({"color": [1, 0.5, 0.1], "scale": 0})", R"({"color": 0})"}) {
        doc["media"][0]["emission"] = json::parse(e);
        const Plan p = make_plan(scene(doc));
        EXPECT_EQ(line(p, kVolumeLight), "volume light: skipped (no medium emits)") << e;
        EXPECT_EQ(line(p, kVolume), "volume map: skipped (no light emits power)") << e;
    }
}

TEST(Plan, ZeroPowerLightsBuildNoMaps) {
    // Each light type's own power quantity decides; the others keep their defaults (1), so a
    // rule reading the wrong field would see power here.
    json doc = glass_floor_fog();
    doc["lights"] = json::parse(R"([
      {"type": "point", "intensity": 0},
      {"type": "spot", "intensity": [0, 0, 0]},
      {"type": "quad", "radiance": 0},
      {"type": "sun", "irradiance": 0},
      {"type": "environment", "radiance": 0}
    ])");
    const Plan p = make_plan(scene(doc));
    for (const PlanItem* item : {&p.volume_map, &p.global_map, &p.caustic_map}) {
        EXPECT_FALSE(item->on);
        EXPECT_EQ(item->reason, "no light emits power");
    }
    EXPECT_EQ(line(p, kVolume), "volume map: skipped (no light emits power)");
    EXPECT_EQ(line(p, kGlobal), "global map: skipped (no light emits power)");
    EXPECT_EQ(line(p, kCaustic), "caustic map: skipped (no light emits power)");
    EXPECT_TRUE(p.embree_scene.on);
    EXPECT_TRUE(p.ray_marching.on);

    // One channel of one light is enough, whatever its type.
    for (const char* light :
         {R"({"type": "spot", "intensity": [0, 0.5, 0]})",
          R"({"type": "quad", "radiance": [0, 0, 2]})", R"({"type": "sun", "irradiance": 3})",
          R"({"type": "environment", "radiance": 0.1})"}) {
        json lit = doc;
        lit["lights"].push_back(json::parse(light));
        const Plan q = make_plan(scene(lit));
        EXPECT_TRUE(q.volume_map.on) << light;
        EXPECT_TRUE(q.global_map.on) << light;
        EXPECT_TRUE(q.caustic_map.on) << light;
    }

    doc.erase("lights");  // no light at all
    EXPECT_EQ(line(make_plan(scene(doc)), kGlobal), "global map: skipped (no light emits power)");
}

TEST(Plan, PathIntegratorBuildsNoMapsAndDoesNotMarch) {
    json doc = glass_floor_fog();
    doc["render"] = json{{"integrator", "path"}};
    const Plan p = make_plan(scene(doc));
    EXPECT_TRUE(p.embree_scene.on);
    EXPECT_FALSE(p.ray_marching.on);
    EXPECT_EQ(line(p, kMarching),
              "ray marching: skipped (integrator is path: media use delta tracking)");
    EXPECT_FALSE(p.volume_map.on);
    EXPECT_EQ(line(p, kVolume), "volume map: skipped (integrator is path)");
    EXPECT_FALSE(p.global_map.on);
    EXPECT_EQ(line(p, kGlobal), "global map: skipped (integrator is path)");
    EXPECT_FALSE(p.caustic_map.on);
    EXPECT_EQ(line(p, kCaustic), "caustic map: skipped (integrator is path)");
}

TEST(Plan, GuidedIntegratorBuildsOnlyTheVolumeMap) {
    json doc = glass_floor_fog();
    doc["render"] = {{"integrator", "guided"}};
    const Plan plan = make_plan(scene(doc));
    EXPECT_TRUE(plan.volume_map.on);
    EXPECT_NE(plan.volume_map.reason.find("camera paths split in media"), std::string::npos);
    EXPECT_FALSE(plan.global_map.on);
    EXPECT_FALSE(plan.caustic_map.on);
    EXPECT_EQ(line(plan, kGlobal),
              "global map: skipped (integrator is guided: only media are guided)");
    EXPECT_TRUE(plan.ray_marching.on);
    EXPECT_NE(plan.ray_marching.reason.find("camera paths use delta tracking"), std::string::npos);
}

TEST(Plan, GlassFloorAndFogTurnEverythingOn) {
    const Plan p = make_plan(scene(glass_floor_fog()));
    EXPECT_TRUE(p.embree_scene.on);
    EXPECT_TRUE(p.ray_marching.on);
    EXPECT_TRUE(p.volume_map.on);
    EXPECT_TRUE(p.global_map.on);
    EXPECT_TRUE(p.caustic_map.on);
    EXPECT_EQ(plan_text(p),
              "integrator: photon (scene; adaptive sampling: a first pass of 8 spp, then the rest "
              "of render.spp's work where it shows the error)\n"
              "Embree scene: built (2 shapes)\n"
              "ray marching: used (1 medium; camera rays and photon free paths march)\n"
              "volume light: skipped (no medium emits)\n"
              "volume map: built (1 scattering medium, budget 100000 photons)\n"
              "global map: built (1 diffuse shape, budget 100000 photons)\n"
              "caustic map: built (1 specular shape, 1 diffuse receiver, budget 50000 photons)\n");
}

TEST(Plan, MarchingReasonNamesTheFreePathMethod) {
    json doc = glass_floor_fog();
    doc["march"] = json{{"method", "delta"}};
    const Plan p = make_plan(scene(doc));
    EXPECT_TRUE(p.ray_marching.on);
    EXPECT_EQ(line(p, kMarching),
              "ray marching: used (1 medium; camera rays march, photon free paths use delta "
              "tracking)");
    doc["march"] = json{{"method", "march"}};  // photon beams need exact free paths
    doc["volume"] = json{{"estimator", "photon_beams"}};
    EXPECT_EQ(line(make_plan(scene(doc)), kMarching),
              "ray marching: used (1 medium; camera rays march, photon free paths use delta "
              "tracking (photon beams))");
}

// Paths that end in the volume map trace surfaces themselves: no surface maps, and the camera side
// uses delta tracking.
TEST(Plan, GatherDepthEndsCameraPathsInTheVolumeMap) {
    json doc = glass_floor_fog();
    doc["volume"] = json{{"gather_depth", 2}};
    // The plan of the run as it runs: 640 x 360 x 16 spp = 3.7 M camera samples run as 3
    // iterations of 6 spp (iteration_size), each closing its map after a quarter of its 1.38 M.
    const Plan p = make_plan(scene(doc));
    EXPECT_EQ(line(p, kMarching),
              "ray marching: used (1 medium; photon free paths march, camera paths use ratio "
              "tracking (first segment) and delta tracking and end in the volume map)");
    EXPECT_EQ(
        line(p, kVolume),
        "volume map: built (1 scattering medium, budget 345600 photons (a photon per "
        "attempt: photons.volume not set); camera paths end "
        "in it at the medium vertex that is their vertex 2 (diffuse bounces count) or the "
        "first after it where its ball spans at most advanced.gather_tau = 1.5 scattering mean "
        "free paths (by vertex 8), looked up from "
        "a grid of its photons' moments (where more than 100 fall within its radius, within "
        "a smaller one holding about volume.k = 50); it closes after 345600 photon attempts "
        "(0.25 per camera sample, at least its budget) if not full before)");
    // A sun over VDB media: its shadow rays read the optical depth along it from a grid
    // (render/sun_shadows.h); advanced.sun_grid 0, or a homogeneous medium, keeps ratio tracking.
    json sunny = smoke_only();
    sunny["lights"].push_back(json{{"type", "sun"}, {"direction", {0, -1, 0}}, {"irradiance", 3}});
    sunny["volume"] = json{{"gather_depth", 3}};
    EXPECT_EQ(line(make_plan(scene(sunny)), kMarching),
              "ray marching: used (1 medium; photon free paths march, camera paths use ratio "
              "tracking (first segment) and delta tracking, take the sun's transmittance from a "
              "grid of optical depth along it (nodes advanced.sun_grid = 1 voxel apart) and end in "
              "the volume map)");
    sunny["advanced"]["sun_grid"] = 2.5;
    EXPECT_NE(line(make_plan(scene(sunny)), kMarching).find("advanced.sun_grid = 2.5 voxels apart"),
              std::string::npos);
    sunny["lights"][1]["angular_radius_deg"] = 2;  // a penumbra wider than a voxel's blur
    EXPECT_EQ(line(make_plan(scene(sunny)), kMarching).find("sun"), std::string::npos);
    sunny["lights"][1]["angular_radius_deg"] = 0.27;
    sunny["advanced"]["sun_grid"] = 0;
    EXPECT_EQ(line(make_plan(scene(sunny)), kMarching).find("sun"), std::string::npos);
    json homogeneous = doc;
    homogeneous["lights"] = sunny["lights"];
    EXPECT_EQ(line(make_plan(scene(homogeneous)), kMarching).find("sun"), std::string::npos);
    // (640 × 360 pixels × 16 spp / 4.) A radius the scene sets is kept at every lookup;
    // gather_tau 0 ends every path at vertex 2; a photons.max_emitted of the scene's own
    // replaces the attempts rule.
    doc["volume"]["radius"] = 0.5;
    doc["advanced"]["gather_tau"] = 0;
    doc["photons"]["max_emitted"] = 2000000;
    EXPECT_EQ(line(make_plan(scene(doc)), kVolume),
              "volume map: built (1 scattering medium, budget 100000 photons; camera paths end "
              "in it at the medium vertex that is their vertex 2 (diffuse bounces count), looked "
              "up from a grid of its photons' moments)");
    EXPECT_FALSE(p.global_map.on);
    EXPECT_EQ(line(p, kCaustic),
              "caustic map: skipped (volume.gather_depth 2: camera paths trace surfaces)");
}

/// glass_floor_fog with camera paths ending in the volume map at vertex 3, 400 × 300 at 64 spp.
json ending_in_the_map() {
    json doc = glass_floor_fog();
    doc["volume"] = json{{"gather_depth", 3}};
    doc["camera"]["width"] = 400;
    doc["camera"]["height"] = 300;
    doc["render"]["spp"] = 64;
    return doc;
}

// The volume map's attempts rule: a quarter of the camera samples, at least the budget, and none
// without paths ending in the map or with the scene's own max_emitted.
TEST(Plan, VolumeAttemptsFollowTheCameraSamples) {
    json doc = ending_in_the_map();
    EXPECT_EQ(volume_attempts(scene(doc)), 400u * 300u * 64u / 4u);
    doc["render"]["spp"] = 2;  // 60 000 attempts: the budget instead
    EXPECT_EQ(volume_attempts(scene(doc)), 100000u);
    doc["photons"]["max_emitted"] = 500000;
    EXPECT_EQ(volume_attempts(scene(doc)), 0u);
    doc["photons"].erase("max_emitted");
    doc["volume"]["gather_depth"] = 0;
    EXPECT_EQ(volume_attempts(scene(doc)), 0u);
}

// The volume map's budget under the attempts rule: a photon per attempt unless the scene (or
// --set) gives photons.volume, at most kVolumeRuleMaxPhotons; the scene's budget otherwise.
TEST(Plan, VolumeBudgetIsAPhotonPerAttemptUnlessTheSceneGivesOne) {
    json doc = ending_in_the_map();
    EXPECT_EQ(volume_budget(scene(doc)), 400u * 300u * 64u / 4u);
    doc["render"]["spp"] = 2;  // 60 000 attempts: at least the default budget's 100 000
    EXPECT_EQ(volume_budget(scene(doc)), 100000u);
    doc["render"]["spp"] = 4096;  // 123 million attempts
    EXPECT_EQ(volume_budget(scene(doc)), kVolumeRuleMaxPhotons);
    doc["render"]["spp"] = 64;
    json given = doc;
    given["photons"]["volume"] = 100000;  // the default's value, given: kept
    EXPECT_EQ(volume_budget(scene(given)), 100000u);
    apply_override(doc, "photons.volume=50000", "scene.json");  // as --set does
    EXPECT_EQ(volume_budget(scene(doc)), 50000u);
    doc["photons"].erase("volume");
    doc["volume"]["gather_depth"] = 0;  // no attempts rule: the default budget
    EXPECT_EQ(volume_budget(scene(doc)), 100000u);
}

// A progressive iteration's samples: the least multiple of render.spp that gives
// kIterationSamples camera samples where the volume map's photons follow the samples (the
// attempts rule's budget); for the photon gather where no medium emits the least multiple that
// gives kGatherIterationSpp; the scene's render.spp otherwise; advanced.iteration_spp when given.
TEST(Plan, IterationsTakeAMillionCameraSamplesWhereThePhotonsFollowThem) {
    json doc = ending_in_the_map();  // 400 x 300 = 120 000 pixels
    doc["progressive"]["time_budget"] = 10;
    doc["render"]["spp"] = 4;  // 480 000 samples: x3 gives 1 440 000, x2 960 000 < 2^20
    EXPECT_EQ(iteration_size(scene(doc)).spp, 12);
    doc["render"]["spp"] = 3;  // x3 = 9 spp: 1 080 000; 8 spp would not be a multiple of 3
    EXPECT_EQ(iteration_size(scene(doc)).spp, 9);
    doc["render"]["spp"] = 64;  // 7.7 million samples already
    EXPECT_EQ(iteration_size(scene(doc)).spp, 64);
    for (const int width : {1, 7, 160, 1023}) {  // the rule's two bounds, checked as products
        doc["camera"]["width"] = width;
        doc["camera"]["height"] = 1;
        doc["render"]["spp"] = 5;
        const int n = iteration_size(scene(doc)).spp;
        EXPECT_EQ(n % 5, 0) << width;
        EXPECT_GE(uint64_t(n) * width, kIterationSamples) << width;
        EXPECT_LT(uint64_t(n - 5) * width, kIterationSamples) << width;
    }
    doc = ending_in_the_map();
    doc["progressive"]["time_budget"] = 10;
    doc["render"]["spp"] = 4;
    doc["advanced"]["iteration_spp"] = 2;  // given: kept
    EXPECT_EQ(iteration_size(scene(doc)).spp, 2);
    EXPECT_NE(iteration_size(scene(doc)).reason.find("advanced.iteration_spp"), std::string::npos);
    doc["advanced"].erase("iteration_spp");
    apply_override(doc, "photons.volume=100000", "scene.json");  // the scene's budget: its spp
    EXPECT_EQ(iteration_size(scene(doc)).spp, 4);
    doc["photons"].erase("volume");
    EXPECT_EQ(iteration_size(scene(doc)).spp, 12);
    doc["volume"]["gather_depth"] = 1;  // no attempts rule: the scene's budgets and render.spp
    doc["photons"]["volume"] = 100000;
    EXPECT_EQ(iteration_size(scene(doc)).spp, 4);
    doc["volume"]["gather_depth"] = 0;  // the photon gather: at least 16 spp, whole render.spp's
    EXPECT_EQ(iteration_size(scene(doc)).spp, kGatherIterationSpp);
    EXPECT_NE(iteration_size(scene(doc)).reason.find("render.spp 4 times 4"), std::string::npos);
    doc["render"]["spp"] = 6;  // 18: 12 would be short of 16
    EXPECT_EQ(iteration_size(scene(doc)).spp, 18);
    doc["render"]["spp"] = 24;
    EXPECT_EQ(iteration_size(scene(doc)).spp, 24);
    doc["advanced"]["iteration_spp"] = 4;  // given: kept
    EXPECT_EQ(iteration_size(scene(doc)).spp, 4);
    doc["advanced"].erase("iteration_spp");
    doc["render"]["spp"] = 4;
    doc["media"][0]["emission"] = json::parse(R"({"kind": "constant", "color": [1, 1, 1]})");
    EXPECT_EQ(iteration_size(scene(doc)).spp, 4);  // a medium emits: its photons pay
}

// A plain render under the attempts rule with at least twice kIterationSamples camera samples
// runs as I = floor(samples / kIterationSamples) iterations, each of the least spp that keeps
// render.spp; one iteration below that, with the scene's budget or without the rule;
// advanced.iteration_spp given splits render.spp into iterations of it.
TEST(Plan, PlainRendersOfManySamplesSplitIntoIterationsOfAMillion) {
    json doc = ending_in_the_map();  // 400 x 300 = 120 000 pixels
    const uint64_t pixels = 120000;
    for (const int spp : {18, 64, 1000}) {
        doc["render"]["spp"] = spp;
        const IterationSize size = iteration_size(scene(doc));
        const uint64_t samples = pixels * uint64_t(spp);
        ASSERT_GE(size.iterations, 2) << spp;
        EXPECT_LE(uint64_t(size.iterations) * kIterationSamples, samples) << spp;
        EXPECT_GT(uint64_t(size.iterations + 1) * kIterationSamples, samples) << spp;
        EXPECT_GE(size.spp * size.iterations, spp) << spp;
        EXPECT_LT((size.spp - 1) * size.iterations, spp) << spp;
        EXPECT_NE(size.reason.find("as " + std::to_string(size.iterations) + " progressive"),
                  std::string::npos)
            << size.reason;
    }
    doc["render"]["spp"] = 1 << 30;  // 1.3e14 samples: at most kMaxProgressiveIterations
    EXPECT_EQ(iteration_size(scene(doc)).iterations, kMaxProgressiveIterations);
    EXPECT_EQ(iteration_size(scene(doc)).spp, (1 << 30) / kMaxProgressiveIterations + 1);
    doc["render"]["spp"] = 64;  // 7 680 000 samples: 7 iterations of 10 spp
    EXPECT_EQ(iteration_size(scene(doc)).iterations, 7);
    EXPECT_EQ(iteration_size(scene(doc)).spp, 10);
    doc["render"]["spp"] = 17;  // 2 040 000 samples < 2^21: one iteration
    EXPECT_EQ(iteration_size(scene(doc)).iterations, 1);
    EXPECT_EQ(iteration_size(scene(doc)).spp, 17);
    EXPECT_EQ(iteration_size(scene(doc)).reason, "");
    doc["render"]["spp"] = 64;
    doc["advanced"]["iteration_spp"] = 24;  // given: 3 iterations of 24
    EXPECT_EQ(iteration_size(scene(doc)).iterations, 3);
    EXPECT_EQ(iteration_size(scene(doc)).spp, 24);
    doc["advanced"]["iteration_spp"] = 64;  // given as render.spp: one iteration
    EXPECT_EQ(iteration_size(scene(doc)).iterations, 1);
    doc["advanced"].erase("iteration_spp");
    json given = doc;
    given["photons"]["volume"] = 100000;  // the scene's budget: one iteration
    EXPECT_EQ(iteration_size(scene(given)).iterations, 1);
    doc["volume"]["gather_depth"] = 0;  // no attempts rule
    EXPECT_EQ(iteration_size(scene(doc)).iterations, 1);
}

// The volume map's k with paths ending in it: twice volume.k where a medium's phase function
// weighs fewer than a fifth of the photons gathered ((1 - g²)² / (1 + g²) < 0.2: |g| above
// 0.678), unless the scene gives k; volume.k otherwise.
TEST(Plan, VolumeKDoublesForAPeakedPhaseFunctionUnlessTheSceneGivesOne) {
    json doc = glass_floor_fog();
    doc["volume"] = json{{"gather_depth", 3}};
    EXPECT_EQ(volume_k(scene(doc)), 50);  // the fog's g is 0
    doc["media"][0]["g"] = 0.5;           // beyond the moment grid, its share still 0.45
    EXPECT_EQ(volume_k(scene(doc)), 50);
    doc["media"][0]["g"] = 0.67;  // share 0.2096
    EXPECT_EQ(volume_k(scene(doc)), 50);
    doc["media"][0]["g"] = -0.69;  // share 0.1859
    EXPECT_EQ(volume_k(scene(doc)), 100);
    EXPECT_NE(line(make_plan(scene(doc)), kVolume)
                  .find("a smaller one holding about 100 (twice volume.k for a peaked phase "
                        "function)"),
              std::string::npos);
    apply_override(doc, "volume.k=30", "scene.json");  // as --set does
    EXPECT_EQ(volume_k(scene(doc)), 30);
    doc["volume"].erase("k");
    doc["volume"]["gather_depth"] = 0;  // camera rays see the map: volume.k
    EXPECT_EQ(volume_k(scene(doc)), 50);
}

TEST(Plan, QuadLightAloneNeedsAnEmbreeScene) {
    // An area light is geometry the camera can hit, even without any shape.
    const Plan p = make_plan(scene(json::parse(R"({
      "lights": [{"type": "quad", "corner": [0, 2, 0], "radiance": 1},
                 {"type": "quad", "corner": [1, 2, 0], "radiance": 1}]})")));
    EXPECT_TRUE(p.embree_scene.on);
    EXPECT_EQ(line(p, kEmbree), "Embree scene: built (2 quad lights)");

    json doc = glass_floor_fog();
    doc["lights"].push_back(json::parse(R"({"type": "quad", "corner": [0, 2, 0]})"));
    EXPECT_EQ(line(make_plan(scene(doc)), kEmbree), "Embree scene: built (2 shapes, 1 quad light)");
}

// render.integrator = "auto" picks by the measured rules (plan.h, choose_integrator): caustics
// from small lights → photon; a point or spot light in a medium → photon; media under sun and
// sky → photon with camera paths ending in the volume map; no medium → path; a scene that names
// an integrator keeps it. The plan's first line says which and why.
TEST(Plan, AutoPicksTheIntegratorAndSaysWhy) {
    auto pick = [](json doc) {
        doc["render"]["integrator"] = "auto";
        SceneDesc d = scene_desc_from_json(doc, "scene.json");
        validate(d);
        return make_plan(d);
    };
    const Plan caustics = pick(glass_floor_fog());  // glass, floor, point light (and fog)
    EXPECT_EQ(std::string(caustics.integrator_name), "photon");
    EXPECT_NE(caustics.integrator.reason.find("caustics"), std::string::npos);
    EXPECT_TRUE(caustics.caustic_map.on);

    const Plan fog = pick(smoke_only());  // a point light and a medium
    EXPECT_EQ(std::string(fog.integrator_name), "photon");
    EXPECT_NE(fog.integrator.reason.find("point or spot light in a medium"), std::string::npos);

    json sunlit = smoke_only();
    sunlit["lights"] = json::parse(R"([{"type": "sun", "direction": [0, -1, 0], "irradiance": 3,
                                        "angular_radius_deg": 0.27},
                                       {"type": "environment", "radiance": 0.2}])");
    const Plan smoke = pick(sunlit);
    EXPECT_EQ(std::string(smoke.integrator_name), "photon");
    EXPECT_TRUE(smoke.volume_map.on);
    EXPECT_EQ(line(smoke, kIntegrator).rfind("integrator: photon (auto: media under sun", 0), 0u)
        << line(smoke, kIntegrator);
    EXPECT_NE(line(smoke, kVolume)
                  .find("camera paths end in it at the medium vertex that is their vertex 3 "
                        "(diffuse bounces count) or the first after it "
                        "where its ball spans at most advanced.gather_tau = 1.5 scattering mean "
                        "free paths (by vertex 12), looked up from a grid of its photons' "
                        "moments"),
              std::string::npos)
        << line(smoke, kVolume);
    json forward = sunlit;  // the moments' series cut after l = 2 would miss too much
    forward["media"][0]["g"] = 0.85;
    EXPECT_NE(
        line(pick(forward), kVolume)
            .find("looked up in its kd-tree (a medium's |g| above 0.4) (where more than 200 fall "
                  "within its radius, within a smaller one holding about 100 (twice volume.k"),
        std::string::npos)
        << line(pick(forward), kVolume);
    json beams = sunlit;  // photon beams gather along marched camera rays: no depth
    beams["volume"]["estimator"] = "photon_beams";
    EXPECT_EQ(line(pick(beams), kVolume).find("camera paths end"), std::string::npos);

    json vacuum = sunlit;
    vacuum["media"] = json::array();
    EXPECT_EQ(std::string(pick(vacuum).integrator_name), "path");

    json fire = sunlit;  // sun and sky, and the smoke glows
    fire["media"][0]["emission"] = json::parse(R"({"grid": "temperature"})");
    const Plan fireball = pick(fire);
    EXPECT_EQ(std::string(fireball.integrator_name), "photon");
    EXPECT_NE(fireball.integrator.reason.find("an emitting medium"), std::string::npos);

    json named = sunlit;
    named["render"]["integrator"] = "photon";
    SceneDesc d = scene_desc_from_json(named, "scene.json");
    validate(d);
    EXPECT_EQ(line(make_plan(d), kIntegrator),
              "integrator: photon (scene; adaptive sampling: a first pass of 8 spp, then the rest "
              "of render.spp's work where it shows the error)");
}

TEST(Plan, JsonHasOneEntryPerItem) {
    const Plan p = make_plan(scene(smoke_only()));
    const json j = plan_json(p);
    EXPECT_EQ(j, json::parse(R"({
      "integrator": {"name": "photon", "reason": "scene; adaptive sampling: a first pass of 8 spp, then the rest of render.spp's work where it shows the error"},
      "embree_scene": {"on": false, "reason": "no surfaces"},
      "ray_marching": {"on": true, "reason": "1 medium; camera rays and photon free paths march"},
      "volume_light": {"on": false, "reason": "no medium emits"},
      "volume_map": {"on": true, "reason": "1 scattering medium, budget 100000 photons"},
      "global_map": {"on": false, "reason": "no diffuse surface"},
      "caustic_map": {"on": false, "reason": "no specular surface"}
    })"));
}

}  // namespace
}  // namespace fogmap
