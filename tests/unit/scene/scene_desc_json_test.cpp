#include "scene/scene_desc_json.h"

#include "core/error.h"
#include "test_support.h"

#include <gtest/gtest.h>

#include <unistd.h>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <string>

namespace fogmap {
namespace {

using nlohmann::json;

using test::catch_input_error;

InputError parse_error(const json& doc) {
    return catch_input_error([&] { scene_desc_from_json(doc, "scene.json"); });
}

InputError validate_error(const json& doc) {
    return catch_input_error([&] { validate(scene_desc_from_json(doc, "scene.json")); });
}

/// A temp folder per test, removed at the end.
struct TempDir : test::TempDir {
    TempDir() : test::TempDir("fogmap_scene") {}
    std::string path() const { return test::TempDir::path().string(); }
};

/// A scene that uses every light, material, shape and medium type, with non-default values.
json full_scene() {
    return json::parse(R"({
      "camera": {"position": [1, 2, 3], "look_at": [0, 0.5, 0], "up": [0, 1, 0],
                 "fov_deg": 35.5, "width": 320, "height": 200},
      "lights": [
        {"type": "point", "intensity": [1, 2, 3], "position": [0, 4, 0]},
        {"type": "spot", "intensity": 7, "position": [1, 4, 0], "direction": [0, -1, 0],
         "cone_angle_deg": 20, "cone_delta_deg": 2.5},
        {"type": "quad", "corner": [-1, 3, -1], "edge_u": [2, 0, 0], "edge_v": [0, 0, 2],
         "radiance": [5, 4, 3]},
        {"type": "sun", "direction": [0.1, -1, 0.2], "irradiance": 3.25,
         "angular_radius_deg": 0.27},
        {"type": "environment", "radiance": [0.1, 0.2, 0.3]}
      ],
      "materials": {
        "floor": {"type": "diffuse", "albedo": [0.7, 0.6, 0.5]},
        "chrome": {"type": "mirror", "albedo": 0.9},
        "water": {"type": "glass", "ior": 1.33}
      },
      "shapes": [
        {"type": "quad", "material": "floor", "corner": [-5, 0, -5], "edge_u": [10, 0, 0],
         "edge_v": [0, 0, 10]},
        {"type": "box", "material": "chrome", "min": [0, 0, 0], "max": [1, 2, 3],
         "transform": {"translate": [1, 0, 0], "rotate_deg": [0, 45, 0], "scale": 0.5}},
        {"type": "sphere", "material": "water", "center": [0, 1, 0], "radius": 0.75},
        {"type": "mesh", "material": "floor", "file": "bunny.ply"}
      ],
      "media": [
        {"type": "vdb", "file": "smoke.vdb", "grid": "dens", "density_scale": 2.5,
         "sigma_s": [1, 2, 3], "sigma_a": 0.25, "g": 0.6,
         "transform": {"matrix": [1, 0, 0, 4, 0, 2, 0, 5, 0, 0, 3, 6, 0, 0, 0, 1]}},
        {"type": "homogeneous", "bounds": {"min": [-1, 0, -1], "max": [1, 2, 1]},
         "density_scale": 0.5, "sigma_s": 0.1, "sigma_a": [0.01, 0.02, 0.03], "g": -0.3}
      ],
      "render": {"integrator": "path", "spp": 64, "max_depth": 12,
                 "seed": 18446744073709551615, "threads": 3, "adaptive": false},
      "photons": {"global": 2000, "caustic": 3000, "volume": 4000, "max_emitted": 900000,
                  "max_bounces": 7},
      "global": {"k": 80, "radius": 0.125, "final_gather": true, "gather_rays": 16},
      "caustic": {"k": 40, "radius": 0.0625, "cone_filter": 1.5},
      "volume": {"k": 30, "radius": 0.25, "estimator": "sphere", "gather_depth": 2},
      "march": {"method": "delta", "step_voxels": 0.5, "step_world": 0.01},
      "progressive": {"iterations": 0, "time_budget": 0, "target_relmse": 0, "alpha": 0.5},
      "advanced": {"map_spp": 2, "guide_vertices": 2, "lookups_per_ray": 5, "light_samples": 3,
                   "gather_tau": 0.75, "sun_grid": 2.5, "iteration_spp": 24}
    })");
}

void expect_mat_near(const Mat4& a, const float (&row_major)[16], float tol) {
    for (int r = 0; r < 4; ++r) {
        for (int c = 0; c < 4; ++c) {
            EXPECT_NEAR(a[c][r], row_major[r * 4 + c], tol) << "row " << r << " col " << c;
        }
    }
}

TEST(SceneDescJson, ReadsEveryFieldOfAFullScene) {
    const SceneDesc d = scene_desc_from_json(full_scene(), "scenes/demo/full.json");
    EXPECT_EQ(d.path, "scenes/demo/full.json");
    EXPECT_EQ(d.base_dir, "scenes/demo");
    EXPECT_EQ(d.camera.position, Vec3(1, 2, 3));
    EXPECT_EQ(d.camera.fov_deg, 35.5f);
    EXPECT_EQ(d.camera.width, 320);
    ASSERT_EQ(d.lights.size(), 5u);
    EXPECT_EQ(d.lights[1].type, LightType::Spot);
    EXPECT_EQ(d.lights[1].intensity, Color(7.0f));
    EXPECT_EQ(d.lights[1].cone_delta_deg, 2.5f);
    EXPECT_EQ(d.lights[2].radiance, Color(5, 4, 3));
    EXPECT_EQ(d.lights[3].irradiance, Color(3.25f));
    EXPECT_EQ(d.lights[3].angular_radius_deg, 0.27f);
    EXPECT_EQ(d.lights[4].type, LightType::Environment);
    ASSERT_EQ(d.materials.size(), 3u);
    EXPECT_EQ(d.materials.at("chrome").type, MaterialType::Mirror);
    EXPECT_EQ(d.materials.at("chrome").albedo, Color(0.9f));
    EXPECT_EQ(d.materials.at("water").ior, 1.33f);
    ASSERT_EQ(d.shapes.size(), 4u);
    EXPECT_EQ(d.shapes[1].max, Vec3(1, 2, 3));
    EXPECT_EQ(d.shapes[2].radius, 0.75f);
    EXPECT_EQ(d.shapes[3].file, "bunny.ply");
    ASSERT_EQ(d.media.size(), 2u);
    EXPECT_EQ(d.media[0].grid, "dens");
    EXPECT_EQ(d.media[0].sigma_a, Color(0.25f));
    expect_mat_near(d.media[0].transform.matrix, {1, 0, 0, 4, 0, 2, 0, 5, 0, 0, 3, 6, 0, 0, 0, 1},
                    0.0f);
    ASSERT_TRUE(d.media[1].bounds.has_value());
    EXPECT_EQ(d.media[1].bounds->hi, Vec3(1, 2, 1));
    EXPECT_FALSE(d.media[0].bounds.has_value());
    EXPECT_EQ(d.render.spp, 64);
    EXPECT_EQ(d.render.map_spp, 2);
    EXPECT_EQ(d.render.seed, 18446744073709551615ull);
    EXPECT_EQ(d.render.threads, 3);
    EXPECT_EQ(d.render.integrator, Integrator::Path);
    EXPECT_EQ(d.photons.global, 2000u);
    EXPECT_EQ(d.photons.caustic, 3000u);
    EXPECT_EQ(d.photons.volume, 4000u);
    EXPECT_EQ(d.photons.max_emitted, 900000u);
    EXPECT_EQ(d.photons.max_bounces, 7);
    EXPECT_EQ(d.global.k, 80);
    EXPECT_EQ(d.global.radius, 0.125f);
    EXPECT_TRUE(d.global.final_gather);
    EXPECT_EQ(d.global.gather_rays, 16);
    EXPECT_EQ(d.caustic.k, 40);
    EXPECT_EQ(d.caustic.radius, 0.0625f);
    EXPECT_EQ(d.caustic.cone_filter, 1.5f);
    EXPECT_EQ(d.volume.k, 30);
    EXPECT_EQ(d.volume.radius, 0.25f);
    EXPECT_EQ(d.volume.lookups_per_ray, 5);
    EXPECT_EQ(d.volume.gather_tau, 0.75f);
    EXPECT_EQ(d.volume.sun_grid, 2.5f);
    EXPECT_EQ(d.volume.light_samples, 3);
    EXPECT_EQ(d.progressive.alpha, 0.5f);
    EXPECT_EQ(d.progressive.spp, 24);
    EXPECT_EQ(d.volume.estimator, VolumeEstimator::Sphere);
    EXPECT_EQ(d.march.method, FreePathMethod::Delta);
    EXPECT_EQ(d.march.step_voxels, 0.5f);
    EXPECT_EQ(d.march.step_world, 0.01f);
    EXPECT_NO_THROW(validate(d));
}

TEST(SceneDescJson, FullSceneRoundTripsThroughToJson) {
    const SceneDesc a = scene_desc_from_json(full_scene(), "full.json");
    const json j = to_json(a);
    const SceneDesc b = scene_desc_from_json(j, "full.json");
    // Field by field against the first reading, then the JSON as a whole (a fixed point).
    EXPECT_EQ(b.camera.look_at, a.camera.look_at);
    EXPECT_EQ(b.camera.fov_deg, a.camera.fov_deg);
    ASSERT_EQ(b.lights.size(), a.lights.size());
    for (size_t i = 0; i < a.lights.size(); ++i) {
        EXPECT_EQ(b.lights[i].type, a.lights[i].type);
        EXPECT_EQ(b.lights[i].intensity, a.lights[i].intensity);
        EXPECT_EQ(b.lights[i].direction, a.lights[i].direction);
        EXPECT_EQ(b.lights[i].radiance, a.lights[i].radiance);
        EXPECT_EQ(b.lights[i].edge_v, a.lights[i].edge_v);
        EXPECT_EQ(b.lights[i].angular_radius_deg, a.lights[i].angular_radius_deg);
    }
    for (const auto& [name, m] : a.materials) {
        EXPECT_EQ(b.materials.at(name).albedo, m.albedo);
        EXPECT_EQ(b.materials.at(name).ior, m.ior);
    }
    ASSERT_EQ(b.shapes.size(), a.shapes.size());
    for (size_t i = 0; i < a.shapes.size(); ++i) {
        EXPECT_EQ(b.shapes[i].type, a.shapes[i].type);
        EXPECT_EQ(b.shapes[i].material, a.shapes[i].material);
        EXPECT_EQ(b.shapes[i].transform.matrix, a.shapes[i].transform.matrix);
    }
    ASSERT_EQ(b.media.size(), a.media.size());
    for (size_t i = 0; i < a.media.size(); ++i) {
        EXPECT_EQ(b.media[i].sigma_s, a.media[i].sigma_s);
        EXPECT_EQ(b.media[i].g, a.media[i].g);
        EXPECT_EQ(b.media[i].transform.matrix, a.media[i].transform.matrix);
        EXPECT_EQ(b.media[i].bounds.has_value(), a.media[i].bounds.has_value());
    }
    EXPECT_EQ(b.render.seed, a.render.seed);
    EXPECT_EQ(b.render.integrator, a.render.integrator);
    EXPECT_EQ(b.render.guide_vertices, 2);
    EXPECT_FALSE(b.render.adaptive);
    EXPECT_EQ(b.photons.volume, a.photons.volume);
    EXPECT_EQ(b.photons.max_emitted, a.photons.max_emitted);
    EXPECT_EQ(b.photons.max_bounces, a.photons.max_bounces);
    EXPECT_EQ(b.global.final_gather, a.global.final_gather);
    EXPECT_EQ(b.global.gather_rays, a.global.gather_rays);
    EXPECT_EQ(b.caustic.cone_filter, a.caustic.cone_filter);
    EXPECT_EQ(b.volume.k, a.volume.k);
    EXPECT_EQ(b.volume.radius, a.volume.radius);
    EXPECT_EQ(b.march.method, a.march.method);
    EXPECT_EQ(b.march.step_world, a.march.step_world);
    EXPECT_EQ(to_json(b), j);
    // Every key of the input is written back, with the same values.
    EXPECT_EQ(j["photons"], full_scene()["photons"]);
    EXPECT_EQ(j["global"], full_scene()["global"]);
    EXPECT_EQ(j["caustic"], full_scene()["caustic"]);
    EXPECT_EQ(j["volume"], full_scene()["volume"]);
    EXPECT_EQ(j["march"], full_scene()["march"]);
    EXPECT_EQ(j["progressive"], full_scene()["progressive"]);
    EXPECT_EQ(j["render"], full_scene()["render"]);
    // Floats print as the shortest decimal that reads back the same: 0.27, not 0.27000001.
    EXPECT_EQ(j["lights"][3]["angular_radius_deg"].dump(), "0.27");
}

TEST(SceneDescJson, EmptyDocumentGivesDefaults) {
    const SceneDesc d = scene_desc_from_json(json::object(), "scene.json");
    const SceneDesc defaults;
    EXPECT_EQ(d.camera.fov_deg, defaults.camera.fov_deg);
    EXPECT_EQ(d.render.spp, defaults.render.spp);
    EXPECT_TRUE(d.lights.empty());
    EXPECT_EQ(d.base_dir, "");
}

// photons.volume and volume.k given at their default values are not the defaults left to a rule
// (render/run_setup.h, volume_budget and volume_k): the scene reads which.
TEST(SceneDescJson, GivenDefaultsAreToldFromDefaultsLeftToARule) {
    const SceneDesc left = scene_desc_from_json(json::object(), "scene.json");
    const SceneDesc given =
        scene_desc_from_json(json{{"photons", {{"volume", kDefaultVolumePhotons}}},
                                  {"volume", {{"k", kDefaultVolumeK}}}},
                             "scene.json");
    EXPECT_FALSE(left.photons.volume || left.volume.k);
    EXPECT_TRUE(given.photons.volume && given.volume.k);
    EXPECT_EQ(given.photons.volume_or_default(), left.photons.volume_or_default());
    EXPECT_EQ(given.volume.k_or_default(), left.volume.k_or_default());
    // Written back only where given, so a file read and written keeps its rules.
    EXPECT_FALSE(to_json(left)["photons"].contains("volume"));
    EXPECT_EQ(scene_desc_from_json(to_json(given), "scene.json").photons.volume,
              given.photons.volume);
}

// The research knobs live in one "advanced" object; a scene that gives one where it stood before
// is told where it went, by its JSON pointer.
TEST(SceneDescJson, ResearchKnobsInTheirOldPlacesSayWhereTheyMoved) {
    const std::pair<const char*, const char*> moved[] = {
        {R"({"render": {"map_spp": 2}})", "/render/map_spp"},
        {R"({"render": {"guide_vertices": 1}})", "/render/guide_vertices"},
        {R"({"volume": {"lookups_per_ray": 4}})", "/volume/lookups_per_ray"},
        {R"({"volume": {"light_samples": 2}})", "/volume/light_samples"},
        {R"({"volume": {"gather_tau": 1}})", "/volume/gather_tau"},
        {R"({"volume": {"sun_grid": 2}})", "/volume/sun_grid"},
        {R"({"progressive": {"spp": 8}})", "/progressive/spp"}};
    for (const auto& [text, pointer] : moved) {
        SCOPED_TRACE(text);
        const InputError e = parse_error(json::parse(text));
        EXPECT_EQ(e.field, pointer);
        EXPECT_EQ(e.reason.rfind("moved to \"advanced\": {\"", 0), 0u) << e.reason;
    }
    EXPECT_NE(
        parse_error(json::parse(R"({"progressive": {"spp": 8}})")).reason.find("iteration_spp"),
        std::string::npos);
}

TEST(SceneDescJson, UnknownKeyNamesPointerAndListsKnownKeys) {
    const InputError e = parse_error(json::parse(R"({"render": {"spp_count": 4}})"));
    EXPECT_EQ(e.file, "scene.json");
    EXPECT_EQ(e.field, "/render/spp_count");
    EXPECT_EQ(e.reason,
              "unknown key 'spp_count'; known keys: adaptive, integrator, max_depth, seed, spp, "
              "threads");

    const InputError top = parse_error(json::parse(R"({"medias": []})"));
    EXPECT_EQ(top.field, "/medias");
    EXPECT_EQ(top.reason,
              "unknown key 'medias'; known keys: advanced, camera, caustic, global, lights, march, "
              "materials, media, photons, progressive, render, shapes, volume");

    const InputError volume = parse_error(json::parse(R"({"volume": {"kk": 64}})"));
    EXPECT_EQ(volume.field, "/volume/kk");
    EXPECT_EQ(volume.reason, "unknown key 'kk'; known keys: estimator, gather_depth, k, radius");

    const InputError photons = parse_error(json::parse(R"({"photons": {"surface": 10}})"));
    EXPECT_EQ(photons.field, "/photons/surface");
    EXPECT_EQ(photons.reason,
              "unknown key 'surface'; known keys: caustic, global, max_bounces, max_emitted, "
              "volume");
}

TEST(SceneDescJson, FieldsOfAnotherTypeAreUnknownKeys) {
    const InputError e = parse_error(
        json::parse(R"({"lights": [{"type": "point"}, {"type": "sun", "intensity": 2}]})"));
    EXPECT_EQ(e.field, "/lights/1/intensity");
    EXPECT_EQ(e.reason,
              "unknown key 'intensity'; known keys: angular_radius_deg, direction, "
              "irradiance, type");

    const InputError m = parse_error(json::parse(R"({"materials": {"g": {"type": "glass",
                                                      "albedo": 0.5}}})"));
    EXPECT_EQ(m.field, "/materials/g/albedo");
    EXPECT_EQ(m.reason, "unknown key 'albedo'; known keys: ior, type");

    const InputError h = parse_error(json::parse(R"({"media": [{"type": "homogeneous",
                                                      "file": "x.vdb"}]})"));
    EXPECT_EQ(h.field, "/media/0/file");
    EXPECT_EQ(h.reason,
              "unknown key 'file'; known keys: bounds, density_scale, emission, g, "
              "sigma_a, sigma_s, type");
}

