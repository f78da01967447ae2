// The extreme-case matrix, cases that must hold: every case goes through validate() and
// run_pipeline() with both integrators (the reference path tracer and the photon-map pipeline) on a
// tiny image, and must end with finite pixels in every AOV, no dropped (NaN/Inf) samples and photon
// maps within their budgets — in bounded time (a watchdog ends the process with the case's name) —
// or with a clear InputError naming the field.
// Where a closed form exists the value is checked too: an absorbing medium shows the sky times
// exp(-tau) and nothing scattered; a near-vacuum shows the sky; a camera inside an albedo-1
// medium under a uniform sky sees the sky radiance (white furnace).
// Stochastic checks compare the image mean with the expected value within 4 standard errors of
// that mean, estimated from the spread of the pixel values (each pixel an independent mean of
// spp samples), plus a small absolute floor for noise-free images.

#include "core/error.h"
#include "media/density_grid.h"
#include "media/volume_gen.h"
#include "render/path_tracer.h"
#include "render/pipeline.h"
#include "render/run_setup.h"
#include "scene/scene.h"
#include "scene_builders.h"
#include "test_support.h"

#include <gtest/gtest.h>
#include <openvdb/openvdb.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <functional>
#include <limits>
#include <mutex>
#include <optional>
#include <ostream>
#include <string>
#include <thread>
#include <tuple>
#include <vector>

