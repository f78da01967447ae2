#pragma once
// What the march, photon-trace and gather benchmarks share: the real volumes of
// ../shared/volumes (FOGMAP_SHARED_VOLUMES), a scene built in code around one of them (the grid
// as a vdb medium lit by a sun, coefficients sized to the grid so photon free paths are marched,
// not delta-tracked), and the raw OpenVDB GridSampler rate on march sample points (defined in
// march_bench.cpp, the one benchmark file that includes OpenVDB). Benchmarks only; fixed seeds.

#include "scene/scene.h"
#include "scene/scene_desc.h"

#include <filesystem>
#include <memory>
#include <string>

namespace fogmap::bench {

/// The two real grids of the photon-trace benchmark (photon_trace_bench.cpp).
inline constexpr const char* kSmokeVdb = "smoke1.vdb";
inline constexpr const char* kCloudVdb = "wdas_cloud_sixteenth.vdb";

/// Absolute path of a file of ../shared/volumes; it may not exist (callers skip).
inline std::string shared_volume(const std::string& name) {
    return std::string(FOGMAP_SHARED_VOLUMES) + "/" + name;
}

inline bool shared_volume_exists(const std::string& name) {
    return std::filesystem::exists(shared_volume(name));
}

/// Largest majorant optical depth per 1-voxel step of the scenes below: under
/// RayMarcher::kMaxTauPerStep (0.25), so photon free paths are marched (the default method).
inline constexpr float kTauPerStep = 0.2f;

/// A scene of `vdb` (grid "density") lit by a sun (irradiance 3) alone; the camera sits at the
/// grid's centre, so the scene bounds (which the sun's photons are aimed at) are the grid's.
/// σ_t per unit density = kTauPerStep / (max density × voxel edge), albedo 0.95, g = 0.5;
/// photons: volume map only, `volume_photons` stored or `max_emitted` emitted (0 = 100 × the
/// budget). Throws InputError if the file does not load.
struct VdbScene {
    SceneDesc desc;
    std::unique_ptr<Scene> scene;
};
inline VdbScene vdb_scene(const std::string& vdb, uint64_t volume_photons,
                          uint64_t max_emitted = 0) {
    SceneDesc d;
    LightDesc sun;
    sun.type = LightType::Sun;
    sun.direction = glm::normalize(Vec3(-0.55f, -0.75f, -0.35f));
    sun.irradiance = Color(3.0f);
    d.lights.push_back(sun);
    MediumDesc m;
    m.type = MediumType::Vdb;
    m.file = shared_volume(vdb);
    d.media.push_back(m);
    const std::unique_ptr<Scene> probe = load_scene(d);
    const Medium& medium = probe->media.at(0);
    const float sigma_t = kTauPerStep / (medium.grid()->max_density() * medium.voxel_world());
    d.media[0].sigma_s = Color(0.95f * sigma_t);
    d.media[0].sigma_a = Color(0.05f * sigma_t);
    d.media[0].g = 0.5f;
    const Box3 bounds = medium.world_bounds();
    d.camera.position = bounds.center();
    d.camera.look_at = bounds.center() - Vec3(0.0f, 0.0f, 1.0f);
    d.photons.global = 0;
    d.photons.caustic = 0;
    d.photons.volume = volume_photons;
    d.photons.max_emitted = max_emitted;
    d.render.seed = 1;
    // The photon integrator named, the maps seen from camera rays: "auto" ends camera paths in
    // the volume map for a sun-lit medium (the gather benchmark measures camera-ray lookups).
    d.render.integrator = Integrator::Photon;
    std::unique_ptr<Scene> scene = load_scene(d);
    return {std::move(d), std::move(scene)};
}

/// Where the raw-sampler rate is measured: march sample points (1-voxel steps, jittered) of
/// random rays through the grid's bounds, in march order or shuffled.
enum class SampleOrder { Coherent, Random };

/// Nanoseconds per trilinear sample of openvdb::tools::GridSampler<FloatGrid::ConstAccessor,
/// BoxSampler> (one thread, index-space isSample) on grid "density" of `path`, at the march
/// points of march_bench.cpp (the same points as its benchmarks); the grid is read on the first
/// call and kept. Throws std::runtime_error if the file does not load.
double gridsampler_ns_per_sample(const std::string& path, SampleOrder order);

}  // namespace fogmap::bench
