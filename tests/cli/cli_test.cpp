// The fogmap command line on bad and good input: one clear message naming file, field and reason,
// exit code 2, and an existing output file left untouched; a good render writes EXR + PNG whole.

#include "core/image.h"
#include "test_support.h"

#include <gtest/gtest.h>
#include <openvdb/openvdb.h>
#include <nlohmann/json.hpp>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace fogmap {
namespace {

namespace fs = std::filesystem;

using test::RunResult;
using test::slurp;

class Cli : public ::testing::Test {
protected:
    fs::path write(const std::string& name, const std::string& text) {
        return tmp_.write(name, text);
    }

    RunResult run(const std::string& args) { return test::run_fogmap(args, dir_); }

    // A small valid scene; `extra` is spliced into the top-level object.
    std::string scene(const std::string& extra = "") {
        return R"({
  "camera": {"position": [0, 1, 4], "look_at": [0, 0.5, 0], "width": 8, "height": 6},
  "lights": [{"type": "sun", "direction": [0.3, -1, 0.2], "irradiance": 3}],
  "materials": {"ground": {"type": "diffuse", "albedo": 0.5}},
  "shapes": [{"type": "quad", "corner": [-5, 0, -5], "edge_u": [0, 0, 10], "edge_v": [10, 0, 0],
              "material": "ground"}],
  "render": {"spp": 2})" +
               extra + "\n}\n";
    }

    test::TempDir tmp_{"fogmap_cli"};
    const fs::path dir_ = tmp_.path();
};

