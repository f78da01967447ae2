// Hostile scene files: a key given twice, a shape without its material, transforms that are
// singular or out of the world range, lights whose power overflows float, and files that
// are not regular files or are too large to read. Each is an InputError naming the JSON pointer
// (or the file) with what was found and what was expected.

#include "core/error.h"
#include "core/input_file.h"
#include "core/world_range.h"
#include "scene/scene_desc_json.h"
#include "test_support.h"

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <filesystem>
#include <string>

namespace fogmap {
namespace {

using nlohmann::json;
using test::catch_input_error;

/// A valid scene with a quad and a box, a sun and a point light.
json scene() {
    return json::parse(R"({
      "camera": {"position": [0, 1, 4], "look_at": [0, 0.5, 0], "width": 8, "height": 6},
      "lights": [{"type": "sun", "direction": [0.3, -1, 0.2], "irradiance": 3},
                 {"type": "point", "position": [0, 3, 0], "intensity": 10}],
      "materials": {"ground": {"type": "diffuse", "albedo": 0.5}},
      "shapes": [{"type": "quad", "corner": [-5, 0, -5], "edge_u": [0, 0, 10],
                  "edge_v": [10, 0, 0], "material": "ground"},
                 {"type": "box", "material": "ground"}]
    })");
}

InputError validate_error(const json& doc) {
    return catch_input_error([&] { validate(scene_desc_from_json(doc, "scene.json")); });
}

/// A bad value put at one place of the valid scene: the error names `field`, and its reason holds
/// `reason`.
struct BadValue {
    const char* pointer;  // where `value` is put
    json value;
    const char* field;   // the field the error names
    const char* reason;  // part of the reason
};

void expect_rejected(const BadValue& c) {
    SCOPED_TRACE(c.pointer + (" = " + c.value.dump()));
    json doc = scene();
    doc[json::json_pointer(c.pointer)] = c.value;
    const InputError e = validate_error(doc);
    EXPECT_EQ(e.field, c.field);
    EXPECT_NE(e.reason.find(c.reason), std::string::npos) << e.reason;
}

TEST(SceneInput, TheValidSceneValidates) {
    EXPECT_NO_THROW(validate(scene_desc_from_json(scene(), "scene.json")));
}

TEST(SceneInput, DuplicateKeyIsAnErrorNamingItsPointer) {
    test::TempDir dir("fogmap_scene_input");
    // The same key twice at the top, inside an object, and inside an array's object.
    const std::pair<std::string, std::string> cases[] = {
        {R"({"render": {"spp": 1}, "render": {"spp": 2}})", "/render"},
        {R"({"camera": {"width": 8, "height": 6, "width": 9}})", "/camera/width"},
        {R"({"materials": {"m": {"type": "diffuse"}},
             "shapes": [{"type": "box", "material": "m"},
                        {"type": "box", "material": "m", "material": "m"}]})",
         "/shapes/1/material"},
    };
    for (const auto& [text, pointer] : cases) {
        SCOPED_TRACE(text);
        const std::string path = dir.write("dup.json", text);
        const InputError e = catch_input_error([&] { load_scene_desc(path); });
        EXPECT_EQ(e.file, path);
        EXPECT_EQ(e.field, pointer);
        const std::string key = pointer.substr(pointer.rfind('/') + 1);
        EXPECT_NE(e.reason.find("key '" + key + "' appears twice"), std::string::npos) << e.reason;
    }
    // Equal keys in different objects are fine.
    const std::string path = dir.write(
        "ok.json", R"({"camera": {"width": 8}, "render": {"spp": 1}, "photons": {"global": 0}})");
    EXPECT_NO_THROW(load_scene_desc(path));
}

TEST(SceneInput, ShapeWithoutMaterialSaysTheKeyIsMissing) {
    json doc = scene();
    doc["shapes"][1].erase("material");
    const InputError e = catch_input_error([&] { scene_desc_from_json(doc, "scene.json"); });
    EXPECT_EQ(e.field, "/shapes/1/material");
    EXPECT_NE(e.reason.find("missing key 'material'"), std::string::npos) << e.reason;
    EXPECT_NE(e.reason.find("ground"), std::string::npos) << "lists the materials: " << e.reason;
}

