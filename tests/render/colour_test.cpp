// A medium's colour grid (Houdini's Cd): the scattering's albedo per channel at σ_t unchanged.
// Against the same density made chromatic by its coefficients — sigma_s·Cd and
// sigma_a + sigma_s·(1 − Cd) — every integrator (the path tracer, paths ending in the volume map,
// the photon gather; the photon pass with them) renders the same image; and a colour grid of its
// own voxel size and offset colours the scattering by world position (red on one side, blue on
// the other); a uniform colour scales single scattering in a block by its closed form.

#include "core/error.h"
#include "render/pipeline.h"
#include "scene/scene.h"
#include "scene/scene_desc.h"
#include "scene_builders.h"
#include "test_support.h"

#include <gtest/gtest.h>
#include <openvdb/openvdb.h>

#include <cmath>
#include <limits>
#include <string>

namespace fogmap {
namespace {

using namespace test;

// A 24^3 block of voxels 0.1 apart centred near the origin, density varying smoothly (0.3..1).
openvdb::FloatGrid::Ptr density_block() {
    auto g = openvdb::FloatGrid::create(0.0f);
    for (int n = 0; n < 24 * 24 * 24; ++n) {
        const int i = n / 576, j = (n / 24) % 24, k = n % 24;
        g->tree().setValue(
            openvdb::Coord(i - 12, j - 12, k - 12),
            0.65f + 0.35f * std::sin(0.5f * float(i)) * std::cos(0.4f * float(j + k)));
    }
    g->setName("density");
    g->setTransform(openvdb::math::Transform::createLinearTransform(0.1));
    return g;
}

// A colour grid of voxels 0.25 apart, offset by 0.1 along x, over [-2, 2]^3 (beyond the block:
// no ramp to 0 within it), `left` where x < 0 and `right` elsewhere.
openvdb::Vec3SGrid::Ptr colour_grid(const openvdb::Vec3s& left, const openvdb::Vec3s& right) {
    auto g = openvdb::Vec3SGrid::create(openvdb::Vec3s(0.0f));
    const double h = 0.25, offset = 0.1;
    for (int i = -8; i <= 8; ++i)
        for (int j = -8; j <= 8; ++j)
            for (int k = -8; k <= 8; ++k)
                g->tree().setValue(openvdb::Coord(i, j, k), i * h + offset < 0.0 ? left : right);
    g->setName("Cd");
    auto xf = openvdb::math::Transform::createLinearTransform(h);
    xf->postTranslate(openvdb::Vec3d(offset, 0.0, 0.0));
    g->setTransform(xf);
    return g;
}

SceneDesc block_scene(const std::string& file, const std::string& integrator, int gather_depth) {
    SceneDesc d;
    d.camera.position = Vec3(0.0f, 0.4f, 6.0f);
    d.camera.look_at = Vec3(0.0f);
    d.camera.fov_deg = 30.0f;
    d.camera.width = 32;
    d.camera.height = 24;
    d.lights.push_back(sun(Vec3(-0.4f, -0.8f, -0.45f), 3.0f));
    d.lights.push_back(environment(0.2f));
    add_ground(&d, -1.3f, 20.0f, 0.5f);
    d.media.push_back(vdb_medium(file, Color(3.0f), Color(0.3f)));
    d.media[0].g = 0.3f;
    d.render.spp = 8;
    d.render.integrator = integrator == "path" ? Integrator::Path : Integrator::Photon;
    d.volume.gather_depth = gather_depth;
    return d;
}

TEST(ColourGrid, RendersAsTheDensityMadeChromaticByItsCoefficients) {
    openvdb::initialize();
    const TempDir dir("colour");
    const std::string file = (dir.path() / "cd.vdb").string();
    const openvdb::Vec3s cd(1.0f, 0.5f, 0.25f);
    openvdb::io::File(file).write({density_block(), colour_grid(cd, cd)});
    struct Case {
        const char* integrator;
        int gather_depth;
    };
    for (const Case c : {Case{"path", 3}, Case{"photon", 3}, Case{"photon", 0}}) {
        SceneDesc coloured = block_scene(file, c.integrator, c.gather_depth);
        coloured.media[0].color_grid = "Cd";
        SceneDesc chromatic = block_scene(file, c.integrator, c.gather_depth);
        const Color s = chromatic.media[0].sigma_s, a = chromatic.media[0].sigma_a;
        const Color albedo(cd[0], cd[1], cd[2]);
        chromatic.media[0].sigma_s = s * albedo;
        chromatic.media[0].sigma_a = a + (s - s * albedo);
        const Image x = run_pipeline(coloured, true).film.beauty;
        const Image y = run_pipeline(chromatic, true).film.beauty;
        double diff = 0.0, sum = 0.0, channel[3] = {0.0, 0.0, 0.0};
        for (size_t p = 0; p < x.pixels.size(); ++p)
            for (int k = 0; k < 3; ++k) {
                diff += std::abs(double(x.pixels[p][k]) - y.pixels[p][k]);
                sum += y.pixels[p][k];
                channel[k] += y.pixels[p][k];
            }
        EXPECT_LE(diff, 1e-5 * sum) << c.integrator << " depth " << c.gather_depth;
        // The colour shows: the scattered light's blue falls short of its red.
        EXPECT_LT(channel[2], 0.95 * channel[0]) << c.integrator;
    }
}

TEST(ColourGrid, AUniformColourScalesSingleScatteringByItsClosedForm) {
    // A block of uniform density (16^3 voxels 0.1 apart) and a uniform colour C, the sun straight
    // down and the camera below looking up (fov 2 degrees, 40 units away: its rays all but
    // vertical), single scattering alone (max_depth 1), isotropic phase. Along a vertical line
    // the sun's and the view's transmittances multiply to the whole line's, so whatever the
    // density's profile L = C sigma_s / sigma_t * E / (4 pi) * tau e^-tau, tau = sigma_t * 1.6
    // (a block of n voxels has optical depth sigma_t n h through its voxel centres): per channel
    // C times the grey medium's.
    openvdb::initialize();
    const TempDir dir("colour_closed");
    const std::string file = (dir.path() / "uniform.vdb").string();
    auto density = openvdb::FloatGrid::create(0.0f);
    density->fill(openvdb::CoordBBox(openvdb::Coord(-8), openvdb::Coord(7)), 1.0f, true);
    density->setName("density");
    density->setTransform(openvdb::math::Transform::createLinearTransform(0.1));
    const openvdb::Vec3s c(0.9f, 0.5f, 0.2f);
    openvdb::io::File(file).write({density, colour_grid(c, c)});
    const float sigma_s = 1.2f, sigma_a = 0.4f, E = 3.0f;
    SceneDesc d;
    d.camera.position = Vec3(0.0f, -40.0f, 0.0f);
    d.camera.look_at = Vec3(0.0f);
    d.camera.up = Vec3(0.0f, 0.0f, 1.0f);
    d.camera.fov_deg = 2.0f;
    d.camera.width = d.camera.height = 8;
    d.lights.push_back(sun(Vec3(0.0f, -1.0f, 0.0f), E));
    d.media.push_back(vdb_medium(file, Color(sigma_s), Color(sigma_a)));
    d.media[0].g = 0.0f;
    d.media[0].color_grid = "Cd";
    d.render.integrator = Integrator::Path;
    d.render.max_depth = 1;
    d.render.spp = 2048;
    const Image img = run_pipeline(d, true).film.beauty;
    const double sigma_t = sigma_s + sigma_a, tau = sigma_t * 16 * 0.1;
    const double grey = sigma_s / sigma_t * E / (4.0 * kPi) * tau * std::exp(-tau);
    for (int ch = 0; ch < 3; ++ch) {
        double sum = 0.0, sum2 = 0.0;
        const int n = img.width * img.height;
        for (int y = 0; y < img.height; ++y)
            for (int x = 0; x < img.width; ++x) {
                const double v = img.at(x, y)[ch];
                sum += v;
                sum2 += v * v;
            }
        const double mean = sum / n, se = std::sqrt(std::max(0.0, sum2 / n - mean * mean) / n);
        EXPECT_NEAR(mean, c[ch] * grey, 4.0 * se + 1e-3 * grey) << "channel " << ch;
    }
}

TEST(ColourGrid, ColoursTheScatteringByWorldPositionThroughItsOwnTransform) {
    // Single scattering alone (max_depth 1, the sun, no sky or ground): a pixel's colour is the
    // colour where its light scattered. Red where x < 0, blue elsewhere; the colour grid's
    // boundary (x = 0, between its voxels at -0.15 and 0.1) blends within one of its voxels.
    openvdb::initialize();
    const TempDir dir("colour_split");
    const std::string file = (dir.path() / "split.vdb").string();
    openvdb::io::File(file).write({density_block(), colour_grid(openvdb::Vec3s(1.0f, 0.0f, 0.0f),
                                                                openvdb::Vec3s(0.0f, 0.0f, 1.0f))});
    SceneDesc d = block_scene(file, "path", 3);
    d.lights.resize(1);  // the sun alone
    d.shapes.clear();
    d.render.max_depth = 1;
    d.render.spp = 16;
    d.camera.position = Vec3(0.0f, 0.0f, 40.0f);  // nearly orthographic: x stays put along a ray
    d.camera.fov_deg = 4.0f;
    d.media[0].color_grid = "Cd";
    const Image img = run_pipeline(d, true).film.beauty;
    Color left(0.0f), right(0.0f);
    for (int y = 4; y < 20; ++y)
        for (int x = 0; x < 32; ++x) {
            if (x < 10) left += img.at(x, y);    // world x below about -0.35
            if (x >= 22) right += img.at(x, y);  // above about 0.35
        }
    EXPECT_GT(left.x, 0.0f);
    EXPECT_EQ(left.y, 0.0f);
    EXPECT_EQ(left.z, 0.0f);
    EXPECT_GT(right.z, 0.0f);
    EXPECT_EQ(right.x, 0.0f);
    EXPECT_EQ(right.y, 0.0f);
}

TEST(ColourGrid, AColourOfTheWrongTypeBelowZeroOrNotFiniteIsAnErrorAndAboveOneIsClamped) {
    openvdb::initialize();
    const TempDir dir("colour_bad");
    const std::string file = (dir.path() / "bad.vdb").string();
    const float nan = std::numeric_limits<float>::quiet_NaN();
    auto wrong_type = openvdb::FloatGrid::create(0.0f);
    wrong_type->setName("Cf");
    wrong_type->tree().setValue(openvdb::Coord(0), 1.0f);
    auto negative = colour_grid(openvdb::Vec3s(1.0f, -0.5f, 1.0f), openvdb::Vec3s(1.0f));
    negative->setName("Cneg");
    auto not_finite = colour_grid(openvdb::Vec3s(nan, 1.0f, 1.0f), openvdb::Vec3s(1.0f));
    not_finite->setName("Cnan");
    auto bright = colour_grid(openvdb::Vec3s(2.0f, 1.0f, 1.0f), openvdb::Vec3s(1.0f));
    bright->setName("Cbright");
    openvdb::io::File(file).write({density_block(), wrong_type, negative, not_finite, bright});
    const auto error_of = [&](const std::string& grid) -> std::string {
        SceneDesc d = block_scene(file, "path", 3);
        d.media[0].color_grid = grid;
        try {
            load_scene(d);
        } catch (const InputError& e) {
            EXPECT_EQ(e.field, "/media/0/color_grid") << grid;
            return e.reason;
        }
        return "";
    };
    EXPECT_NE(error_of("Cf").find("has type float; expected a vec3s grid"), std::string::npos);
    // colour_grid's left half (x < 0): 8 of its 17 columns of 17 x 17 voxels.
    const std::string half = std::to_string(8 * 17 * 17);
    EXPECT_NE(error_of("Cneg").find("has " + half + " channel values below 0 or not finite"),
              std::string::npos);
    EXPECT_NE(error_of("Cnan").find("has " + half + " channel values below 0 or not finite"),
              std::string::npos);
    SceneDesc d = block_scene(file, "path", 3);
    d.media[0].color_grid = "Cbright";
    const auto scene = load_scene(d);
    ASSERT_EQ(scene->warnings.size(), 1u);
    EXPECT_NE(scene->warnings[0].find(half + " channel values above 1 clamped to 1"),
              std::string::npos)
        << scene->warnings[0];
}

}  // namespace
}  // namespace fogmap