TEST_F(Cli, MalformedJsonReportsLineAndColumn) {
    const fs::path p = write("bad.json", "{\n  \"camera\": {\n    \"fov_deg\": 40,,\n  }\n}\n");
    const RunResult r = run("render -q " + p.string() + " -o " + (dir_ / "x.exr").string());
    EXPECT_EQ(r.code, 2);
    EXPECT_NE(r.err.find("fogmap: error: " + p.string()), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("line 3"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("column"), std::string::npos) << r.err;
}

TEST_F(Cli, UnknownKeyListsTheKnownKeys) {
    const fs::path p = write("s.json", scene(R"(, "rendr": {})"));
    const RunResult r = run("render -q " + p.string());
    EXPECT_EQ(r.code, 2);
    EXPECT_NE(r.err.find("rendr"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("camera"), std::string::npos) << r.err;  // listed among the known keys
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << "one message: " << r.err;
}

TEST_F(Cli, NegativeCoefficientNamesTheField) {
    const fs::path p = write("s.json", scene(R"(, "media": [{"type": "homogeneous",
        "bounds": {"min": [-1, 0, -1], "max": [1, 1, 1]}, "sigma_s": [1, -2, 1]}])"));
    const RunResult r = run("render -q " + p.string());
    EXPECT_EQ(r.code, 2);
    EXPECT_NE(r.err.find("/media/0/sigma_s"), std::string::npos) << r.err;
}

TEST_F(Cli, ZeroResolutionIsRejected) {
    const fs::path p = write("s.json", scene());
    const RunResult r = run("render -q " + p.string() + " --set camera.width=0");
    EXPECT_EQ(r.code, 2);
    EXPECT_NE(r.err.find("/camera/width"), std::string::npos) << r.err;
}

TEST_F(Cli, OverridesGoThroughValidation) {
    const fs::path p = write("s.json", scene());
    RunResult r = run("render -q " + p.string() + " --set render.spp=0");
    EXPECT_EQ(r.code, 2);
    EXPECT_NE(r.err.find("/render/spp"), std::string::npos) << r.err;
    r = run("render -q " + p.string() + " --set render.spp=\\\"many\\\"");
    EXPECT_EQ(r.code, 2);
    EXPECT_NE(r.err.find("/render/spp"), std::string::npos) << r.err;
}

TEST_F(Cli, MissingVdbFileNamesTheFile) {
    const fs::path p =
        write("s.json", scene(R"(, "media": [{"type": "vdb", "file": "nope.vdb"}])"));
    const RunResult r = run("render -q " + p.string());
    EXPECT_EQ(r.code, 2);
    EXPECT_NE(r.err.find("nope.vdb"), std::string::npos) << r.err;
}

TEST_F(Cli, MissingGridListsTheGridsOfTheFile) {
    const std::string vdb = std::string(FOGMAP_SHARED_VOLUMES) + "/usd_densityAndHeat.vdb";
    if (!fs::exists(vdb)) return test::missing_shared_volume(vdb);
    const fs::path p = write("s.json", scene(R"(, "media": [{"type": "vdb", "file": ")" + vdb +
                                             R"(", "grid": "smoke"}])"));
    const RunResult r = run("render -q " + p.string());
    EXPECT_EQ(r.code, 2);
    EXPECT_NE(r.err.find("smoke"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("density"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("heat"), std::string::npos) << r.err;
}

TEST_F(Cli, NonFloatGridIsRejectedWithItsType) {
    openvdb::initialize();
    auto grid = openvdb::Vec3SGrid::create();
    grid->setName("density");
    grid->tree().setValue(openvdb::Coord(1, 2, 3), openvdb::Vec3s(1.0f));
    const fs::path vdb = dir_ / "vel.vdb";
    openvdb::io::File(vdb.string()).write({grid});
    const fs::path p = write("s.json", scene(R"(, "media": [{"type": "vdb", "file": "vel.vdb"}])"));
    const RunResult r = run("render -q " + p.string());
    EXPECT_EQ(r.code, 2);
    EXPECT_NE(r.err.find("vec3s"), std::string::npos) << r.err;
}

TEST_F(Cli, FailedRunLeavesTheOldOutputUntouched) {
    const fs::path exr = dir_ / "keep.exr", png = dir_ / "keep.png";
    std::ofstream(exr) << "old exr";
    std::ofstream(png) << "old png";
    const fs::path p = write("s.json", scene(R"(, "bogus": 1)"));
    const RunResult r = run("render -q " + p.string() + " -o " + exr.string());
    EXPECT_EQ(r.code, 2);
    EXPECT_EQ(slurp(exr), "old exr");
    EXPECT_EQ(slurp(png), "old png");
}

TEST_F(Cli, RenderWritesExrAndPngAndAJsonReport) {
    const fs::path p = write("s.json", scene());
    const fs::path exr = dir_ / "sub" / "img.exr";
    const RunResult r = run("render -q --json " + p.string() + " -o " + exr.string());
    ASSERT_EQ(r.code, 0) << r.err;
    const Image img = read_exr(exr.string());
    EXPECT_EQ(img.width, 8);
    EXPECT_EQ(img.height, 6);
    EXPECT_TRUE(fs::exists(dir_ / "sub" / "img.png"));
    for (const auto& e : fs::directory_iterator(dir_ / "sub"))
        EXPECT_EQ(e.path().string().find(".tmp-"), std::string::npos) << e.path();
    EXPECT_NE(r.out.find("\"time_s\""), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("\"rays_per_s\""), std::string::npos) << r.out;
    // The floor under the sun: albedo E cos θ / π on every pixel that sees it (bottom row).
    const float cos_theta = 1.0f / std::sqrt(0.09f + 1.0f + 0.04f);
    EXPECT_NEAR(img.at(4, 5).x, 0.5f * 3.0f * cos_theta / 3.14159265f, 1e-4f);
}

TEST_F(Cli, InfoListsGridsOfTheDisneyCloud) {
    const std::string vdb = std::string(FOGMAP_SHARED_VOLUMES) + "/wdas_cloud_sixteenth.vdb";
    if (!fs::exists(vdb)) return test::missing_shared_volume(vdb);
    const RunResult r = run("info " + vdb);
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_NE(r.out.find("density"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("415642"), std::string::npos) << r.out;  // SOURCES.md, incl. tiles
}

// Every bundled scene renders from a clean clone: its files lie inside the repository (never in
// ../shared, which a user cloning it does not have), and it renders at a small size.
TEST_F(Cli, EveryBundledSceneRendersFromTheRepositoryAlone) {
    const fs::path root = fs::canonical(FOGMAP_SOURCE_DIR);
    int scenes = 0;
    for (const auto& e : fs::directory_iterator(root / "scenes")) {
        if (e.path().extension() != ".json") continue;
        SCOPED_TRACE(e.path().filename().string());
        ++scenes;
        std::ifstream in(e.path());
        const nlohmann::json doc = nlohmann::json::parse(in);
        for (const auto& m : doc.value("media", nlohmann::json::array())) {
            if (!m.contains("file")) continue;
            const fs::path file =
                fs::weakly_canonical(e.path().parent_path() / m["file"].get<std::string>());
            const std::string rel = fs::relative(file, root).string();
            EXPECT_TRUE(rel.rfind("..", 0) != 0) << file << " lies outside the repository";
        }
        const fs::path exr = dir_ / (e.path().stem().string() + ".exr");
        const RunResult r = run("render " + e.path().string() + " -o " + exr.string() +
                                " --set camera.width=32 --set camera.height=18 --spp 4 -q");
        EXPECT_EQ(r.code, 0) << r.err;
    }
    EXPECT_GE(scenes, 6);
}

TEST_F(Cli, FireScenesRenderByDefaultWithoutWarnings) {
    // The bundled fire (blackbody) and heat (scalar) scenes, at their own settings (smaller
    // images), lit by themselves from the repository's own volumes; the Plan names the volume
    // light and its source.
    for (const char* name : {"fire.json", "heat.json"}) {
        SCOPED_TRACE(name);
        const std::string scene = std::string(FOGMAP_SOURCE_DIR) + "/scenes/" + name;
        const fs::path exr = dir_ / (std::string(name) + ".exr");
        for (const char* integrator : {"path", "photon"}) {
            const RunResult r = run("render " + scene + " -o " + exr.string() +
                                    " --set camera.width=48 --set camera.height=27 --set "
                                    "render.integrator=\"" +
                                    integrator + "\"");
            ASSERT_EQ(r.code, 0) << r.err;
            EXPECT_EQ(r.err.find("warning"), std::string::npos) << r.err;
            EXPECT_NE(r.err.find("volume light: built (medium 0: "), std::string::npos) << r.err;
            const Image img = read_exr(exr.string());
            EXPECT_GT(img.mean(), 0.0f) << integrator;
        }
    }
}

TEST_F(Cli, FireballVolumeHasDensityAndTemperature) {
    const fs::path vdb = dir_ / "fireball.vdb";
    const RunResult r = run("volume fireball -o " + vdb.string() + " --resolution 24");
    ASSERT_EQ(r.code, 0) << r.err;
    const RunResult info = run("info " + vdb.string());
    ASSERT_EQ(info.code, 0) << info.err;
    EXPECT_NE(info.out.find("density: float"), std::string::npos) << info.out;
    EXPECT_NE(info.out.find("temperature: float"), std::string::npos) << info.out;
}

TEST_F(Cli, BadArgumentsExitWithTwo) {
    EXPECT_EQ(run("render").code, 2);
    EXPECT_EQ(run("frobnicate").code, 2);
    EXPECT_EQ(run("info " + (dir_ / "missing.vdb").string()).code, 2);
}

// fogmap starts itself again with glibc's huge pages (main.cpp, where the kernel gives them on
// advice); a GLIBC_TUNABLES naming them already skips that. Both runs render the same image
// from the same arguments (a medium, so the grids the pages serve are built).
TEST_F(Cli, TheHugePageRestartKeepsTheArgumentsAndTheImage) {
    const fs::path p = write("s.json", scene(R"(, "media": [{"type": "homogeneous",
        "bounds": {"min": [-1, 0, -1], "max": [1, 1, 1]}, "sigma_s": 2, "sigma_a": 0.1}])"));
    const std::string args = "render -q " + p.string() + " --spp 3 --seed 5 -o ";
    const fs::path restarted = dir_ / "restarted.exr", direct = dir_ / "direct.exr";
    const RunResult a = test::run_fogmap(args + restarted.string(), dir_, "env -u GLIBC_TUNABLES ");
    ASSERT_EQ(a.code, 0) << a.err;
    const RunResult b = test::run_fogmap(args + direct.string(), dir_,
                                         "env GLIBC_TUNABLES=glibc.malloc.hugetlb=0 ");
    ASSERT_EQ(b.code, 0) << b.err;
    EXPECT_EQ(slurp(restarted), slurp(direct));
    EXPECT_FALSE(slurp(restarted).empty());
}

}  // namespace
}  // namespace fogmap