TEST(SceneInput, SingularOrOutOfRangeTransformsNameTheField) {
    const BadValue cases[] = {
        // Zero scale: the box would vanish.
        {"/shapes/1/transform", json::parse(R"({"scale": [1, 0, 1]})"), "/shapes/1/transform",
         "axis scales 1 x 0 x 1"},
        // Two axes made parallel by a matrix: singular though no axis is zero.
        {"/shapes/1/transform", json::parse(R"({"matrix": [1,1,0,0, 0,0,1,0, 0,0,1,0, 0,0,0,1]})"),
         "/shapes/1/transform", "singular"},
        {"/shapes/1/transform", json::parse(R"({"scale": 1e18})"), "/shapes/1/transform",
         "axis scales 1e+18 x 1e+18 x 1e+18"},
        {"/shapes/1/transform", json::parse(R"({"translate": [1e12, 0, 0]})"),
         "/shapes/1/transform", "translation 1e+12"},
        // In range itself (1e8 as a float), but the transformed quad reaches 1e8 + 5.
        {"/shapes/0/transform", json::parse(R"({"translate": [99999999, 0, 0]})"),
         "/shapes/0/transform", "the transformed shape spans"},
        {"/camera/position", json::parse("[0, 1e12, 4]"), "/camera/position", "within ±1e+08"},
        {"/lights/1/position", json::parse("[1e30, 0, 0]"), "/lights/1/position", "within ±1e+08"},
    };
    for (const BadValue& c : cases) expect_rejected(c);
    // A medium's transform: its own field too.
    json doc = scene();
    doc["media"] = json::parse(R"([{"type": "vdb", "file": "x.vdb",
                                    "transform": {"scale": [2, 2, 0]}}])");
    EXPECT_EQ(validate_error(doc).field, "/media/0/transform");
}

// Photon beams carry their photon's power along the free path, which is the transmittance of
// every channel only when all channels have the same extinction.
TEST(SceneInput, PhotonBeamsNeedGreyExtinction) {
    json doc = scene();
    doc["media"] = json::parse(R"([{"type": "homogeneous", "sigma_s": [1, 1, 1],
                                    "sigma_a": [0.5, 0.5, 0.5],
                                    "bounds": {"min": [-1, 0, -1], "max": [1, 1, 1]}}])");
    doc["volume"] = json{{"estimator", "photon_beams"}};
    EXPECT_NO_THROW(validate(scene_desc_from_json(doc, "scene.json")));
    doc["media"][0]["sigma_a"] = json::parse("[0.5, 0.4, 0.5]");
    const InputError e = validate_error(doc);
    EXPECT_EQ(e.field, "/volume/estimator");
    EXPECT_NE(e.reason.find("/media/0 has [1.5, 1.4, 1.5]"), std::string::npos) << e.reason;
    doc["volume"]["estimator"] = "beam";  // the point estimates take any medium
    EXPECT_NO_THROW(validate(scene_desc_from_json(doc, "scene.json")));
}

// volume.gather_depth counts medium vertices; photon beams gather along marched camera rays, which
// paths that end in the volume map do not have.
TEST(SceneInput, GatherDepthIsCheckedAndExcludesPhotonBeams) {
    json doc = scene();
    doc["volume"] = json{{"gather_depth", -1}};
    EXPECT_EQ(validate_error(doc).field, "/volume/gather_depth");
    doc["volume"] = json{{"gather_depth", 2}, {"estimator", "photon_beams"}};
    const InputError e = validate_error(doc);
    EXPECT_EQ(e.field, "/volume/estimator");
    EXPECT_NE(e.reason.find("gather_depth 2"), std::string::npos) << e.reason;
    doc["volume"]["estimator"] = "sphere";
    EXPECT_NO_THROW(validate(scene_desc_from_json(doc, "scene.json")));
}