TEST(SceneDescJson, WrongTypeNamesPointerAndFoundValue) {
    const InputError s = parse_error(json::parse(R"({"media": [{"type": "vdb", "file": "a.vdb",
                                                      "sigma_s": "abc"}]})"));
    EXPECT_EQ(s.field, "/media/0/sigma_s");
    EXPECT_EQ(s.reason, "expected a number or [r, g, b], found string \"abc\"");

    const InputError v = parse_error(json::parse(R"({"camera": {"position": [0, "x", 0]}})"));
    EXPECT_EQ(v.field, "/camera/position/1");
    EXPECT_EQ(v.reason, "expected a number, found string \"x\"");

    const InputError i = parse_error(json::parse(R"({"render": {"spp": 2.5}})"));
    EXPECT_EQ(i.field, "/render/spp");
    EXPECT_EQ(i.reason, "expected an integer, found number 2.5");

    const InputError a = parse_error(json::parse(R"({"lights": {"type": "point"}})"));
    EXPECT_EQ(a.field, "/lights");
    EXPECT_EQ(a.reason, "expected an array, found object");

    const InputError n = parse_error(json::parse(R"({"render": {"seed": -1}})"));
    EXPECT_EQ(n.field, "/render/seed");
}

TEST(SceneDescJson, NonFiniteNumbersAreRejected) {
    json doc = json::parse(R"({"camera": {"fov_deg": 40}})");
    doc["camera"]["fov_deg"] = std::nan("");
    EXPECT_EQ(parse_error(doc).field, "/camera/fov_deg");
    doc["camera"]["fov_deg"] = 1e39;  // finite as a double, infinite as a float
    const InputError e = parse_error(doc);
    EXPECT_EQ(e.field, "/camera/fov_deg");
    EXPECT_NE(e.reason.find("finite"), std::string::npos) << e.reason;
}

