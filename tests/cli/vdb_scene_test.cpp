// `fogmap render cache.vdb`: a VDB alone renders with a scene made for it — the camera frames
// the density's bounds (projected here by hand), the written scene (--write-scene) renders the
// same image, grids are recognised by their Houdini and Blender names (info says each one's
// use), the density scale and a non-kelvin temperature's mapping follow their stated rules, and
// a file with nothing to render, or a pattern without --frames, is one error.

#include "core/image.h"
#include "media/density_grid.h"
#include "test_support.h"

#include <gtest/gtest.h>
#include <openvdb/openvdb.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

namespace fogmap {
namespace {

namespace fs = std::filesystem;

using test::RunResult;

class VdbAlone : public ::testing::Test {
protected:
    void SetUp() override { openvdb::initialize(); }
    RunResult run(const std::string& args) { return test::run_fogmap(args, dir_); }
    std::string path(const std::string& name) const { return (dir_ / name).string(); }
    nlohmann::json scene_of(const std::string& args) {
        const RunResult r = run(args + " --write-scene " + path("made.json"));
        EXPECT_EQ(r.code, 0) << r.err;
        std::ifstream in(path("made.json"));
        return nlohmann::json::parse(in);
    }

    test::TempDir tmp_{"fogmap_vdb_scene"};
    const fs::path dir_ = tmp_.path();
};

const std::string kPlume = std::string(FOGMAP_SOURCE_DIR) + "/volumes/plume.vdb";

Vec3 vec(const nlohmann::json& a) {
    return Vec3(a[0].get<float>(), a[1].get<float>(), a[2].get<float>());
}

TEST_F(VdbAlone, TheCameraFramesTheDensityAndTheWrittenSceneRendersTheSameImage) {
    const std::string small = " --set camera.width=96 --set camera.height=54 --spp 2 -q";
    const RunResult direct = run("render " + kPlume + small + " -o " + path("a.exr"));
    ASSERT_EQ(direct.code, 0) << direct.err;
    const nlohmann::json s = scene_of("render " + kPlume + small);
    const RunResult again = run("render " + path("made.json") + " -q -o " + path("b.exr"));
    ASSERT_EQ(again.code, 0) << again.err;
    const Image a = read_exr(path("a.exr")), b = read_exr(path("b.exr"));
    ASSERT_EQ(a.pixels.size(), size_t(96 * 54));
    EXPECT_TRUE(a.pixels == b.pixels);

    // Every corner of the density's world bounds inside the image, and the widest within a
    // fifth of its edge: a pinhole with vertical field of view fov, written out here.
    const GridInfo density = inspect_vdb(kPlume).front();
    const Vec3 eye = vec(s["camera"]["position"]), at = vec(s["camera"]["look_at"]);
    const Vec3 forward = glm::normalize(at - eye);
    const Vec3 right = glm::normalize(glm::cross(forward, Vec3(0.0f, 1.0f, 0.0f)));
    const Vec3 up = glm::cross(right, forward);
    const double tan_y = std::tan(s["camera"]["fov_deg"].get<double>() * kPiDouble / 360.0);
    const double tan_x = tan_y * 96.0 / 54.0;
    double widest = 0.0;
    for (int n = 0; n < 8; ++n) {
        const Box3& w = density.world_bounds;
        const Vec3 q((n & 1) ? w.hi.x : w.lo.x, (n & 2) ? w.hi.y : w.lo.y,
                     (n & 4) ? w.hi.z : w.lo.z);
        const Vec3 r = q - eye;
        const double depth = glm::dot(r, forward);
        ASSERT_GT(depth, 0.0);
        const double x = std::abs(glm::dot(r, right)) / (depth * tan_x),
                     y = std::abs(glm::dot(r, up)) / (depth * tan_y);
        EXPECT_LE(x, 1.0) << "corner " << n;
        EXPECT_LE(y, 1.0) << "corner " << n;
        widest = std::max({widest, x, y});
    }
    EXPECT_GE(widest, 0.8);
    // The ground under the volume: its quad at the bounds' lowest y.
    EXPECT_FLOAT_EQ(s["shapes"][0]["corner"][1].get<float>(), density.world_bounds.lo.y);
}

TEST_F(VdbAlone, AVelocitySplitIntoFloatGridsIsTheMediumsVelocity) {
    // Houdini's vector volumes as float grids vel.x, vel.y and vel.z.
    openvdb::GridPtrVec grids;
    for (const char* name : {"density", "vel.x", "vel.y", "vel.z"}) {
        auto g = openvdb::FloatGrid::create(0.0f);
        g->tree().fill(openvdb::CoordBBox(openvdb::Coord(0), openvdb::Coord(7)), 0.5f, true);
        g->setName(name);
        g->setTransform(openvdb::math::Transform::createLinearTransform(0.1));
        grids.push_back(g);
    }
    openvdb::io::File(path("split.vdb")).write(grids);
    const RunResult info = run("info " + path("split.vdb"));
    ASSERT_EQ(info.code, 0) << info.err;
    size_t uses = 0;
    for (size_t at = info.out.find("velocity (motion blur"); at != std::string::npos;
         at = info.out.find("velocity (motion blur", at + 1))
        ++uses;
    EXPECT_EQ(uses, 3u) << info.out;
    const nlohmann::json s = scene_of("render " + path("split.vdb"));
    EXPECT_EQ(s["media"][0]["velocity_grid"], "vel");
    EXPECT_EQ(s["camera"]["shutter"]["fps"], 24);
    const RunResult render =
        run("render -q " + path("split.vdb") +
            " --set camera.width=8 --set camera.height=6 --spp 1 -o " + path("split.exr"));
    EXPECT_EQ(render.code, 0) << render.err;
}

TEST_F(VdbAlone, GridsAreRecognisedByTheirNamesAndInfoSaysEachOnesUse) {
    // density (0..0.5 over 16^3 voxels of 0.1), a Houdini temperature of 0..2 (not kelvin), Cd
    // and vel: the medium's density scale makes 10 the optical depth across the box's cube root
    // at the densest value; the temperature maps its hottest voxel to 2500 K.
    auto density = openvdb::FloatGrid::create(0.0f);
    auto temperature = openvdb::FloatGrid::create(0.0f);
    auto cd = openvdb::Vec3SGrid::create(openvdb::Vec3s(0.0f));
    auto vel = openvdb::Vec3SGrid::create(openvdb::Vec3s(0.0f));
    for (int n = 0; n < 16 * 16 * 16; ++n) {
        const openvdb::Coord c(n / 256, (n / 16) % 16, n % 16);
        density->tree().setValue(c, 0.5f * float(n % 16 + 1) / 16.0f);
        temperature->tree().setValue(c, 2.0f * float(n % 7) / 6.0f);
        cd->tree().setValue(c, openvdb::Vec3s(1.0f, 0.5f, 0.25f));
        vel->tree().setValue(c, openvdb::Vec3s(0.0f, 1.0f, 0.0f));
    }
    density->setName("density");
    temperature->setName("temperature");
    cd->setName("Cd");
    vel->setName("vel");
    for (auto g : openvdb::GridPtrVec{density, temperature, cd, vel})
        g->setTransform(openvdb::math::Transform::createLinearTransform(0.1));
    openvdb::io::File(path("pyro.vdb")).write({density, temperature, cd, vel});

    const RunResult info = run("info " + path("pyro.vdb"));
    ASSERT_EQ(info.code, 0) << info.err;
    for (const char* use :
         {"density (the medium)", "emission (blackbody, its hottest voxel as 2500 K)",
          "colour (the scattering's albedo per channel)",
          "velocity (motion blur over camera.shutter)"})
        EXPECT_NE(info.out.find(use), std::string::npos) << use << "\n" << info.out;

    // A render uses every grid: it names none as left out.
    const RunResult render =
        run("render -q " + path("pyro.vdb") +
            " --set camera.width=16 --set camera.height=9 --spp 1 -o " + path("pyro.exr"));
    ASSERT_EQ(render.code, 0) << render.err;
    EXPECT_EQ(render.err.find("not used"), std::string::npos) << render.err;

    const nlohmann::json s = scene_of("render " + path("pyro.vdb"));
    const nlohmann::json& m = s["media"][0];
    EXPECT_EQ(m["grid"], "density");
    EXPECT_EQ(m["color_grid"], "Cd");
    EXPECT_EQ(m["velocity_grid"], "vel");
    EXPECT_EQ(s["camera"]["shutter"]["open"], -0.25);
    EXPECT_EQ(s["camera"]["shutter"]["close"], 0.25);
    EXPECT_EQ(s["camera"]["shutter"]["fps"], 24);
    EXPECT_EQ(m["file"], "pyro.vdb");
    // Active voxels 0..15 span 1.5 world units (centres 0.1 apart) on each axis.
    EXPECT_NEAR(m["density_scale"].get<double>(), 10.0 / (0.5 * 1.5), 1e-4);
    EXPECT_EQ(m["emission"]["kind"], "blackbody");
    EXPECT_EQ(m["emission"]["grid"], "temperature");
    EXPECT_NEAR(m["emission"]["temperature_scale"].get<double>(), 2500.0 / 2.0, 1e-3);
}

TEST_F(VdbAlone, NothingToRenderOrAPatternWithoutFramesIsOneError) {
    auto vel = openvdb::Vec3SGrid::create(openvdb::Vec3s(0.0f));
    vel->tree().setValue(openvdb::Coord(0), openvdb::Vec3s(1.0f));
    vel->setName("vel");
    openvdb::io::File(path("vel.vdb")).write({vel});
    const RunResult none = run("render -q " + path("vel.vdb") + " -o " + path("o.exr"));
    EXPECT_EQ(none.code, 2) << none.err;
    EXPECT_NE(none.err.find("no float grid named density"), std::string::npos) << none.err;
    const RunResult pattern = run("render -q " + path("cache.####.vdb") + " -o " + path("o.exr"));
    EXPECT_EQ(pattern.code, 2) << pattern.err;
    EXPECT_NE(pattern.err.find("expected --frames"), std::string::npos) << pattern.err;
    EXPECT_FALSE(fs::exists(path("o.exr")));
}

}  // namespace
}  // namespace fogmap