namespace fogmap {
namespace {

namespace fs = std::filesystem;
using namespace test;

// Sanitizer builds run 3-10x slower; the watchdog scales its limit so they do not trip it.
#if defined(__SANITIZE_ADDRESS__)
constexpr int kTimeScale = 10;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
constexpr int kTimeScale = 10;
#else
constexpr int kTimeScale = 1;
#endif
#else
constexpr int kTimeScale = 1;
#endif

constexpr float kSky = 0.5f;  // radiance of the uniform environment of the base scene

/// Ends the process with a message if the guarded scope runs longer than `seconds`: a hang shows
/// up as one failed test naming the case instead of a CTest timeout of the whole group.
class Watchdog {
public:
    Watchdog(std::string what, int seconds)
        : thread_([this, what = std::move(what), seconds] {
              std::unique_lock<std::mutex> lock(mutex_);
              if (!cv_.wait_for(lock, std::chrono::seconds(seconds), [this] { return done_; })) {
                  std::fprintf(stderr, "extreme case %s: still running after %d s (a hang)\n",
                               what.c_str(), seconds);
                  std::fflush(stderr);
                  std::_Exit(3);
              }
          }) {}
    ~Watchdog() {
        {
            std::lock_guard<std::mutex> lock(mutex_);
            done_ = true;
        }
        cv_.notify_all();
        thread_.join();
    }

private:
    std::mutex mutex_;
    std::condition_variable cv_;
    bool done_ = false;
    std::thread thread_;
};

/// 8x6 pixels looking at the origin from +z, a uniform sky and a sun, no surfaces; small photon
/// budgets, one thread (the tests share two cores); the default depth limits (paths end by
/// Russian roulette).
SceneDesc base_scene() {
    SceneDesc d;
    d.camera.position = Vec3(0.0f, 0.0f, 4.0f);
    d.camera.look_at = Vec3(0.0f);
    d.camera.width = 8;
    d.camera.height = 6;
    d.lights = {environment(kSky), sun(glm::normalize(Vec3(0.3f, -1.0f, 0.2f)), 2.0f)};
    d.render.spp = 4;
    d.render.threads = 1;
    d.render.seed = 7;
    d.photons.global = 500;
    d.photons.caustic = 200;
    d.photons.volume = 2000;
    d.photons.max_emitted = 40000;
    d.global.k = 20;
    d.caustic.k = 20;
    d.volume.k = 20;
    return d;
}

/// Adds a diffuse ground quad at y = -1.5 (exercises the global map and surface shadow rays).
void add_ground(SceneDesc* d) { test::add_ground(d, -1.5f, 4.0f, 0.6f); }

/// Writes an n^3 grid centred on the origin (voxel centres at ((i - (n-1)/2) * voxel, ...)).
fs::path cube_grid(const fs::path& dir, int n, float voxel,
                   const std::function<float(int, int, int)>& value) {
    const fs::path p = dir / "grid.vdb";
    write_float_grid(p.string(), "density", n, n, n, value, Vec3(voxel),
                     Vec3(-0.5f * static_cast<float>(n - 1) * voxel));
    return p;
}

fs::path constant_grid(const fs::path& dir, int n, float voxel, float density) {
    return cube_grid(dir, n, voxel, [density](int, int, int) { return density; });
}

/// A base scene holding an 8^3 grid of voxel 0.25 (2 world units across) whose optical depth
/// per voxel is tau_voxel, with albedo `albedo`.
SceneDesc tau_per_voxel_scene(const fs::path& dir, float tau_voxel, float albedo) {
    constexpr float kVoxel = 0.25f;
    SceneDesc d = base_scene();
    const float sigma_t = tau_voxel / kVoxel;
    d.media.push_back(vdb_medium(constant_grid(dir, 8, kVoxel, 1.0f), Color(albedo * sigma_t),
                                 Color((1.0f - albedo) * sigma_t)));
    return d;
}

/// Expects the image mean over pixels of channel 0 within 4 standard errors (+ floor) of
/// `expected` (pixels are independent estimates; the unbiased variance).
void expect_mean(const Image& img, double expected, double floor, const std::string& what) {
    SampleStats<> s;
    for (const Color& c : img.pixels) s.add(c.x);
    const double mean = s.mean(), se = s.standard_error_unbiased();
    EXPECT_NEAR(mean, expected, 4.0 * se + floor) << what << ": mean " << mean << " +- " << se;
}

void expect_all_zero(const Image& img, const std::string& what) {
    for (const Color& c : img.pixels) {
        ASSERT_EQ(c, Color(0.0f)) << what << " must be exactly 0";
    }
}

using SceneFn = std::function<SceneDesc(const fs::path& dir)>;
using CheckFn = std::function<void(const PipelineResult&, Integrator)>;

/// An independent expected image: the same scene built another way, whose image has the same
/// expectation by a stated symmetry (sanitising rule, scale invariance, a limit, an equivalent
/// estimator), rendered in the same run.
struct SameAs {
    SceneFn scene;
    /// Rendered with the path tracer at max_depth 1 whatever the case's integrator (direct light
    /// and single scattering: what the photon integrator gives without photons).
    bool path_depth_one = false;
    /// Bit-identical pixels expected (the same grid values, the same random numbers).
    bool exact = false;
    /// Allowed relative difference of the means besides 4 standard errors, with its reason.
    double floor = 0.0;
    /// Only the photon integrator's image is compared.
    bool photon_only = false;
};

struct Case {
    Case(std::string name_, SceneFn scene_, CheckFn check_ = {}, std::string error_field_ = {})
        : name(std::move(name_)),
          scene(std::move(scene_)),
          check(std::move(check_)),
          error_field(std::move(error_field_)) {}
    std::string name;
    SceneFn scene;
    /// Value checks on the result (closed forms); may be empty.
    CheckFn check;
    /// When set: the case must end with an InputError naming this JSON pointer.
    std::string error_field;
    /// When set: the image equals this one's in expectation (or exactly).
    std::optional<SameAs> same_as;
    int timeout_s = 30;
};

// GoogleTest prints parameters of failed tests: the case's name, not its bytes.
void PrintTo(const Case& c, std::ostream* os) { *os << c.name; }

std::vector<Case> tau_cases() {
    std::vector<Case> cases;
    const std::pair<const char*, float> taus[] = {
        {"1em6", 1e-6f}, {"1em3", 1e-3f}, {"1", 1.0f}, {"1e2", 1e2f}, {"1e4", 1e4f}};
    for (const auto& [label, tau] : taus) {
        const float t = tau;
        Case c{std::string("TauPerVoxel_") + label,
               [t](const fs::path& dir) { return tau_per_voxel_scene(dir, t, 0.9f); }};
        if (t <= 1e-6f) {
            // Optical depth 8e-6 across: the sky within 1e-4 relative.
            c.check = [](const PipelineResult& r, Integrator) {
                expect_mean(r.film.beauty, kSky, 1e-4 * kSky, "near vacuum");
            };
        }
        cases.push_back(c);
    }
    return cases;
}

std::vector<Case> density_scale_cases() {
    std::vector<Case> cases;
    const std::pair<const char*, float> scales[] = {
        {"1em9", 1e-9f}, {"1em3", 1e-3f}, {"1e3", 1e3f}, {"1e9", 1e9f}};
    for (const auto& [label, scale] : scales) {
        const float s = scale;
        Case c{std::string("DensityScale_") + label, [s](const fs::path& dir) {
                   SceneDesc d = base_scene();
                   d.media.push_back(
                       vdb_medium(constant_grid(dir, 8, 0.25f, 1.0f), Color(0.8f), Color(0.2f), s));
                   return d;
               }};
        if (s <= 1e-9f) {
            // sigma_t = 1e-9 per unit over 2 units: vacuum to 1e-8 relative.
            c.check = [](const PipelineResult& r, Integrator) {
                expect_mean(r.film.beauty, kSky, 1e-5 * kSky, "density scale 1e-9");
            };
        }
        // Extinction 1e9 per unit over a box reaching 1.0: the mean free path is below float
        // resolution there (scene.cpp, check_resolvable): an InputError, not a different medium.
        if (s >= 1e9f) c.error_field = "/media/0";
        cases.push_back(c);
    }
    // sigma_s * density_scale overflows float: must be a clear error, not Inf coefficients.
    cases.push_back(Case{"DensityScaleOverflow",
                         [](const fs::path& dir) {
                             SceneDesc d = base_scene();
                             d.media.push_back(vdb_medium(constant_grid(dir, 8, 0.25f, 1.0f),
                                                          Color(1e30f), Color(0.0f), 1e9f));
                             return d;
                         },
                         {},
                         "/media/0/density_scale"});
    // Finite but absurd coefficients (1e20 per unit): free paths below float resolution, an
    // InputError (rendered, it would show a surface-like random walk, far too bright).
    cases.push_back(Case{"SigmaHugeGrid",
                         [](const fs::path& dir) {
                             SceneDesc d = base_scene();
                             d.media.push_back(vdb_medium(constant_grid(dir, 8, 0.25f, 1.0f),
                                                          Color(1e20f), Color(1e19f)));
                             return d;
                         },
                         {},
                         "/media/0"});
    auto opaque_box = [](float sigma) {
        return [sigma](const fs::path&) {
            SceneDesc d = base_scene();
            d.media.push_back(
                homogeneous(Box3{Vec3(-1.0f), Vec3(1.0f)}, Color(sigma), Color(0.1f * sigma)));
            return d;
        };
    };
    cases.push_back(Case{"SigmaHugeHomogeneous", opaque_box(1e20f), {}, "/media/0"});
    // About the densest a box reaching 1.0 may be (σ_t ≤ 2^20): opaque like σ = 1e4, a
    // semi-infinite medium of the same albedo behind each face. Light enters 1e-4 of the box's size
    // at σ = 1e4: 0.2% for what that moves.
    Case dense{"SigmaOpaqueHomogeneous", opaque_box(1e5f)};
    dense.same_as = SameAs{opaque_box(1e4f), false, false, 0.002};
    cases.push_back(dense);
    return cases;
}

std::vector<Case> voxel_size_cases() {
    std::vector<Case> cases;
    const std::pair<const char*, float> sizes[] = {
        {"1em4", 1e-4f}, {"1em2", 1e-2f}, {"1", 1.0f}, {"1e2", 1e2f}, {"1e4", 1e4f}};
    auto scaled = [](float v) {
        return [v](const fs::path& dir) {
            // Optical depth 1 per voxel whatever the scale; the camera stands 2 grid widths away.
            SceneDesc d = base_scene();
            d.camera.position = Vec3(0.0f, 0.0f, 16.0f * v);
            d.media.push_back(
                vdb_medium(constant_grid(dir, 8, v, 1.0f), Color(0.9f / v), Color(0.1f / v)));
            return d;
        };
    };
    for (const auto& [label, size] : sizes) {
        Case c{std::string("VoxelSize_") + label, scaled(size)};
        // Lights (sun irradiance, sky radiance) are scale-free and every default length (march
        // step, gather radii, ray offsets) scales with the scene, so the image is the unit
        // scale's; the same random numbers drive both, float rounding at other scales moves a few
        // paths (0.2%).
        if (size != 1.0f) c.same_as = SameAs{scaled(1.0f), false, false, 0.002};
        cases.push_back(c);
    }
    // Small voxels far from the origin: at x = 1000 a float step is 6e-5, the free path 1e-4:
    // refused (scene.cpp, check_resolvable).
    cases.push_back(Case{"VoxelSize_1em4_FarFromOrigin",
                         [](const fs::path& dir) {
                             SceneDesc d = base_scene();
                             const Vec3 at(1000.0f, 0.0f, 0.0f);
                             const fs::path p = dir / "far.vdb";
                             write_float_grid(
                                 p.string(), "density", 8, 8, 8, [](int, int, int) { return 1.0f; },
                                 Vec3(1e-4f), at);
                             d.camera.position = at + Vec3(0.0f, 0.0f, 0.005f);
                             d.camera.look_at = at + Vec3(4e-4f);
                             d.media.push_back(vdb_medium(p, Color(9000.0f), Color(1000.0f)));
                             return d;
                         },
                         {},
                         "/media/0"});
    return cases;
}

std::vector<Case> bad_voxel_cases() {
    std::vector<Case> cases;
    const float nan = std::numeric_limits<float>::quiet_NaN();
    const float inf = std::numeric_limits<float>::infinity();
    const float denorm = std::numeric_limits<float>::denorm_min();
    const std::pair<const char*, float> bad[] = {
        {"NaN", nan}, {"Inf", inf}, {"MinusInf", -inf}, {"Negative", -3.0f}, {"Denormal", denorm}};
    for (const auto& [label, value] : bad) {
        const float b = value;
        // Every third voxel bad, the rest density 1: the sanitised grid is the one written with 0
        // there, so the images are bit-identical.
        auto grid = [](float bad) {
            return [bad](const fs::path& dir) {
                SceneDesc d = base_scene();
                d.media.push_back(vdb_medium(cube_grid(dir, 8, 0.25f,
                                                       [bad](int i, int j, int k) {
                                                           return (i + j + k) % 3 == 0 ? bad : 1.0f;
                                                       }),
                                             Color(3.0f), Color(1.0f)));
                return d;
            };
        };
        Case c{std::string("BadVoxels_") + label, grid(b)};
        c.same_as = SameAs{grid(0.0f), false, /*exact=*/true};
        cases.push_back(c);
    }
    // A grid holding nothing but bad values is empty after sanitising: vacuum.
    cases.push_back(Case{"BadVoxels_AllNaN",
                         [nan](const fs::path& dir) {
                             SceneDesc d = base_scene();
                             d.media.push_back(vdb_medium(constant_grid(dir, 4, 0.25f, nan),
                                                          Color(3.0f), Color(1.0f)));
                             return d;
                         },
                         [](const PipelineResult& r, Integrator) {
                             expect_mean(r.film.beauty, kSky, 1e-6, "all-NaN grid = vacuum");
                         }});
    return cases;
}

std::vector<Case> grid_shape_cases() {
    std::vector<Case> cases;
    cases.push_back(Case{"EmptyGrid",
                         [](const fs::path& dir) {
                             SceneDesc d = base_scene();
                             d.media.push_back(vdb_medium(constant_grid(dir, 4, 0.25f, 0.0f),
                                                          Color(3.0f), Color(1.0f)));
                             return d;
                         },
                         [](const PipelineResult& r, Integrator) {
                             expect_mean(r.film.beauty, kSky, 1e-6, "empty grid = vacuum");
                         }});
    cases.push_back(Case{"OneVoxelGrid", [](const fs::path& dir) {
                             SceneDesc d = base_scene();
                             d.camera.position = Vec3(0.0f, 0.0f, 1.0f);
                             d.media.push_back(vdb_medium(constant_grid(dir, 1, 0.25f, 1.0f),
                                                          Color(20.0f), Color(2.0f)));
                             return d;
                         }});
    cases.push_back(Case{"OneVoxelGridOpaque", [](const fs::path& dir) {
                             SceneDesc d = base_scene();
                             d.camera.position = Vec3(0.0f, 0.0f, 1.0f);
                             d.media.push_back(vdb_medium(constant_grid(dir, 1, 0.25f, 1.0f),
                                                          Color(4e4f), Color(1.0f)));
                             return d;
                         }});
    return cases;
}

std::vector<Case> albedo_and_phase_cases() {
    std::vector<Case> cases;
    // Albedo 0: a slab of sigma_a = 2, 1 unit thick, seen head-on through a 1-degree field of
    // view (path length 1 within 2e-4): the sky times exp(-2), and nothing scattered.
    cases.push_back(Case{
        "AlbedoZeroSlab",
        [](const fs::path&) {
            SceneDesc d = base_scene();
            d.camera.fov_deg = 1.0f;
            d.render.spp = 64;
            d.media.push_back(
                homogeneous(Box3{Vec3(-50.0f, -50.0f, -0.5f), Vec3(50.0f, 50.0f, 0.5f)},
                            Color(0.0f), Color(2.0f)));
            return d;
        },
        [](const PipelineResult& r, Integrator integrator) {
            expect_mean(r.film.beauty, kSky * std::exp(-2.0), 1e-4, "sky through absorber");
            if (integrator == Integrator::Photon) {
                expect_all_zero(r.film.layer(Layer::VolumeSingle), "volume_single at albedo 0");
                expect_all_zero(r.film.layer(Layer::VolumeMultiple), "volume_multiple at albedo 0");
            }
        }});
    // Albedo exactly 1, camera inside a homogeneous medium under a uniform sky (sun removed):
    // the white furnace, every pixel sees the sky radiance. The path tracer is unbiased given a
    // depth cap the paths do not reach (tau 3 to the walls; 10^4 vertices).
    cases.push_back(Case{"AlbedoOneFurnaceCameraInside",
                         [](const fs::path&) {
                             SceneDesc d = base_scene();
                             d.lights = {environment(kSky)};
                             d.camera.position = Vec3(0.1f, -0.2f, 0.3f);
                             d.render.spp = 16;
                             d.render.max_depth = 10000;
                             d.photons.volume = 20000;
                             d.photons.max_emitted = 200000;
                             d.photons.max_bounces = 10000;
                             d.volume.k = 50;
                             d.media.push_back(homogeneous(Box3{Vec3(-1.0f), Vec3(1.0f)},
                                                           Color(3.0f), Color(0.0f), 0.3f));
                             return d;
                         },
                         [](const PipelineResult& r, Integrator integrator) {
                             if (integrator == Integrator::Path)
                                 expect_mean(r.film.beauty, kSky, 1e-6, "white furnace");
                             // Photon mapping is consistent, not unbiased: lookups near the
                             // walls reach outside the medium, where there are no photons, so
                             // the estimate is low (measured 0.479, -4%, with these budgets).
                             // A regression bound, not a standard-error test: within 10%.
                             else
                                 EXPECT_NEAR(r.film.beauty.mean(), kSky, 0.1 * kSky)
                                     << "photon furnace: direct "
                                     << r.film.layer(Layer::Direct).mean() << " single "
                                     << r.film.layer(Layer::VolumeSingle).mean() << " multiple "
                                     << r.film.layer(Layer::VolumeMultiple).mean();
                         }});
    // Albedo exactly 1 and optical depth 1e3 to the walls: paths would need ~1e6 vertices to
    // escape; max_depth (16) and max_bounces (32), set low here, end them. The cut energy shows as
    // an image darker than the sky (the furnace value), and the run says so in a warning.
    cases.push_back(Case{"AlbedoOneDepthCapTerminates",
                         [](const fs::path&) {
                             SceneDesc d = base_scene();
                             d.lights = {environment(kSky)};
                             d.camera.position = Vec3(0.1f, -0.2f, 0.3f);
                             d.render.max_depth = 16;
                             d.photons.max_bounces = 32;
                             d.media.push_back(homogeneous(Box3{Vec3(-1.0f), Vec3(1.0f)},
                                                           Color(1000.0f), Color(0.0f)));
                             return d;
                         },
                         [](const PipelineResult& r, Integrator integrator) {
                             EXPECT_LT(r.film.beauty.mean(), 0.5 * kSky)
                                 << "the depth cap removes energy here";
                             const std::string cap = integrator == Integrator::Path
                                                         ? "render.max_depth"
                                                         : "photons.max_bounces";
                             bool warned = false;
                             for (const std::string& w : r.report.warnings)
                                 warned = warned || w.find(cap) != std::string::npos;
                             EXPECT_TRUE(warned) << "no warning about " << cap;
                         }});
    for (float g : {0.999f, -0.999f}) {
        cases.push_back(
            Case{std::string("HenyeyGreenstein_g") + (g > 0 ? "Plus" : "Minus") + "0999",
                 [g](const fs::path& dir) {
                     SceneDesc d = base_scene();
                     add_ground(&d);
                     MediumDesc m =
                         vdb_medium(constant_grid(dir, 8, 0.25f, 1.0f), Color(2.0f), Color(0.1f));
                     m.g = g;
                     d.media.push_back(m);
                     d.media.push_back(
                         homogeneous(Box3{Vec3(-3.0f), Vec3(3.0f)}, Color(0.2f), Color(0.0f), g));
                     return d;
                 }});
    }
    return cases;
}

std::vector<Case> placement_cases() {
    std::vector<Case> cases;
    cases.push_back(Case{"CameraInsideGrid", [](const fs::path& dir) {
                             SceneDesc d = base_scene();
                             d.camera.position = Vec3(0.1f, 0.05f, 0.2f);
                             d.media.push_back(vdb_medium(constant_grid(dir, 8, 0.25f, 1.0f),
                                                          Color(2.0f), Color(0.5f)));
                             return d;
                         }});
    cases.push_back(Case{"PointLightInsideHomogeneous", [](const fs::path&) {
                             SceneDesc d = base_scene();
                             add_ground(&d);
                             d.lights = {point_light(Vec3(0.0f, 0.2f, 0.0f), 5.0f)};
                             d.media.push_back(homogeneous(Box3{Vec3(-1.0f), Vec3(1.0f)},
                                                           Color(1.5f), Color(0.2f), 0.5f));
                             return d;
                         }});
    cases.push_back(Case{"PointLightInsideGrid", [](const fs::path& dir) {
                             SceneDesc d = base_scene();
                             // Exactly on a voxel centre, where photons start at a density max.
                             d.lights = {point_light(Vec3(0.125f, 0.125f, 0.125f), 5.0f)};
                             d.media.push_back(vdb_medium(constant_grid(dir, 8, 0.25f, 1.0f),
                                                          Color(4.0f), Color(0.5f)));
                             return d;
                         }});
    cases.push_back(Case{
        "SpotLightAndCameraInsideMedium", [](const fs::path&) {
            SceneDesc d = base_scene();
            add_ground(&d);
            d.lights = {spot_light(Vec3(0.0f, 0.5f, 0.0f), Vec3(0.0f, -1.0f, 0.0f), 20.0f)};
            d.camera.position = Vec3(0.3f, 0.0f, 1.0f);
            d.media.push_back(homogeneous(Box3{Vec3(-2.0f), Vec3(2.0f)}, Color(0.5f), Color(0.1f)));
            return d;
        }});
    return cases;
}

std::vector<Case> photon_cases() {
    auto scene = [](uint64_t photons, int k, float radius) {
        return [=](const fs::path& dir) {
            SceneDesc d = base_scene();
            add_ground(&d);
            d.photons.global = photons;
            d.photons.caustic = photons;
            d.photons.volume = photons;
            d.photons.max_emitted = photons == 0 ? 0 : 2000;
            d.global.k = k;
            d.caustic.k = k;
            d.volume.k = k;
            d.global.radius = radius;
            d.caustic.radius = radius;
            d.volume.radius = radius;
            d.media.push_back(
                vdb_medium(constant_grid(dir, 8, 0.25f, 1.0f), Color(2.0f), Color(0.5f)));
            return d;
        };
    };
    // Without photons, or with radii no photon falls within, the photon integrator gives direct
    // light and single scattering: in expectation the path tracer's image at max_depth 1.
    const SameAs no_maps{scene(0, 20, 0.0f), /*path_depth_one=*/true, false, 0.0, true};
    std::vector<Case> cases = {
        Case{"ZeroPhotons", scene(0, 20, 0.0f)},
        Case{"OnePhoton", scene(1, 20, 0.0f)},
        Case{"OnePhotonKOne", scene(1, 1, 0.0f)},
        Case{"KLargerThanMap", scene(50, 100000, 0.0f)},
        // Radius 0 means "the default" (a fraction of the scene diagonal).
        Case{"RadiusZeroIsDefault", scene(500, 20, 0.0f)},
        // Radius -> 0: the smallest normal and denormal floats; r^3 underflows.
        Case{"RadiusTiny", scene(500, 20, 1e-20f)},
        Case{"RadiusDenormal", scene(500, 20, std::numeric_limits<float>::denorm_min())},
        Case{"RadiusNegative", scene(500, 20, -1.0f), {}, "/global/radius"},
    };
    for (Case& c : cases)
        if (c.name == "ZeroPhotons" || c.name == "RadiusTiny" || c.name == "RadiusDenormal")
            c.same_as = no_maps;
    return cases;
}

std::vector<Case> all_cases() {
    std::vector<Case> all;
    for (auto make : {tau_cases, density_scale_cases, voxel_size_cases, bad_voxel_cases,
                      grid_shape_cases, albedo_and_phase_cases, placement_cases, photon_cases}) {
        for (Case& c : make()) all.push_back(std::move(c));
    }
    return all;
}

void expect_finite(const Image& img, const std::string& what) {
    ASSERT_EQ(img.pixels.size(), static_cast<size_t>(img.width) * img.height) << what;
    for (size_t i = 0; i < img.pixels.size(); ++i) {
        ASSERT_TRUE(is_finite(img.pixels[i])) << what << " pixel " << i << " = " << img.pixels[i].x
                                              << ", " << img.pixels[i].y << ", " << img.pixels[i].z;
        ASSERT_GE(std::min({img.pixels[i].x, img.pixels[i].y, img.pixels[i].z}), 0.0f)
            << what << " pixel " << i;
    }
}

/// Renders `same.scene` (in its own folder) with the case's integrator, or the path tracer at
/// max_depth 1 and 64 spp, and compares the images: bit for bit, or the means within 4 standard
/// errors of the per-pixel differences (both images estimate the same pixel values, so their
/// differences are zero-mean and independent across pixels) plus same.floor relative.
void expect_same_as(const SameAs& same, const PipelineResult& result, const SceneDesc& desc,
                    const fs::path& dir, const std::string& name) {
    const fs::path ref_dir = dir / "same_as";
    fs::create_directories(ref_dir);
    SceneDesc ref = same.scene(ref_dir);
    ref.render.integrator = same.path_depth_one ? Integrator::Path : desc.render.integrator;
    if (same.path_depth_one) {
        ref.render.max_depth = 1;
        ref.render.spp = 64;
    }
    const Image& a = result.film.beauty;
    const Image b = run_pipeline(ref, /*quiet=*/true).film.beauty;
    ASSERT_EQ(a.pixels.size(), b.pixels.size()) << name;
    if (same.exact) {
        EXPECT_EQ(0, std::memcmp(a.pixels.data(), b.pixels.data(), a.pixels.size() * sizeof(Color)))
            << name << ": not bit-identical to its equivalent scene";
        return;
    }
    SampleStats<> difference;
    for (size_t i = 0; i < a.pixels.size(); ++i)
        difference.add(double(a.pixels[i].x) - b.pixels[i].x);
    const double mean = difference.mean(), se = difference.standard_error_unbiased();
    EXPECT_NEAR(a.mean(), b.mean(), 4.0 * se + same.floor * b.mean())
        << name << ": mean difference " << mean << " ± " << se << " against its equivalent scene";
}

class ExtremeCase : public ::testing::TestWithParam<std::tuple<Case, Integrator>> {};

TEST_P(ExtremeCase, FinitePixelsInBoundedTimeOrInputError) {
    const Case& c = std::get<0>(GetParam());
    const Integrator integrator = std::get<1>(GetParam());
    const std::string name = c.name + "/" + to_string(integrator);
    const TempDir dir("fogmap_extreme_" + c.name + "_" + to_string(integrator));
    const Watchdog watchdog(name, c.timeout_s * kTimeScale);
    SceneDesc desc = c.scene(dir.path());
    desc.render.integrator = integrator;
    PipelineResult result;
    try {
        validate(desc);
        result = run_pipeline(desc, /*quiet=*/true);
    } catch (const InputError& e) {
        ASSERT_FALSE(c.error_field.empty()) << name << ": unexpected InputError: " << e.what();
        EXPECT_EQ(e.field, c.error_field) << e.what();
        EXPECT_FALSE(e.reason.empty());
        return;
    }
    ASSERT_TRUE(c.error_field.empty()) << name << ": expected an InputError at " << c.error_field;
    // Slow cases say where their time went (timings are never asserted).
    double total_s = 0.0;
    std::string phases;
    for (const auto& [phase, s] : result.report.phases_s) {
        total_s += s;
        phases += " " + phase + " " + std::to_string(s) + " s;";
    }
    if (total_s > 1.0)
        std::printf("%s:%s photons emitted %llu\n", name.c_str(), phases.c_str(),
                    static_cast<unsigned long long>(result.report.photons_emitted));
    expect_finite(result.film.beauty, name + " beauty");
    if (result.film.layered()) {
        for (const NamedImage& layer : result.film.named_layers())
            expect_finite(*layer.image, name + " " + layer.name);
    }
    EXPECT_EQ(result.report.nonfinite, 0u) << name << ": samples dropped as NaN/Inf";
    // Bounded memory: a map holds its budget plus the rest of the path of the photon that filled
    // it (photon_pass.cpp keeps that path whole; at most the longest path's interactions) — or
    // what the photon pass's first round stored, at most 256 paths of every stream, when that
    // is more (every stream must contribute to every map).
    uint64_t longest = 0, streams = result.report.streams.size();
    for (const auto& st : result.report.streams)
        longest = std::max<uint64_t>(longest, st["longest_path"].get<uint64_t>());
    for (const auto& map : result.report.maps) {
        const uint64_t budget = map.name == "global"    ? desc.photons.global
                                : map.name == "caustic" ? desc.photons.caustic
                                                        : resolve_run(desc).photons.volume;
        EXPECT_LE(map.stored, std::max(budget + longest, 256 * streams * longest))
            << name << ": " << map.name << " map";
    }
    if (c.check) c.check(result, integrator);
    if (c.same_as && (!c.same_as->photon_only || integrator == Integrator::Photon))
        expect_same_as(*c.same_as, result, desc, dir.path(), name);
}

INSTANTIATE_TEST_SUITE_P(Matrix, ExtremeCase,
                         ::testing::Combine(::testing::ValuesIn(all_cases()),
                                            ::testing::Values(Integrator::Path,
                                                              Integrator::Photon)),
                         [](const ::testing::TestParamInfo<ExtremeCase::ParamType>& info) {
                             return std::get<0>(info.param).name + "_" +
                                    to_string(std::get<1>(info.param));
                         });

// The load-time rule for bad voxel values (docs/design.md, Density between voxels): NaN, ±Inf,
// negative and denormal values are set to 0 with a warning and counted per kind, in leaf voxels
// and in active tiles (a tile counts the voxels it covers).
TEST(ExtremeGrid, BadVoxelsAreSanitisedAndCounted) {
    const TempDir dir("fogmap_extreme_sanitize");
    openvdb::initialize();
    auto grid = openvdb::FloatGrid::create(0.0f);
    grid->setName("density");
    auto acc = grid->getAccessor();
    const float nan = std::numeric_limits<float>::quiet_NaN();
    const float inf = std::numeric_limits<float>::infinity();
    acc.setValue(openvdb::Coord(0, 0, 0), nan);
    acc.setValue(openvdb::Coord(1, 0, 0), nan);
    acc.setValue(openvdb::Coord(2, 0, 0), inf);
    acc.setValue(openvdb::Coord(3, 0, 0), -inf);
    acc.setValue(openvdb::Coord(4, 0, 0), -0.5f);
    acc.setValue(openvdb::Coord(5, 0, 0), std::numeric_limits<float>::denorm_min());
    acc.setValue(openvdb::Coord(6, 0, 0), 2.0f);
    // An active tile of one 8^3 leaf's extent holding NaN: 512 voxels.
    grid->tree().addTile(1, openvdb::Coord(64, 0, 0), nan, /*active=*/true);
    const fs::path p = dir.path() / "bad.vdb";
    openvdb::io::File(p.string()).write({grid});

    const auto loaded = DensityGrid::load(p.string(), "density", "/media/0");
    ASSERT_EQ(loaded->warnings().size(), 1u);
    const std::string warning = loaded->warnings()[0];
    const SanitizeStats& s = loaded->sanitize_stats();
    EXPECT_EQ(s.nan, 2u + 512u);
    EXPECT_EQ(s.inf, 2u);
    EXPECT_EQ(s.negative, 1u);
    EXPECT_EQ(s.denormal, 1u);
    EXPECT_EQ(loaded->max_density(), 2.0f);
    EXPECT_NE(warning.find("514 NaN"), std::string::npos) << warning;
    EXPECT_NE(warning.find("2 infinite"), std::string::npos) << warning;
    EXPECT_NE(warning.find("1 negative"), std::string::npos) << warning;
    EXPECT_NE(warning.find("1 denormal"), std::string::npos) << warning;
    // Sanitised voxels read as 0; the one good voxel keeps its value.
    DensityGrid::Sampler sampler(*loaded);
    for (int i = 0; i < 6; ++i) EXPECT_EQ(sampler.density(Vec3(i, 0, 0)), 0.0f) << i;
    EXPECT_EQ(sampler.density(Vec3(6, 0, 0)), 2.0f);
    EXPECT_EQ(sampler.density(Vec3(68, 4, 4)), 0.0f);
    // Majorants never see the bad values.
    for (float m : loaded->majorants().max_density) EXPECT_LE(m, 2.0f);
}

TEST(ExtremeGrid, CleanGridLoadsWithoutWarning) {
    const TempDir dir("fogmap_extreme_clean");
    const fs::path p = constant_grid(dir.path(), 4, 0.5f, 1.0f);
    testing::internal::CaptureStderr();
    const auto loaded = DensityGrid::load(p.string(), "density", "/media/0");
    EXPECT_EQ(testing::internal::GetCapturedStderr(), "");
    EXPECT_TRUE(loaded->warnings().empty());
    EXPECT_EQ(loaded->sanitize_stats().total(), 0u);
}

}  // namespace
}  // namespace fogmap