TEST(SceneDescJson, UnknownEnumValueListsAllChoices) {
    const InputError e = parse_error(json::parse(R"({"lights": [{"type": "laser"}]})"));
    EXPECT_EQ(e.field, "/lights/0/type");
    EXPECT_EQ(e.reason,
              "unknown light type 'laser'; expected one of: point, spot, quad, sun, "
              "environment");

    const InputError missing = parse_error(json::parse(R"({"shapes": [{"material": "m"}]})"));
    EXPECT_EQ(missing.field, "/shapes/0/type");
    EXPECT_EQ(missing.reason,
              "missing key 'type'; expected one of: quad, box, sphere, mesh "
              "(shape type)");

    const InputError integrator = parse_error(json::parse(R"({"render": {"integrator": 1}})"));
    EXPECT_EQ(integrator.field, "/render/integrator");
    EXPECT_EQ(integrator.reason,
              "expected one of: auto, path, photon, guided (integrator), found number 1");

    const InputError path = parse_error(json::parse(R"({"render": {"integrator": "bdpt"}})"));
    EXPECT_EQ(path.field, "/render/integrator");
    EXPECT_EQ(path.reason,
              "unknown integrator 'bdpt'; expected one of: auto, path, photon, guided");

    const InputError estimator = parse_error(json::parse(R"({"volume": {"estimator": "cone"}})"));
    EXPECT_EQ(estimator.field, "/volume/estimator");
    EXPECT_EQ(estimator.reason,
              "unknown volume estimator 'cone'; expected one of: sphere, beam, photon_beams");

    const InputError method = parse_error(json::parse(R"({"march": {"method": "ratio"}})"));
    EXPECT_EQ(method.field, "/march/method");
    EXPECT_EQ(method.reason, "unknown free path method 'ratio'; expected one of: march, delta");
}