TEST(SceneInput, EmissionValuesAreChecked) {
    json doc = scene();
    doc["media"] = json::parse(R"([{"type": "homogeneous", "sigma_a": 1,
                                    "bounds": {"min": [-1, 0, -1], "max": [1, 1, 1]},
                                    "emission": {"color": [1, 0.5, 0.2]}}])");
    EXPECT_NO_THROW(validate(scene_desc_from_json(doc, "scene.json")));
    const BadValue cases[] = {
        {"/media/0/emission/scale", -1, "/media/0/emission/scale", "must be finite and >= 0"},
        {"/media/0/emission/color", json::parse("[1, -1, 0]"), "/media/0/emission/color",
         "must be >= 0"},
        {"/media/0/emission/temperature_scale", -2, "/media/0/emission/temperature_scale",
         "must be finite and >= 0"},
        {"/media/0/emission/temperature_offset", 2e5, "/media/0/emission/temperature_offset",
         "within ±100000 K"},
        {"/media/0/emission/kind", "fire", "/media/0/emission/kind",
         "auto, blackbody, scalar, constant"},
        {"/media/0/emission/grid", "heat", "/media/0/emission/grid", "no grids to emit from"},
        {"/media/0/emission/kind", "blackbody", "/media/0/emission/kind", "no grids to emit from"},
        {"/media/0/sigma_a", 0, "/media/0/emission", "its sigma_a is 0"},
        {"/media/0/emission/flame", 1, "/media/0/emission/flame", "unknown key 'flame'"},
    };
    for (BadValue c : cases) {
        SCOPED_TRACE(c.pointer + (" = " + c.value.dump()));
        json bad = doc;
        bad[json::json_pointer(c.pointer)] = c.value;
        const InputError e = validate_error(bad);
        EXPECT_EQ(e.field, c.field);
        EXPECT_NE(e.reason.find(c.reason), std::string::npos) << e.reason;
    }
}

TEST(SceneInput, TransformRangeBoundariesAreAccepted) {
    // The stated range (core/world_range.h) is inclusive: scales 1e-6 and 1e6 are fine.
    for (const double scale : {kMinScale, kMaxScale}) {
        json doc = scene();
        doc["shapes"][1]["transform"] = {{"scale", scale}};
        EXPECT_NO_THROW(validate(scene_desc_from_json(doc, "scene.json"))) << scale;
    }
}

TEST(SceneInput, LightPowerBeyondFloatHeadroomIsRefused) {
    // Point: 4π I; quad: π A L; sun: E itself (its power needs the scene size: checked at load);
    // environment: 4π² L per unit of cross-section. Each here exceeds 1e20 W (per m²).
    const char* const reason = "expected at most 1e+20";
    const BadValue cases[] = {
        {"/lights/0/irradiance", 1e36, "/lights/0/irradiance", reason},
        {"/lights/1/intensity", 1e19, "/lights/1/intensity", reason},  // 4π 1e19 = 1.26e20
        {"/lights/1", json::parse(R"({"type": "environment", "radiance": [1, 1e19, 1]})"),
         "/lights/1/radiance", reason},
        {"/lights/1", json::parse(R"({"type": "quad", "corner": [0, 3, 0], "edge_u": [1e3, 0, 0],
                                      "edge_v": [0, 0, 1e3], "radiance": 1e14})"),
         "/lights/1/radiance", reason},  // π 1e6 1e14 = 3.1e20
    };
    for (const BadValue& c : cases) expect_rejected(c);
    // Just below: 4π 7e18 = 8.8e19 W.
    json doc = scene();
    doc["lights"][1]["intensity"] = 7e18;
    EXPECT_NO_THROW(validate(scene_desc_from_json(doc, "scene.json")));
}

TEST(SceneInput, NonRegularAndOversizedFilesAreRefusedBeforeReading) {
    test::TempDir dir("fogmap_scene_input");
    const std::string fifo = (dir.path() / "scene.fifo").string();
    ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
    // Opening the FIFO would block until a writer comes: it must be refused by stat alone.
    InputError e = catch_input_error([&] { load_scene_desc(fifo); });
    EXPECT_EQ(e.file, fifo);
    EXPECT_NE(e.reason.find("FIFO"), std::string::npos) << e.reason;
    e = catch_input_error([&] { load_scene_desc("/dev/zero"); });
    EXPECT_NE(e.reason.find("character device"), std::string::npos) << e.reason;
    e = catch_input_error([&] { load_scene_desc(dir.path().string()); });
    EXPECT_NE(e.reason.find("folder"), std::string::npos) << e.reason;

    // A sparse file one byte over the cap: refused by its size, without being read.
    const std::string big = dir.write("big.json", "");
    std::filesystem::resize_file(big, kMaxSceneFileBytes + 1);
    e = catch_input_error([&] { load_scene_desc(big); });
    EXPECT_EQ(e.file, big);
    EXPECT_NE(e.reason.find("at most 16 MB"), std::string::npos) << e.reason;
}

}  // namespace
}  // namespace fogmap
