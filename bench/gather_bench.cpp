// The volume gather of one camera ray through the volume map, per estimator, on the same photons
// and the same rays (one thread):
//   march_only         the camera march alone (σ sampling, transmittance): the cost all share,
//   sphere_every_step  march + the k-NN sphere estimate at every step (advanced.lookups_per_ray 0),
//   sphere_8_lookups   march + 8 lookups at steps drawn by stratified importance sampling of the
//                      march weights (the integrator's default, advanced.lookups_per_ray = 8),
//   beam               march + one BeamTree::for_each_hit per ray,
//   photon_beams       march + one PhotonBeams::for_each_hit per ray over the same photon paths'
//                      beams (volume.estimator photon_beams).
// Each runs render/volume_gather.h's multiple scattering, the code the photon integrator runs,
// without shadow rays. Scenes (bench_volumes.h): the Disney cloud (1/16) with 100k volume photons
// and smoke1 with 20k, k = 50, radius 5% of the grid's diagonal (the scene defaults), traced once
// with their beams (so delta-tracked, as photon beams need) for every estimate. Rays: a
// pinhole fan from two grid extents away on +z towards random points of the grid's bounds; fixed
// seeds. ns per ray in thread CPU time; beam and photon_beams set `speedup_vs_<variant>`; mean_L
// (luminance of the estimate per ray) shows the estimators agree.

#include "bench_volumes.h"
#include "core/rng.h"
#include "core/timer.h"
#include "photon/beam_tree.h"
#include "photon/photon_beams.h"
#include "photon/photon_pass.h"
#include "render/gather_params.h"
#include "render/run_setup.h"
#include "render/volume_gather.h"