TEST(SceneDescJson, NewSettingsDefaultToTheAutoIntegrator) {
    const SceneDesc d = scene_desc_from_json(json::object(), "scene.json");
    EXPECT_EQ(d.render.integrator, Integrator::Auto);
    EXPECT_EQ(d.march.method, FreePathMethod::March);
    EXPECT_NO_THROW(validate(d));
    // Each enum value reads back from its own name.
    const SceneDesc p = scene_desc_from_json(
        json::parse(R"({"render": {"integrator": "photon"}, "march": {"method": "march"}})"),
        "scene.json");
    EXPECT_EQ(p.render.integrator, Integrator::Photon);
    EXPECT_EQ(p.march.method, FreePathMethod::March);
}

TEST(SceneDescJson, SettingsJsonHoldsEveryEffectiveSetting) {
    const SceneDesc d = scene_desc_from_json(full_scene(), "scene.json");
    const json s = settings_json(d);
    const json full = full_scene();
    EXPECT_EQ(s, (json{{"render", full["render"]},
                       {"photons", full["photons"]},
                       {"global", full["global"]},
                       {"caustic", full["caustic"]},
                       {"volume", full["volume"]},
                       {"march", full["march"]},
                       {"progressive", full["progressive"]},
                       {"advanced", full["advanced"]}}));

    // Defaults are written too, but for the keys a rule sets when absent.
    const json defaults = settings_json(SceneDesc{});
    EXPECT_EQ(defaults["render"]["integrator"], "auto");
    EXPECT_FALSE(defaults["photons"].contains("volume"));
    EXPECT_EQ(defaults["global"]["final_gather"], false);
    EXPECT_EQ(defaults["caustic"]["cone_filter"], 0.0);
    EXPECT_EQ(defaults["volume"]["estimator"], "beam");
    EXPECT_EQ(defaults["march"]["method"], "march");
    EXPECT_EQ(defaults["march"]["step_voxels"], 1.0);
}

