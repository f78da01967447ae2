// The reference path tracer against closed forms: white furnaces (energy is neither lost nor
// gained), a diffuse plane under a sun, a plane under a rectangular area light (form factor),
// single scattering in a slab and, with paths ended by PathPolicy::pixel_estimate, in a cube, the
// layers' split of a slab's light and of a sky seen through a mirror, and bit-identical images for
// 1 and 2 threads.
// Stochastic checks use n independent samples and a tolerance of 3 (or 4) standard errors of
// the sample mean, estimated from the same samples.

#include "render/path_tracer.h"

#include "core/parallel.h"
#include "core/sampling.h"
#include "media/volume_gen.h"
#include "scene/scene.h"
#include "scene_builders.h"
#include "slab_reference.h"

#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>

namespace fogmap {
namespace {

using namespace test;

struct MeanEstimate {
    double mean = 0.0, standard_error = 0.0;
};

// Mean radiance (channel c) of n samples of one ray, with its standard error.
MeanEstimate radiance_mean(const Scene& scene, int max_depth, const Ray& ray, int n, int c = 0) {
    const PathTracer tracer(scene, max_depth);
    PathTracer::ThreadState ts = tracer.make_state();
    double sum = 0.0, sum2 = 0.0;
    for (int i = 0; i < n; ++i) {
        Rng rng(42, i);
        const double v = tracer.radiance(ray, rng, ts)[c];
        sum += v;
        sum2 += v * v;
    }
    const double mean = sum / n;
    return {mean, std::sqrt(std::max(0.0, sum2 / n - mean * mean) / n)};
}

// Each layer's mean radiance (channel 0) of n samples of one ray, with its standard error; every
// sample's layers must add up to its radiance.
std::array<MeanEstimate, kLayerCount> layer_means(const Scene& scene, const Ray& ray, int n) {
    const PathTracer tracer(scene, RenderSettings{}.max_depth);
    PathTracer::ThreadState ts = tracer.make_state();
    ts.layered = true;
    std::array<double, kLayerCount> sum{}, sum2{};
    for (int i = 0; i < n; ++i) {
        Rng rng(43, i);
        const double L = tracer.radiance(ray, rng, ts)[0];
        double parts = 0.0;
        for (int l = 0; l < kLayerCount; ++l) {
            const double v = ts.layers[size_t(l)][0];
            parts += v;
            sum[size_t(l)] += v;
            sum2[size_t(l)] += v * v;
        }
        EXPECT_NEAR(parts, L, 1e-5 * L) << "sample " << i;
    }
    std::array<MeanEstimate, kLayerCount> out;
    for (size_t l = 0; l < out.size(); ++l) {
        const double mean = sum[l] / n;
        out[l] = {mean, std::sqrt(std::max(0.0, sum2[l] / n - mean * mean) / n)};
    }
    return out;
}

// Henyey–Greenstein written out independently of media/henyey_greenstein.h.
double hg_phase_reference(double cos_theta, double g) {
    return (1.0 - g * g) / (4.0 * kPiDouble * std::pow(1.0 + g * g - 2.0 * g * cos_theta, 1.5));
}

SceneDesc base_desc() {
    SceneDesc d;
    d.materials["white"] = MaterialDesc{MaterialType::Diffuse, Color(1.0f), 1.5f};
    d.materials["grey"] = MaterialDesc{MaterialType::Diffuse, Color(0.5f), 1.5f};
    return d;
}

TEST(WhiteFurnace, AlbedoOneHomogeneousMediumRendersTheEnvironment) {
    for (float sigma : {0.5f, 5.0f}) {
        SceneDesc d = base_desc();
        d.lights.push_back(environment(0.8f));
        d.media.push_back(
            homogeneous(Box3{Vec3(-1.0f), Vec3(1.0f)}, Color(sigma), Color(0.0f), 0.6f));
        const auto scene = load_scene(d);
        const Ray ray{Vec3(0.2f, 0.1f, 5.0f), glm::normalize(Vec3(-0.05f, 0.0f, -1.0f))};
        const MeanEstimate e = radiance_mean(*scene, 100000, ray, 20000);
        EXPECT_NEAR(e.mean, 0.8, 3.0 * e.standard_error + 1e-6) << "sigma " << sigma;
        // The camera inside the medium sees the same.
        const Ray inside{Vec3(0.3f, -0.2f, 0.1f), glm::normalize(Vec3(1.0f, 2.0f, -0.5f))};
        const MeanEstimate f = radiance_mean(*scene, 100000, inside, 20000);
        EXPECT_NEAR(f.mean, 0.8, 3.0 * f.standard_error + 1e-6) << "inside, sigma " << sigma;
    }
}

TEST(WhiteFurnace, VdbDensityOverFourDecadesRendersTheEnvironment) {
    const auto path = std::filesystem::temp_directory_path() / "fogmap_furnace_decades.vdb";
    // Density 10^(-4 t) with t running 0..1 across the grid's diagonal: four orders of magnitude.
    write_float_grid(
        path.string(), "density", 24, 24, 24,
        [](int i, int j, int k) {
            return std::pow(10.0f, -4.0f * static_cast<float>(i + j + k) / 69.0f);
        },
        Vec3(0.1f));
    SceneDesc d = base_desc();
    d.lights.push_back(environment(1.3f));
    MediumDesc m;
    m.type = MediumType::Vdb;
    m.file = path.string();
    m.sigma_s = Color(40.0f);  // optical depth up to ~100 across the dense corner
    m.g = -0.3f;
    d.media.push_back(m);
    const auto scene = load_scene(d);
    std::filesystem::remove(path);
    for (const Vec3& target : {Vec3(0.3f), Vec3(1.2f), Vec3(2.0f)}) {
        const Vec3 o(-3.0f, 0.5f, -2.0f);
        const Ray ray{o, glm::normalize(target - o)};
        const MeanEstimate e = radiance_mean(*scene, 100000, ray, 10000);
        EXPECT_NEAR(e.mean, 1.3, 3.0 * e.standard_error + 1e-6);
    }
}

TEST(WhiteFurnace, ConvexAlbedoOneSurfaceRendersTheEnvironment) {
    // A convex Lambertian object of albedo 1 under a uniform sky reflects exactly the sky
    // radiance: checks environment sampling, cosine sampling and their MIS weights.
    SceneDesc d = base_desc();
    d.lights.push_back(environment(0.7f));
    ShapeDesc s;
    s.type = ShapeType::Sphere;
    s.material = "white";
    d.shapes.push_back(s);
    const auto scene = load_scene(d);
    const Ray ray{Vec3(0.3f, 0.2f, 4.0f), glm::normalize(Vec3(-0.1f, 0.0f, -1.0f))};
    const MeanEstimate e = radiance_mean(*scene, 64, ray, 20000);
    EXPECT_NEAR(e.mean, 0.7, 3.0 * e.standard_error + 1e-6);
}

SceneDesc ground_plane_desc() {
    SceneDesc d = base_desc();
    d.shapes.push_back(quad(Vec3(-50.0f, 0.0f, -50.0f), Vec3(0.0f, 0.0f, 100.0f),
                            Vec3(100.0f, 0.0f, 0.0f), "grey"));
    return d;
}

TEST(DiffusePlane, UnderSunRendersAlbedoTimesIrradianceTimesCosineOverPi) {
    for (float theta_deg : {0.0f, 35.0f, 70.0f}) {
        SceneDesc d = ground_plane_desc();
        const float theta = theta_deg * kPi / 180.0f;
        LightDesc sun;
        sun.type = LightType::Sun;
        sun.irradiance = Color(3.0f);
        sun.direction = Vec3(std::sin(theta), -std::cos(theta), 0.0f);
        d.lights.push_back(sun);
        const auto scene = load_scene(d);
        const Ray ray{Vec3(0.3f, 2.0f, 0.4f), glm::normalize(Vec3(0.1f, -1.0f, 0.2f))};
        const MeanEstimate e = radiance_mean(*scene, 64, ray, 200);
        const double expected = 0.5 * 3.0 * std::cos(theta) / kPi;
        EXPECT_NEAR(e.mean, expected, 1e-5) << "theta " << theta_deg;
    }
}

TEST(DiffusePlane, UnderRectangularLightMatchesFormFactor) {
    // Point at the origin below the corner of an a x b rectangle at height h of radiance L:
    // L_out = albedo · L · F, F the differential-area-to-parallel-rectangle form factor
    // F = 1/(2π) [A/√(1+A²) atan(B/√(1+A²)) + B/√(1+B²) atan(A/√(1+B²))], A = a/h, B = b/h.
    const float a = 1.5f, b = 0.8f, h = 1.0f, L = 2.0f;
    SceneDesc d = ground_plane_desc();
    LightDesc quad;
    quad.type = LightType::Quad;
    quad.corner = Vec3(0.0f, h, 0.0f);
    quad.edge_u = Vec3(a, 0.0f, 0.0f);  // u x v points down, towards the floor
    quad.edge_v = Vec3(0.0f, 0.0f, b);
    quad.radiance = Color(L);
    d.lights.push_back(quad);
    const auto scene = load_scene(d);
    const double A = a / h, B = b / h;
    const double F = (A / std::sqrt(1 + A * A) * std::atan(B / std::sqrt(1 + A * A)) +
                      B / std::sqrt(1 + B * B) * std::atan(A / std::sqrt(1 + B * B))) /
                     (2.0 * kPiDouble);
    const Vec3 o(-0.5f, 0.5f, -0.5f);
    const Ray ray{o, glm::normalize(Vec3(0.0f) - o)};
    const MeanEstimate e = radiance_mean(*scene, 1, ray, 40000);
    EXPECT_NEAR(e.mean, 0.5 * L * F, 3.0 * e.standard_error);
}

TEST(SingleScattering, ThinSlabMatchesClosedForm) {
    // Slab y in [0, d], camera below looking up, delta sun at angle θ; max_depth 1 keeps single
    // scattering only: L = σ_s p(cos) E (e^{−σ_t d} − e^{−σ_t d / cos θ}) / (σ_t (1/cos θ − 1)).
    const float d_slab = 0.5f, sigma_s = 0.6f, sigma_a = 0.3f, g = 0.4f, E = 5.0f;
    const float theta = 40.0f * kPi / 180.0f;
    SceneDesc d = base_desc();
    LightDesc sun;
    sun.type = LightType::Sun;
    sun.irradiance = Color(E);
    sun.direction = Vec3(std::sin(theta), -std::cos(theta), 0.0f);
    d.lights.push_back(sun);
    d.media.push_back(homogeneous(Box3{Vec3(-100.0f, 0.0f, -100.0f), Vec3(100.0f, d_slab, 100.0f)},
                                  Color(sigma_s), Color(sigma_a), g));
    const auto scene = load_scene(d);
    const Ray ray{Vec3(0.0f, -1.0f, 0.0f), Vec3(0.0f, 1.0f, 0.0f)};
    const MeanEstimate e = radiance_mean(*scene, 1, ray, 100000);
    const double sigma_t = sigma_s + sigma_a, c = 1.0 / std::cos(theta);
    // Scattering angle: light travels along sun.direction and leaves towards the camera (−y).
    const double cos_scatter = glm::dot(glm::normalize(sun.direction), Vec3(0.0f, -1.0f, 0.0f));
    const double p = hg_phase_reference(cos_scatter, g);
    const double expected = sigma_s * p * E *
                            (std::exp(-sigma_t * d_slab) - std::exp(-sigma_t * d_slab * c)) /
                            (sigma_t * (c - 1.0));
    EXPECT_NEAR(e.mean, expected, 3.0 * e.standard_error);
}

TEST(PathLayers, SingleScatteringInASlabIsTheVolumeSingleLayer) {
    // The slab of ThinSlabMatchesClosedForm at its full depth: the volume_single layer holds
    // the closed form's single scattering, volume_multiple the rest, and no other layer any.
    const float d_slab = 0.5f, sigma_s = 0.6f, sigma_a = 0.3f, g = 0.4f, E = 5.0f;
    const float theta = 40.0f * kPi / 180.0f;
    SceneDesc d = base_desc();
    d.lights.push_back(sun(Vec3(std::sin(theta), -std::cos(theta), 0.0f), E));
    d.media.push_back(homogeneous(Box3{Vec3(-100.0f, 0.0f, -100.0f), Vec3(100.0f, d_slab, 100.0f)},
                                  Color(sigma_s), Color(sigma_a), g));
    const auto scene = load_scene(d);
    const Ray ray{Vec3(0.0f, -1.0f, 0.0f), Vec3(0.0f, 1.0f, 0.0f)};
    const auto layers = layer_means(*scene, ray, 100000);
    const double sigma_t = sigma_s + sigma_a, c = 1.0 / std::cos(theta);
    const double p = hg_phase_reference(std::cos(theta), g);  // light along sun, out along -y
    const double single = sigma_s * p * E *
                          (std::exp(-sigma_t * d_slab) - std::exp(-sigma_t * d_slab * c)) /
                          (sigma_t * (c - 1.0));
    const MeanEstimate& s = layers[size_t(Layer::VolumeSingle)];
    EXPECT_NEAR(s.mean, single, 3.0 * s.standard_error);
    EXPECT_GT(layers[size_t(Layer::VolumeMultiple)].mean, 0.0);
    for (Layer l : {Layer::Direct, Layer::Caustic, Layer::Indirect, Layer::Emission})
        EXPECT_EQ(layers[size_t(l)].mean, 0.0) << kLayerNames[size_t(l)];
}

TEST(PathLayers, SkyThroughAMirrorIsTheCausticLayer) {
    // A diffuse floor (albedo ρ) under a constant sky L, a large vertical mirror one unit beside
    // the point seen: the mirror turns the half of the floor's hemisphere that faces it (half of
    // the cosine-weighted measure) to sky again, so the point's radiance is ρ L, of which ρ L / 2
    // comes straight from the sky (direct) and ρ L / 2 by the mirror (caustic); upwards from a
    // plane nothing reaches the floor again (no indirect).
    const float rho = 0.5f, L = 1.0f, big = 1e4f;
    SceneDesc d = base_desc();
    d.lights.push_back(environment(L));
    add_ground(&d, 0.0f, big, rho);
    d.materials["mirror"] = MaterialDesc{MaterialType::Mirror, Color(1.0f), 1.5f};
    d.shapes.push_back(quad(Vec3(1.0f, 0.0f, -big), Vec3(0.0f, big, 0.0f),
                            Vec3(0.0f, 0.0f, 2.0f * big), "mirror"));
    const auto scene = load_scene(d);
    const Ray ray{Vec3(-0.3f, 1.0f, 0.0f), glm::normalize(Vec3(0.3f, -1.0f, 0.0f))};
    const auto layers = layer_means(*scene, ray, 40000);
    for (Layer l : {Layer::Direct, Layer::Caustic}) {
        const MeanEstimate& e = layers[size_t(l)];
        EXPECT_NEAR(e.mean, 0.5 * rho * L, 3.0 * e.standard_error + 1e-6) << kLayerNames[size_t(l)];
    }
    for (Layer l : {Layer::VolumeSingle, Layer::VolumeMultiple, Layer::Indirect, Layer::Emission})
        EXPECT_EQ(layers[size_t(l)].mean, 0.0) << kLayerNames[size_t(l)];
}

TEST(DepthCap, EveryPathInADeepConservativeMediumIsCountedAsCut) {
    // Camera inside an albedo-1 cube with optical radius 1000: every path scatters again and
    // again (roulette never ends an albedo-1 path), so with max_depth 3 each sample is cut;
    // in vacuum none is.
    for (const bool medium : {true, false}) {
        SceneDesc d = base_desc();
        LightDesc sky;
        sky.type = LightType::Environment;
        sky.radiance = Color(1.0f);
        d.lights.push_back(sky);
        if (medium)
            d.media.push_back(
                homogeneous(Box3{Vec3(-10.0f), Vec3(10.0f)}, Color(1000.0f), Color(0.0f), 0.0f));
        d.camera.position = Vec3(0.0f);
        d.camera.look_at = Vec3(0.0f, 0.0f, -1.0f);
        d.camera.width = 8;
        d.camera.height = 6;
        d.render.max_depth = 3;
        d.render.spp = 2;
        RenderStats stats;
        render_path(*load_scene(d), d.render, true, &stats);
        EXPECT_EQ(stats.capped, medium ? stats.samples : 0u);
    }
}

// The path tracer in the slab of `fogmap validate`: a laterally wide homogeneous slab of unit
// thickness under a sun at normal incidence (irradiance 1). Diffuse reflectance is
// Rd = ∫ L_up cos θ dω / E: rays leave a point just above the slab downwards in cosine-weighted
// directions, so Rd = π × mean radiance; Td likewise from below, and Tt = Td + e^{−τ} (the
// unscattered beam, a delta the rays never see). Scattering weighs the throughput by the albedo,
// so paths end by Russian roulette: a roulette that forgot to divide by its survival probability
// would lose energy here. Reference: adding-doubling (slab_reference.h); tolerance 3 SE.
TEST(PathTracedSlab, MatchesAddingDoublingWithRouletteActive) {
    struct Case {
        double tau, albedo, g;
    };
    for (const Case c : {Case{2.0, 0.9, 0.75}, Case{10.0, 0.99, 0.75}}) {
        SceneDesc d;
        d.lights.push_back(sun(Vec3(0.0f, -1.0f, 0.0f), 1.0f));
        d.media.push_back(homogeneous(Box3{Vec3(-1e4f, -1.0f, -1e4f), Vec3(1e4f, 0.0f, 1e4f)},
                                      Color(float(c.albedo * c.tau)),
                                      Color(float((1.0 - c.albedo) * c.tau)), float(c.g)));
        const auto scene = load_scene(d);
        const PathTracer tracer(*scene, RenderSettings{}.max_depth);
        PathTracer::ThreadState ts = tracer.make_state();
        // π × the mean radiance over cosine-weighted directions about `up`, from `origin`.
        auto flux = [&](const Vec3& origin, const Vec3& up, uint64_t stream) {
            constexpr int kN = 40000;
            double sum = 0.0, sum2 = 0.0;
            for (int i = 0; i < kN; ++i) {
                Rng rng(stream, i);
                const Vec3 w = sample_cosine_hemisphere(up, Vec2(rng.uniform(), rng.uniform()));
                const double v = kPi * tracer.radiance(Ray{origin, -w}, rng, ts).x;
                sum += v;
                sum2 += v * v;
            }
            const double mean = sum / kN;
            return MeanEstimate{mean, std::sqrt(std::max(0.0, sum2 / kN - mean * mean) / kN)};
        };
        const slab_reference::SlabValues ref =
            slab_reference::adding_doubling(c.tau, c.albedo, c.g);
        const MeanEstimate rd = flux(Vec3(0.0f, 1e-3f, 0.0f), Vec3(0.0f, 1.0f, 0.0f), 41);
        const MeanEstimate td = flux(Vec3(0.0f, -1.001f, 0.0f), Vec3(0.0f, -1.0f, 0.0f), 43);
        EXPECT_NEAR(rd.mean, ref.rd.mean, 3.0 * rd.standard_error) << "Rd, tau " << c.tau;
        EXPECT_NEAR(td.mean + std::exp(-c.tau), ref.tt.mean, 3.0 * td.standard_error)
            << "Tt, tau " << c.tau;
    }
}

// PathPolicy's factories name the kind and carry only what it reads.
TEST(PathPolicy, FactoriesNameTheirKind) {
    const PathPolicy plain = PathPolicy::plain();
    EXPECT_EQ(plain.kind(), MediumVertex::Continue);
    EXPECT_FALSE(plain.guides(1));
    EXPECT_FALSE(plain.sun_covers(0));
    const PhotonMap empty;
    const std::vector<Medium> media;
    const AdjointGrid grid(empty, media, 0.25f);
    const PathPolicy estimate = PathPolicy::pixel_estimate(grid);
    EXPECT_EQ(estimate.kind(), MediumVertex::EndInGrid);
    EXPECT_EQ(estimate.split().grid, &grid);
    EXPECT_EQ(estimate.split().pixels, nullptr);
    const Image pixels(1, 1);
    const PathPolicy guided = PathPolicy::guided(nullptr, AdjointSplit{&grid, &pixels});
    EXPECT_EQ(guided.kind(), MediumVertex::Guided);
    EXPECT_FALSE(guided.guides(1));  // no guide: the phase alone
    EXPECT_EQ(guided.split().pixels, &pixels);
    const VolumeMapEnd end(empty, media, 0.25f, 2);
    const PathPolicy map_end = PathPolicy::end_in_map(end, nullptr);
    EXPECT_EQ(map_end.kind(), MediumVertex::EndInMap);
    EXPECT_EQ(&map_end.end(), &end);
    EXPECT_FALSE(map_end.sun_covers(0));
}

// PathPolicy::pixel_estimate ends paths at their first medium vertex with its direct light plus
// L̃; with an empty map L̃ is 0, so the estimate is single scattering, here in closed form: a ray
// along z through the middle of the cube [−1, 1]³ under a sun straight above (its shadow rays 1
// long, at 90° to the ray), L = σ_s p(0) E e^{−σ_t} (1 − e^{−2 σ_t}) / σ_t. Tolerance 4 SE.
TEST(PathPolicy, PixelEstimateWithNoLightToComeIsSingleScattering) {
    const double sigma_s = 0.6, sigma_a = 0.4, g = 0.3, sigma_t = sigma_s + sigma_a;
    SceneDesc d;
    d.lights.push_back(sun(Vec3(0.0f, -1.0f, 0.0f), 1.0f));
    d.media.push_back(homogeneous(Box3{Vec3(-1.0f), Vec3(1.0f)}, Color(float(sigma_s)),
                                  Color(float(sigma_a)), float(g)));
    const auto scene = load_scene(d);
    const PhotonMap empty;
    const AdjointGrid grid(empty, scene->media, 0.25f);
    const PathTracer tracer(*scene, RenderSettings{}.max_depth, PathPolicy::pixel_estimate(grid));
    PathTracer::ThreadState ts = tracer.make_state();
    constexpr int kN = 40000;
    double sum = 0.0, sum2 = 0.0;
    for (int i = 0; i < kN; ++i) {
        Rng rng(47, i);
        const double v =
            tracer.radiance(Ray{Vec3(0.0f, 0.0f, -3.0f), Vec3(0.0f, 0.0f, 1.0f)}, rng, ts).x;
        sum += v;
        sum2 += v * v;
    }
    const double mean = sum / kN;
    const double se = std::sqrt(std::max(0.0, sum2 / kN - mean * mean) / kN);
    const double expected = sigma_s * hg_phase_reference(0.0, g) * std::exp(-sigma_t) *
                            (1.0 - std::exp(-2.0 * sigma_t)) / sigma_t;
    EXPECT_NEAR(mean, expected, 4.0 * se);
    EXPECT_GT(se, 0.0);
}

TEST(Determinism, OneAndTwoThreadsGiveIdenticalPixels) {
    const auto path = std::filesystem::temp_directory_path() / "fogmap_determinism.vdb";
    write_float_grid(
        path.string(), "density", 12, 12, 12,
        [](int i, int j, int k) { return 0.1f * ((i * 7 + j * 3 + k) % 10); }, Vec3(0.1f),
        Vec3(-0.6f, 0.0f, -0.6f));
    SceneDesc d = ground_plane_desc();
    d.lights.push_back(environment(0.3f));
    LightDesc sun;
    sun.type = LightType::Sun;
    sun.direction = Vec3(0.3f, -1.0f, 0.2f);
    sun.irradiance = Color(2.0f);
    d.lights.push_back(sun);
    MediumDesc m;
    m.type = MediumType::Vdb;
    m.file = path.string();
    m.sigma_s = Color(8.0f, 6.0f, 4.0f);
    m.sigma_a = Color(0.5f);
    m.g = 0.5f;
    d.media.push_back(m);
    d.camera.position = Vec3(0.0f, 0.8f, 3.0f);
    d.camera.look_at = Vec3(0.0f, 0.5f, 0.0f);
    d.camera.width = 40;
    d.camera.height = 30;
    const auto scene = load_scene(d);
    std::filesystem::remove(path);
    RenderSettings rs;
    rs.spp = 4;
    rs.seed = 9;
    Image one, two;
    {
        const ThreadLimit limit(1);
        one = render_path(*scene, rs, true, nullptr).beauty;
    }
    {
        const ThreadLimit limit(2);
        two = render_path(*scene, rs, true, nullptr).beauty;
    }
    ASSERT_EQ(one.pixels.size(), two.pixels.size());
    EXPECT_EQ(0,
              std::memcmp(one.pixels.data(), two.pixels.data(), one.pixels.size() * sizeof(Color)));
    EXPECT_GT(one.mean(), 0.0);
    rs.seed = 10;  // and the seed matters
    const Image other = render_path(*scene, rs, true, nullptr).beauty;
    EXPECT_NE(
        0, std::memcmp(one.pixels.data(), other.pixels.data(), one.pixels.size() * sizeof(Color)));
}

}  // namespace
}  // namespace fogmap