#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <ctime>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace fogmap::bench {
namespace {

constexpr uint64_t kSeed = 0x6A7E4ull;
constexpr int kRays = 1024;
constexpr int kK = 50;
constexpr int kLookups = 8;

enum class Estimate { MarchOnly, SphereEveryStep, Sphere8, Beam, PhotonBeams };
const char* estimate_name(Estimate e) {
    switch (e) {
        case Estimate::MarchOnly:
            return "march_only";
        case Estimate::SphereEveryStep:
            return "sphere_every_step";
        case Estimate::Sphere8:
            return "sphere_8_lookups";
        case Estimate::Beam:
            return "beam";
        case Estimate::PhotonBeams:
            return "photon_beams";
    }
    return "?";
}

/// One scene with its photon map, beam tree and camera rays (only the current one is kept).
struct Fixture {
    std::string vdb;
    VdbScene vs;
    const Scene* scene = nullptr;
    PhotonMaps maps;
    GatherParams gather;
    std::unique_ptr<BeamTree> beam;
    std::unique_ptr<PhotonBeams> beams;
    double beam_build_s = 0.0, beams_build_s = 0.0;
    std::vector<Ray> rays;
};

std::unique_ptr<Fixture> g_fixture;

const Fixture& fixture(const std::string& vdb) {
    if (g_fixture && g_fixture->vdb == vdb) return *g_fixture;
    g_fixture.reset();
    auto f = std::make_unique<Fixture>();
    f->vdb = vdb;
    f->vs = vdb_scene(vdb, vdb == kCloudVdb ? 100000 : 20000);
    f->scene = f->vs.scene.get();
    const SceneDesc& d = f->vs.desc;
    PhotonSettings photons = d.photons;
    photons.volume_beams = true;
    f->maps = build_trees(
        trace_photons(*f->scene, make_plan(d), photons, d.march, d.render.seed, /*quiet=*/true));
    f->gather = gather_params(d, *f->scene, f->maps, false);
    f->gather.volume.k = kK;
    const Timer timer;
    f->beam = std::make_unique<BeamTree>(*f->maps.volume, kK, f->gather.volume.radius);
    f->beam_build_s = timer.seconds();
    const Timer beams_timer;
    f->beams = std::make_unique<PhotonBeams>(*f->maps.volume, kK, f->gather.volume.radius);
    f->beams_build_s = beams_timer.seconds();
    const Box3 box = f->scene->media[0].world_bounds();
    const Vec3 eye = box.center() + Vec3(0.0f, 0.0f, 2.0f * max_component(box.extent()));
    Rng rng(kSeed, 0);
    for (int i = 0; i < kRays; ++i) {
        const Vec3 target =
            box.lo + box.extent() * Vec3(rng.uniform(), rng.uniform(), rng.uniform());
        f->rays.push_back(Ray{eye, glm::normalize(target - eye)});
    }
    g_fixture = std::move(f);
    return *g_fixture;
}

/// The gather of one estimate: the integrator's VolumeGather with that estimator's settings.
VolumeGather make_gather(const Fixture& f, Estimate e) {
    GatherParams p = f.gather;
    p.estimator = e == Estimate::Beam          ? VolumeEstimator::Beam
                  : e == Estimate::PhotonBeams ? VolumeEstimator::PhotonBeams
                                               : VolumeEstimator::Sphere;
    p.lookups_per_ray = e == Estimate::Sphere8 ? kLookups : 0;
    return VolumeGather(*f.scene, f.vs.desc.march, p, &*f.maps.volume, f.beam.get(), f.beams.get());
}

/// Multiple-scattering radiance along `ray` (throughput 1) for estimate e, or for march_only the
/// optical depth (kept, so the march is not optimised away).
Color gather_radiance(const VolumeGather& gather, const Ray& ray, Estimate e, Rng& rng,
                      VolumeGather::State& st) {
    const Color tau = gather.march(ray, kInfinity, Color(1.0f), rng.uniform(), st);
    if (e == Estimate::MarchOnly) return tau;
    return gather.multiple_scattering(ray, Color(1.0f), rng, st);
}

double thread_cpu_seconds() {
    timespec ts;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

/// Same-run results: volume → estimate → ns per ray.
std::map<std::string, std::map<Estimate, double>> g_results;

void bm_gather(benchmark::State& state, std::string vdb, Estimate e) {
    if (!shared_volume_exists(vdb)) {
        state.SkipWithError((shared_volume(vdb) + " not found").c_str());
        return;
    }
    const Fixture& f = fixture(vdb);
    if (!f.maps.volume || f.maps.volume->tree.empty()) {
        state.SkipWithError("the photon pass stored no volume photon");
        return;
    }
    const VolumeGather gather = make_gather(f, e);
    VolumeGather::State st = gather.make_state();
    double seconds = 0.0, sum_l = 0.0;
    int64_t rays = 0;
    for (auto _ : state) {
        const double t0 = thread_cpu_seconds();
        for (size_t i = 0; i < f.rays.size(); ++i) {
            Rng rng(kSeed, 1 + i);  // the same jitter for every estimate
            sum_l += luminance(gather_radiance(gather, f.rays[i], e, rng, st));
        }
        seconds += thread_cpu_seconds() - t0;
        rays += static_cast<int64_t>(f.rays.size());
    }
    const double ns = 1e9 * seconds / static_cast<double>(rays);
    state.SetItemsProcessed(rays);
    state.counters["ns_per_ray"] = ns;
    state.counters["photons"] = static_cast<double>(f.maps.volume->tree.size());
    auto& row = g_results[vdb];
    row[e] = ns;
    if (e == Estimate::MarchOnly) return;
    state.counters["mean_L"] = sum_l / static_cast<double>(rays);
    state.counters[e == Estimate::Beam          ? "photons_per_ray"
                   : e == Estimate::PhotonBeams ? "beams_per_ray"
                                                : "lookups_per_ray"] =
        static_cast<double>(st.lookups) / static_cast<double>(rays);
    if (const auto it = row.find(Estimate::MarchOnly); it != row.end())
        state.counters["estimate_ns_per_ray"] = ns - it->second;
    if (e != Estimate::Beam && e != Estimate::PhotonBeams) return;
    state.counters["build_ms"] = 1e3 * (e == Estimate::Beam ? f.beam_build_s : f.beams_build_s);
    if (e == Estimate::PhotonBeams)
        state.counters["beams"] = static_cast<double>(f.maps.volume->beams.size());
    for (Estimate s : {Estimate::SphereEveryStep, Estimate::Sphere8, Estimate::Beam}) {
        const auto it = row.find(s);
        if (s != e && it != row.end())
            state.counters[std::string("speedup_vs_") + estimate_name(s)] = it->second / ns;
    }
}

void register_all() {
    for (const char* vdb : {kCloudVdb, kSmokeVdb}) {
        for (Estimate e : {Estimate::MarchOnly, Estimate::SphereEveryStep, Estimate::Sphere8,
                           Estimate::Beam, Estimate::PhotonBeams}) {
            benchmark::RegisterBenchmark(
                (std::string("gather/") + vdb + "/" + estimate_name(e)).c_str(), bm_gather,
                std::string(vdb), e)
                ->Unit(benchmark::kMillisecond)
                ->MinTime(0.3);
        }
    }
}

const bool g_registered = (register_all(), true);

}  // namespace
}  // namespace fogmap::bench