TEST(SceneDescJson, NegativePhotonBudgetIsRejectedByTheReader) {
    const InputError e = parse_error(json::parse(R"({"photons": {"volume": -5}})"));
    EXPECT_EQ(e.field, "/photons/volume");
    EXPECT_EQ(e.reason, "expected a non-negative integer (64 bits), found -5");

    const InputError f = parse_error(json::parse(R"({"photons": {"max_emitted": 1.5}})"));
    EXPECT_EQ(f.field, "/photons/max_emitted");
    EXPECT_EQ(f.reason, "expected a non-negative integer, found number 1.5");
}

TEST(SceneDescJson, TransformComposesScaleRotationsTranslation) {
    // M = T * Rz * Ry * Rx * S. By hand: S maps (x, y, z) to (x, 2y, 3z); Rx(90) then Ry(90)
    // then Rz(90) map (x, y, z) to (z, y, -x); T adds (10, 20, 30). So the point (x, y, z) goes
    // to (3z + 10, 2y + 20, -x + 30).
    const json doc = json::parse(R"({"shapes": [{"type": "box", "material": "m",
        "transform": {"translate": [10, 20, 30], "rotate_deg": [90, 90, 90],
                      "scale": [1, 2, 3]}}]})");
    const float expected[16] = {0, 0, 3, 10, 0, 2, 0, 20, -1, 0, 0, 30, 0, 0, 0, 1};
    expect_mat_near(scene_desc_from_json(doc, "s.json").shapes[0].transform.matrix, expected,
                    1e-5f);

    // Single rotations follow the right-hand rule: Rz(90) maps x to y.
    const json rz = json::parse(R"({"shapes": [{"type": "box", "material": "m",
        "transform": {"rotate_deg": [0, 0, 90], "scale": 2}}]})");
    const float expected_rz[16] = {0, -2, 0, 0, 2, 0, 0, 0, 0, 0, 2, 0, 0, 0, 0, 1};
    expect_mat_near(scene_desc_from_json(rz, "s.json").shapes[0].transform.matrix, expected_rz,
                    1e-5f);
}

TEST(SceneDescJson, TransformMatrixExcludesOtherKeys) {
    const InputError e = parse_error(json::parse(R"({"shapes": [{"type": "box", "material": "m",
        "transform": {"matrix": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1], "scale": 2}}]})"));
    EXPECT_EQ(e.field, "/shapes/0/transform/scale");
    EXPECT_NE(e.reason.find("cannot be combined with 'matrix'"), std::string::npos) << e.reason;

    const InputError n = parse_error(json::parse(R"({"shapes": [{"type": "box", "material": "m",
        "transform": {"matrix": [1, 0, 0]}}]})"));
    EXPECT_EQ(n.field, "/shapes/0/transform/matrix");
    EXPECT_EQ(n.reason, "expected 16 numbers (row-major 4x4), found array of 3 elements");

    const InputError k = parse_error(json::parse(R"({"shapes": [{"type": "box", "material": "m",
        "transform": {"rotate": [0, 1, 0]}}]})"));
    EXPECT_EQ(k.field, "/shapes/0/transform/rotate");
    EXPECT_EQ(k.reason, "unknown key 'rotate'; known keys: matrix, rotate_deg, scale, translate");
}

