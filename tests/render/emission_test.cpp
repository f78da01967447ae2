// Emitting media seen by the camera and lighting a scene, against closed forms and the path
// tracer: an emission-only slab seen through its depth d gives L = L_e σ_a/σ_t (1 − e^{−σ_t d}),
// in a homogeneous box and in a VDB block with its one-voxel ramps (along a ray σ and the source
// σ_a L_e keep their ratio, so the ramps change nothing), for both integrators; a self-lit sphere
// of medium over a plane and a scattering, emitting cloud give the same images by photon mapping
// as by path tracing (the photon integrator's light then comes from the maps alone).

#include "media/blackbody.h"
#include "media/volume_gen.h"
#include "render/path_tracer.h"
#include "render/photon_integrator.h"
#include "render/pipeline.h"
#include "scene/scene.h"
#include "scene_builders.h"
#include "test_support.h"

#include <gtest/gtest.h>
#include <glm/gtc/matrix_transform.hpp>

#include <cmath>
#include <cstdio>
#include <vector>

namespace fogmap {
namespace {

using namespace test;

// Along −z through the slab z in [−d, 0] from z = 3.
const Ray kRay{Vec3(0.02f, -0.03f, 3.0f), Vec3(0.0f, 0.0f, -1.0f)};

struct Estimate {
    DVec3 mean{0.0}, standard_error{0.0};
};

/// Per-channel mean and standard error of n samples of f(rng).
template <class F>
Estimate estimate(int n, F&& f) {
    SampleStats<DVec3> samples;
    for (int i = 0; i < n; ++i) {
        Rng rng(11, static_cast<uint64_t>(i));
        samples.add(DVec3(f(rng)));
    }
    return {samples.mean(), samples.standard_error()};
}

/// The path tracer's radiance along kRay (its emission layer alone when `layer`), and the photon
/// integrator's emission layer.
Estimate path_radiance(const SceneDesc& d, int n, bool layer = false) {
    const auto scene = load_scene(d);
    const PathTracer tracer(*scene, d.render.max_depth);
    PathTracer::ThreadState ts = tracer.make_state();
    ts.layered = layer;
    return estimate(n, [&](Rng& rng) {
        const Color L = tracer.radiance(kRay, rng, ts);
        return layer ? ts.layers[size_t(Layer::Emission)] : L;
    });
}

Estimate photon_emission(const SceneDesc& d, int n) {
    const auto scene = load_scene(d);
    const PhotonMaps maps;
    const PhotonIntegrator integrator(*scene, maps, gather_params(d, *scene, maps, false), d.march,
                                      d.render.max_depth);
    PhotonIntegrator::ThreadState ts = integrator.make_state();
    return estimate(n,
                    [&](Rng& rng) { return integrator.radiance(kRay, rng, ts)[Layer::Emission]; });
}

void expect_near(const Estimate& e, const DVec3& want, double relative, const char* what) {
    for (int c = 0; c < 3; ++c)
        EXPECT_NEAR(e.mean[c], want[c], 4.0 * e.standard_error[c] + relative * want[c])
            << what << ", channel " << c;
}

EmissionDesc constant_emission(const Color& color) {
    EmissionDesc e;
    e.kind = EmissionSource::Constant;
    e.color = color;
    return e;
}

TEST(EmissionRender, HomogeneousSlabMatchesTheClosedForm) {
    const float depth = 0.5f;
    const Color sigma_a(2.0f, 1.0f, 0.5f), Le(1.0f, 2.0f, 3.0f);
    SceneDesc d;
    d.media.push_back(homogeneous(Box3{Vec3(-1.0f, -1.0f, -depth), Vec3(1.0f, 1.0f, 0.0f)},
                                  Color(0.0f), sigma_a));
    d.media[0].emission = constant_emission(Le);
    DVec3 want;
    for (int c = 0; c < 3; ++c) want[c] = Le[c] * -std::expm1(-double(sigma_a[c]) * depth);
    expect_near(path_radiance(d, 40000), want, 0.0, "path tracer");
    expect_near(photon_emission(d, 200), want, 1e-4, "photon integrator");

    // Scattering as well: the emission seen directly is L_e σ_a/σ_t (1 − e^{−σ_t d}) (either
    // integrator's emission layer; the scattered part is another layer's).
    d.media[0].sigma_s = Color(1.0f);
    for (int c = 0; c < 3; ++c) {
        const double sigma_t = 1.0 + sigma_a[c];
        want[c] = Le[c] * sigma_a[c] / sigma_t * -std::expm1(-sigma_t * depth);
    }
    expect_near(photon_emission(d, 200), want, 1e-4, "photon integrator, scattering slab");
    expect_near(path_radiance(d, 40000, /*layer=*/true), want, 0.0, "path tracer, scattering slab");
}

TEST(EmissionRender, VdbBlockWithItsRampsMatchesTheClosedForm) {
    // Density: 16³ voxels of 0.05, value 1, centred on the origin; temperature: 1500 K in a grid
    // of its own, 8³ voxels of 0.2 (larger than the density's box, other voxels and origin).
    const TempDir dir("emission_block");
    const std::string file = (dir.path() / "fire.vdb").string();
    constexpr int kN = 16;
    constexpr float kH = 0.05f;
    write_float_grids(
        file,
        {{"density", kN, kN, kN, [](int, int, int) { return 1.0f; }, Vec3(kH), Vec3(-0.375f)},
         {"temperature", 8, 8, 8, [](int, int, int) { return 1500.0f; }, Vec3(0.2f), Vec3(-0.7f)}});
    const float sigma_a = 4.0f;
    SceneDesc d;
    d.media.push_back(vdb_medium(file, Color(0.0f), Color(sigma_a)));
    d.media[0].emission = EmissionDesc{};  // auto: finds the grid 'temperature', blackbody
    d.media[0].transform.matrix = glm::translate(Mat4(1.0f), Vec3(0.0f, 0.0f, -0.4f));
    // ∫ density along the ray = kN kH (the ramps add half a voxel each side of the plateau).
    const DVec3 want = DVec3(blackbody_radiance(1500.0)) * -std::expm1(-double(sigma_a) * kN * kH);
    expect_near(path_radiance(d, 40000), want, 0.0, "path tracer");
    expect_near(photon_emission(d, 400), want, 0.005, "photon integrator");
}

TEST(EmissionRender, EmissionGridsAreCheckedAtLoad) {
    const TempDir dir("emission_load");
    const std::string file = (dir.path() / "fire.vdb").string();
    auto write = [&](float hottest) {
        write_float_grids(file, {{"density", 4, 4, 4, [](int, int, int) { return 1.0f; }},
                                 {"temperature", 4, 4, 4, [&](int i, int j, int) {
                                      return i == 0 ? -50.0f : j == 0 ? NAN : hottest;
                                  }}});
    };
    SceneDesc d;
    d.path = "scene.json";
    d.media.push_back(vdb_medium(file, Color(1.0f), Color(1.0f)));
    d.media[0].emission = EmissionDesc{};
    // Negative and NaN temperatures are set to 0 (no emission) and counted, like density.
    write(1800.0f);
    const auto scene = load_scene(d);
    const SanitizeStats& stats = scene->media[0].emission()->grid()->sanitize_stats();
    EXPECT_EQ(stats.negative, 16u);
    EXPECT_EQ(stats.nan, 12u);
    EXPECT_NEAR(scene->media[0].emission()->max_kelvin(), 1800.0, 1e-3);
    ASSERT_EQ(scene->emitters.size(), 1u);
    EXPECT_NE(scene->emitters[0].find("blackbody from grid 'temperature' (found in the file)"),
              std::string::npos)
        << scene->emitters[0];
    // Hotter than 1e5 K: an input error, whether from the grid or its mapping.
    write(2e5f);
    InputError e = catch_input_error([&] { load_scene(d); });
    EXPECT_EQ(e.field, "/media/0/emission");
    EXPECT_NE(e.reason.find("temperatures reach 2e+05 K"), std::string::npos) << e.reason;
    write(1000.0f);
    d.media[0].emission->temperature_scale = 150.0f;
    e = catch_input_error([&] { load_scene(d); });
    EXPECT_NE(e.reason.find("temperatures reach 1.5e+05 K"), std::string::npos) << e.reason;
    // A grid that is not there, named or looked for.
    d.media[0].emission->grid = "flame";
    e = catch_input_error([&] { load_scene(d); });
    EXPECT_EQ(e.field, "/media/0/emission/grid");
    EXPECT_NE(e.reason.find("no grid 'flame'; grids present: density, temperature"),
              std::string::npos)
        << e.reason;
    write_float_grid(file, "density", 4, 4, 4, [](int, int, int) { return 1.0f; });
    d.media[0].emission->grid = "";
    d.media[0].emission->kind = EmissionSource::Blackbody;
    e = catch_input_error([&] { load_scene(d); });
    EXPECT_EQ(e.field, "/media/0/emission/grid");
    EXPECT_NE(e.reason.find("none of temperature, heat, flame, flames (grids present: density)"),
              std::string::npos)
        << e.reason;
}

/// A sphere of medium (radius 0.5, density 1, 24³ voxels) at (0, 0.8, 0) over a diffuse ground
/// at y = 0, emitting `Le`, seen from above at an angle; no light.
SceneDesc self_lit_sphere(const TempDir& dir, const Color& sigma_s, const Color& sigma_a,
                          bool ground) {
    const std::string file = (dir.path() / "sphere.vdb").string();
    constexpr int kN = 24;
    write_float_grid(
        file, "density", kN, kN, kN,
        [](int i, int j, int k) {
            const Vec3 p = (Vec3(i, j, k) - Vec3(0.5f * (kN - 1))) / (0.5f * kN);
            return glm::length(p) < 1.0f ? 1.0f : 0.0f;
        },
        Vec3(1.0f / kN), Vec3(-0.5f + 0.5f / kN));
    SceneDesc d;
    d.camera.position = Vec3(0.0f, 2.6f, 3.2f);
    d.camera.look_at = Vec3(0.0f, 0.4f, 0.0f);
    d.camera.fov_deg = 50.0f;
    d.camera.width = 32;
    d.camera.height = 24;
    if (ground) add_ground(&d, 0.0f, 3.0f, 0.7f);
    d.media.push_back(vdb_medium(file, sigma_s, sigma_a));
    d.media[0].transform.matrix = glm::translate(Mat4(1.0f), Vec3(0.0f, 0.8f, 0.0f));
    d.media[0].emission = constant_emission(Color(1.0f, 0.6f, 0.3f));
    return d;
}

/// The scene path-traced at path_spp and photon-mapped (4 spp, the given budgets), and the mask
/// of the pixels where the photon film sees emission directly (`seen`) or not.
struct Renders {
    Image path;
    Film photon;
    std::vector<bool> mask;
};

Renders render_both(SceneDesc d, int path_spp, uint64_t global, uint64_t volume, bool seen) {
    Renders r;
    d.render.integrator = Integrator::Path;
    d.render.spp = path_spp;
    r.path = run_pipeline(d, true).film.beauty;
    d.render.integrator = Integrator::Photon;
    d.render.spp = 4;
    d.photons.global = global;
    d.photons.volume = volume;
    r.photon = run_pipeline(d, true).film;
    r.mask.resize(r.path.pixels.size());
    for (size_t i = 0; i < r.mask.size(); ++i)
        r.mask[i] = (max_component(r.photon.layer(Layer::Emission).pixels[i]) > 0.0f) == seen;
    return r;
}

/// Mean luminance over the pixels where `mask` holds.
double masked_mean(const Image& image, const std::vector<bool>& mask) {
    double sum = 0.0;
    int n = 0;
    for (size_t i = 0; i < mask.size(); ++i) {
        if (!mask[i]) continue;
        sum += luminance(image.pixels[i]);
        ++n;
    }
    EXPECT_GT(n, 40);
    return sum / n;
}

TEST(EmissionRender, SelfLitSphereLightsTheGroundAsThePathTracerDoes) {
    const TempDir dir("emission_sphere");
    // The ground: pixels the medium does not cover (no emission seen).
    const Renders r = render_both(self_lit_sphere(dir, Color(0.0f), Color(3.0f), true), 1024,
                                  400000, 100000, false);
    const double photon = masked_mean(r.photon.beauty, r.mask), path = masked_mean(r.path, r.mask);
    std::printf("ground: photon %.5f, path %.5f\n", photon, path);
    EXPECT_NEAR(photon, path, 0.03 * path);
    EXPECT_NEAR(r.photon.beauty.mean(), r.path.mean(), 0.02 * r.path.mean()) << "the whole image";
}

TEST(EmissionRender, ScatteringEmittingCloudMatchesThePathTracer) {
    // Albedo 0.8: most of what leaves the cloud has scattered in it; the photon integrator has it
    // from the volume map (volume_multiple) and the emission it sees directly.
    const TempDir dir("emission_cloud");
    const Renders r = render_both(self_lit_sphere(dir, Color(4.0f), Color(1.0f), false), 256,
                                  100000, 400000, true);
    const double photon = masked_mean(r.photon.beauty, r.mask), path = masked_mean(r.path, r.mask);
    const double multiple = masked_mean(r.photon.layer(Layer::VolumeMultiple), r.mask);
    std::printf("cloud: photon %.5f (volume_multiple %.5f), path %.5f\n", photon, multiple, path);
    EXPECT_GT(multiple, 0.3 * photon) << "the scattered light is a large part";
    EXPECT_NEAR(photon, path, 0.03 * path);
}

}  // namespace
}  // namespace fogmap