TEST(SceneDescJson, MalformedJsonReportsLineAndColumn) {
    TempDir dir;
    // Line 3 is `  "render": {"spp": @}`: the '@' is its 21st character.
    const std::string path =
        dir.write("bad.json", "{\n  \"camera\": {},\n  \"render\": {\"spp\": @}\n}\n");
    const InputError e = catch_input_error([&] { load_scene_desc(path); });
    EXPECT_EQ(e.file, path);
    EXPECT_EQ(e.field, "");
    EXPECT_EQ(e.reason.rfind("invalid JSON at line 3, column 21: ", 0), 0u) << e.reason;

    // A missing comma: the parser stops after reading the unexpected string "render", whose
    // closing quote is line 2, column 10.
    const std::string comma = dir.write("comma.json", "{\"camera\": {}\n  \"render\": {}}");
    const InputError c = catch_input_error([&] { load_scene_desc(comma); });
    EXPECT_EQ(c.reason.rfind("invalid JSON at line 2, column 10: ", 0), 0u) << c.reason;
}

TEST(SceneDescJson, MissingFileSaysCannotOpen) {
    TempDir dir;
    const std::string path = dir.path() + "/nope.json";
    const InputError e = catch_input_error([&] { load_scene_desc(path); });
    EXPECT_EQ(e.file, path);
    EXPECT_EQ(e.field, "");
    EXPECT_EQ(e.reason, "cannot open file: No such file or directory");
}

TEST(SceneDescJson, LoadSetsBaseDirAndValidates) {
    TempDir dir;
    const std::string path = dir.write("scene.json", full_scene().dump(2));
    const SceneDesc d = load_scene_desc(path);
    EXPECT_EQ(d.base_dir, dir.path());
    EXPECT_EQ(d.render.spp, 64);

    const std::string bad = dir.write("bad.json", R"({"render": {"spp": 0}})");
    const InputError e = catch_input_error([&] { load_scene_desc(bad); });
    EXPECT_EQ(e.field, "/render/spp");
    EXPECT_EQ(e.reason, "spp must be >= 1; found 0");
}

TEST(SceneDescOverride, OverridesChangeValues) {
    TempDir dir;
    const std::string path = dir.write("scene.json", full_scene().dump());
    const SceneDesc d = load_scene_desc(
        path, {"render.spp=8", "lights.0.intensity=[4,5,6]", "materials.chrome.albedo=0.25",
               "media.1.bounds.max=[2,3,4]", "shapes.3.file=other.obj", "camera.width=99"});
    EXPECT_EQ(d.render.spp, 8);
    EXPECT_EQ(d.lights[0].intensity, Color(4, 5, 6));
    EXPECT_EQ(d.materials.at("chrome").albedo, Color(0.25f));
    EXPECT_EQ(d.media[1].bounds->hi, Vec3(2, 3, 4));
    EXPECT_EQ(d.shapes[3].file, "other.obj");  // not JSON, so taken as a string
    EXPECT_EQ(d.camera.width, 99);
    EXPECT_EQ(d.render.max_depth, 12);  // untouched

    // Missing objects are created.
    json doc = json::object();
    apply_override(doc, "render.threads=2", "s.json");
    EXPECT_EQ(doc, json::parse(R"({"render": {"threads": 2}})"));
}

TEST(SceneDescOverride, OverridesReachTheNewSettings) {
    TempDir dir;
    const std::string path = dir.write("scene.json", full_scene().dump());
    const SceneDesc d =
        load_scene_desc(path, {"volume.k=64", "march.method=march", "photons.caustic=0",
                               "global.final_gather=false", "render.integrator=photon"});
    EXPECT_EQ(d.volume.k, 64);
    EXPECT_EQ(d.volume.radius, 0.25f);  // untouched
    EXPECT_EQ(d.march.method, FreePathMethod::March);
    EXPECT_EQ(d.photons.caustic, 0u);
    EXPECT_FALSE(d.global.final_gather);
    EXPECT_EQ(d.render.integrator, Integrator::Photon);

    // A scene without a "volume" object gets one created by the override.
    const std::string bare = dir.write("bare.json", "{}");
    EXPECT_EQ(load_scene_desc(bare, {"volume.k=64"}).volume.k, 64);

    const InputError k = catch_input_error([&] { load_scene_desc(path, {"volume.k=0"}); });
    EXPECT_EQ(k.field, "/volume/k");
    EXPECT_EQ(k.reason, "k must be in [1, 100000]; found 0 (from --set 'volume.k=0')");
}

TEST(SceneDescOverride, BadOverridesFailThroughTheNormalChecks) {
    TempDir dir;
    const std::string path = dir.write("scene.json", full_scene().dump());
    const InputError g = catch_input_error([&] { load_scene_desc(path, {"media.0.g=1"}); });
    EXPECT_EQ(g.file, path);
    EXPECT_EQ(g.field, "/media/0/g");
    EXPECT_EQ(g.reason, "g must be in (-1, 1); found 1 (from --set 'media.0.g=1')");

    const InputError t = catch_input_error([&] { load_scene_desc(path, {"render.spp=many"}); });
    EXPECT_EQ(t.field, "/render/spp");
    EXPECT_EQ(t.reason,
              "expected an integer, found string \"many\" (from --set 'render.spp=many')");

    const InputError k = catch_input_error([&] { load_scene_desc(path, {"render.spp_count=3"}); });
    EXPECT_EQ(k.field, "/render/spp_count");
    EXPECT_EQ(
        k.reason.rfind("unknown key 'spp_count'; known keys: adaptive, integrator, max_depth, "
                       "seed, "
                       "spp, threads",
                       0),
        0u)
        << k.reason;
}

TEST(SceneDescOverride, MalformedAssignmentsNameThePointer) {
    json doc = full_scene();
    const InputError range =
        catch_input_error([&] { apply_override(doc, "lights.7.intensity=1", "s.json"); });
    EXPECT_EQ(range.field, "/lights/7");
    EXPECT_EQ(range.reason,
              "--set 'lights.7.intensity=1': index 7 is out of range; the array "
              "has 5 elements");

    const InputError scalar =
        catch_input_error([&] { apply_override(doc, "render.spp.x=1", "s.json"); });
    EXPECT_EQ(scalar.field, "/render/spp");
    EXPECT_NE(scalar.reason.find("--set"), std::string::npos);

    const InputError no_eq =
        catch_input_error([&] { apply_override(doc, "render.spp", "s.json"); });
    EXPECT_EQ(no_eq.reason, "--set 'render.spp': expected key=value, e.g. render.spp=64");
}

TEST(SceneValidate, ReportsPointerFoundAndExpected) {
    struct Case {
        const char* patch;  // merged into the full scene
        const char* field;
        const char* reason;
    };
    const Case cases[] = {
        {R"({"camera": {"width": 0}})", "/camera/width", "width must be in [1, 16384]; found 0"},
        {R"({"camera": {"fov_deg": 180}})", "/camera/fov_deg",
         "fov_deg must be in (0, 180); found 180"},
        {R"({"camera": {"up": [-1, -1.5, -3]}})", "/camera/up",
         "up [-1, -1.5, -3] is parallel to the view direction [-1, -1.5, -3]; expected a vector "
         "not parallel to look_at - position"},
        {R"({"materials": {"floor": {"albedo": [0.5, 1.5, 0.5]}}})", "/materials/floor/albedo",
         "albedo must be in [0, 1] per channel; found [0.5, 1.5, 0.5]"},
        {R"({"materials": {"water": {"ior": 0}}})", "/materials/water/ior",
         "ior must be finite and > 0; found 0"},
        {R"({"render": {"max_depth": 100000001}})", "/render/max_depth",
         "max_depth must be in [1, 100000000]; found 100000001"},
        {R"({"render": {"threads": -2}})", "/render/threads",
         "threads must be >= 0 (0 = all cores); found -2"},
        {R"({"advanced": {"map_spp": -1}})", "/advanced/map_spp",
         "map_spp must be >= 0 (0 = every sample); found -1"},
        {R"({"advanced": {"guide_vertices": -1}})", "/advanced/guide_vertices",
         "guide_vertices must be in [0, 100000000]; found -1"},
        {R"({"photons": {"global": 1000000001}})", "/photons/global",
         "global must be in [0, 1000000000]; found 1000000001"},
        {R"({"photons": {"caustic": 18446744073709551615}})", "/photons/caustic",
         "caustic must be in [0, 1000000000]; found 18446744073709551615"},
        {R"({"photons": {"volume": 2000000000}})", "/photons/volume",
         "volume must be in [0, 1000000000]; found 2000000000"},
        {R"({"photons": {"max_bounces": 0}})", "/photons/max_bounces",
         "max_bounces must be in [1, 100000000]; found 0"},
        {R"({"photons": {"max_bounces": 100000001}})", "/photons/max_bounces",
         "max_bounces must be in [1, 100000000]; found 100000001"},
        {R"({"global": {"k": 0}})", "/global/k", "k must be in [1, 100000]; found 0"},
        {R"({"global": {"radius": -0.5}})", "/global/radius",
         "radius must be finite and >= 0; found -0.5"},
        {R"({"global": {"gather_rays": 0}})", "/global/gather_rays",
         "gather_rays must be in [1, 4096]; found 0"},
        {R"({"global": {"gather_rays": 4097}})", "/global/gather_rays",
         "gather_rays must be in [1, 4096]; found 4097"},
        {R"({"caustic": {"k": 100001}})", "/caustic/k", "k must be in [1, 100000]; found 100001"},
        {R"({"caustic": {"radius": -1}})", "/caustic/radius",
         "radius must be finite and >= 0; found -1"},
        {R"({"caustic": {"cone_filter": 0.5}})", "/caustic/cone_filter",
         "cone_filter must be 0 (box filter) or finite and >= 1 (Jensen's k_f); found 0.5"},
        {R"({"caustic": {"cone_filter": -1}})", "/caustic/cone_filter",
         "cone_filter must be 0 (box filter) or finite and >= 1 (Jensen's k_f); found -1"},
        {R"({"volume": {"k": -3}})", "/volume/k", "k must be in [1, 100000]; found -3"},
        {R"({"volume": {"radius": -2}})", "/volume/radius",
         "radius must be finite and >= 0; found -2"},
        {R"({"march": {"step_voxels": 0}})", "/march/step_voxels",
         "step_voxels must be finite, > 0 and <= 1000000; found 0"},
        {R"({"march": {"step_voxels": 2e6}})", "/march/step_voxels",
         "step_voxels must be finite, > 0 and <= 1000000; found 2e+06"},
        {R"({"march": {"step_world": -0.1}})", "/march/step_world",
         "step_world must be finite and >= 0; found -0.1"},
        {R"({"advanced": {"light_samples": -1}})", "/advanced/light_samples",
         "light_samples must be in [0, 4096]; found -1"},
        {R"({"advanced": {"sun_grid": -0.5}})", "/advanced/sun_grid",
         "sun_grid must be finite and >= 0; found -0.5"},
        {R"({"progressive": {"alpha": 1}})", "/progressive/alpha",
         "alpha must be in (0, 1); found 1"},
        {R"({"progressive": {"iterations": -2}})", "/progressive/iterations",
         "iterations must be in [0, 1000000]; found -2"},
        {R"({"advanced": {"iteration_spp": -1}})", "/advanced/iteration_spp",
         "iteration_spp must be >= 0 (0 = by rule); found -1"},
        {R"({"progressive": {"time_budget": -1}})", "/progressive/time_budget",
         "time_budget must be finite and >= 0; found -1"},
        {R"({"progressive": {"target_relmse": -0.5}})", "/progressive/target_relmse",
         "target_relmse must be finite and >= 0; found -0.5"},
    };
    for (const Case& c : cases) {
        json doc = full_scene();
        doc.merge_patch(json::parse(c.patch));
        const InputError e = validate_error(doc);
        EXPECT_EQ(e.file, "scene.json");
        EXPECT_EQ(e.field, c.field) << c.patch;
        EXPECT_EQ(e.reason, c.reason) << c.patch;
    }
}

TEST(SceneValidate, NewSettingsAcceptTheirBoundaries) {
    json doc = full_scene();
    doc.merge_patch(json::parse(R"({
      "photons": {"global": 0, "caustic": 1000000000, "volume": 0, "max_emitted": 0,
                  "max_bounces": 100000000},
      "global": {"k": 1, "radius": 0, "gather_rays": 4096},
      "caustic": {"k": 100000, "radius": 0, "cone_filter": 1},
      "volume": {"k": 1, "radius": 0},
      "march": {"step_voxels": 1000000, "step_world": 0}})"));
    EXPECT_NO_THROW(validate(scene_desc_from_json(doc, "scene.json")));
    doc["march"]["step_voxels"] = 1e-6;
    doc["caustic"]["cone_filter"] = 0;
    EXPECT_NO_THROW(validate(scene_desc_from_json(doc, "scene.json")));

    // Values that JSON cannot carry but code can: validate catches them too.
    SceneDesc d;
    d.march.step_world = std::numeric_limits<float>::infinity();
    const InputError e = catch_input_error([&] { validate(d); });
    EXPECT_EQ(e.field, "/march/step_world");
    EXPECT_EQ(e.reason, "step_world must be finite and >= 0; found inf");
    d = SceneDesc{};
    d.caustic.cone_filter = std::nanf("");
    EXPECT_EQ(catch_input_error([&] { validate(d); }).field, "/caustic/cone_filter");
}

TEST(SceneValidate, ArrayEntriesAreCheckedPerType) {
    struct Case {
        const char* pointer;  // "/lights/1/cone_delta_deg" is replaced by value
        json value;
        const char* reason;
    };
    const Case cases[] = {
        {"/lights/1/cone_delta_deg", 25,
         "cone_delta_deg must be in [0, cone_angle_deg = 20]; "
         "found 25"},
        {"/lights/2/edge_v", json::array({4, 0, 0}),
         "edge_u [2, 0, 0] and edge_v [4, 0, 0] span no area; expected two non-parallel, "
         "non-zero edges"},
        {"/lights/3/direction", json::array({0, 0, 0}),
         "direction must be a non-zero vector; found [0, 0, 0]"},
        {"/lights/3/angular_radius_deg", 45, "angular_radius_deg must be in [0, 45); found 45"},
        {"/lights/0/intensity", -1, "intensity must be >= 0 per channel; found [-1, -1, -1]"},
        {"/shapes/1/material", "gold",
         "unknown material 'gold'; known materials: chrome, floor, water"},
        {"/shapes/2/radius", 0, "radius must be finite and > 0; found 0"},
        {"/shapes/3/file", "", "file is empty; expected an .obj or .ply path"},
        {"/media/0/sigma_a", json::array({0, -0.5, 0}),
         "sigma_a must be >= 0 per channel; found [0, -0.5, 0]"},
        {"/media/0/g", -1, "g must be in (-1, 1); found -1"},
        {"/media/0/grid", "", "grid is empty; expected a float grid name"},
        {"/media/1/density_scale", -2, "density_scale must be finite and >= 0; found -2"},
    };
    for (const Case& c : cases) {
        json doc = full_scene();
        doc[json::json_pointer(c.pointer)] = c.value;
        const InputError e = validate_error(doc);
        EXPECT_EQ(e.field, c.pointer);
        EXPECT_EQ(e.reason, c.reason) << c.pointer;
    }
    json sphere = full_scene();
    sphere["shapes"][2]["transform"] = json::parse(R"({"scale": [1, 2, 1]})");
    const InputError sp = validate_error(sphere);
    EXPECT_EQ(sp.field, "/shapes/2/transform");
    EXPECT_EQ(sp.reason,
              "a sphere's transform must be rotation, uniform scale and translation; "
              "found axis scales [1, 2, 1] (or sheared axes)");
    sphere["shapes"][2]["transform"] = json::parse(R"({"scale": 3, "rotate_deg": [10, 20, 30]})");
    EXPECT_NO_THROW(validate(scene_desc_from_json(sphere, "scene.json")));

    json box = full_scene();
    box["shapes"][1]["max"] = json::array({1, 0, 3});
    const InputError b = validate_error(box);
    EXPECT_EQ(b.field, "/shapes/1/max");
    EXPECT_EQ(b.reason, "min must be < max on every axis; found min [0, 0, 0], max [1, 0, 3]");
}

}  // namespace
}  // namespace fogmap
