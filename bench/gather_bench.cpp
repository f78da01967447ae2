// The volume gather of one camera ray through the volume map, per estimator, on the same photons
// and the same rays (one thread):
//   march_only         the camera march alone (σ sampling, transmittance): the cost all share,
//   sphere_every_step  march + volume_inscattered (k-NN sphere estimate) at every step,
//   sphere_8_lookups   march + 8 lookups at steps drawn by stratified importance sampling of the
//                      march weights (the integrator's default, volume.lookups_per_ray = 8),
//   beam               march for the optical-depth table + one BeamTree::for_each_hit per ray.
// These are the integrator's multiple-scattering terms (photon_integrator.cpp) without shadow
// rays. Scenes (bench_volumes.h): the Disney cloud (1/16) with 100k volume photons and smoke1
// with 20k, k = 50, radius 5% of the grid's diagonal (the scene defaults). Rays: a pinhole fan
// from two grid extents away on +z towards random points of the grid's bounds; fixed seeds.
// ns per ray in thread CPU time; beam sets `speedup_vs_<sphere variant>`; mean_L (luminance of
// the estimate per ray) shows the estimators agree.

#include "bench_volumes.h"
#include "core/rng.h"
#include "core/timer.h"
#include "media/henyey_greenstein.h"
#include "media/ray_march.h"
#include "photon/beam_tree.h"
#include "photon/estimators.h"
#include "photon/photon_pass.h"
#include "render/photon_integrator.h"
#include "scene/plan.h"

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

enum class Estimate { MarchOnly, SphereEveryStep, Sphere8, Beam };
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
    }
    return "?";
}

/// One scene with its photon map, beam tree and camera rays (only the current one is kept).
struct Fixture {
    std::string vdb;
    VdbScene vs;
    const Scene* scene = nullptr;
    PhotonMaps maps;
    std::unique_ptr<BeamTree> beam;
    std::unique_ptr<RayMarcher> marcher;
    float radius = 0.0f;
    double beam_build_s = 0.0;
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
    f->maps = build_trees(
        trace_photons(*f->scene, make_plan(d), d.photons, d.march, d.render.seed, /*quiet=*/true));
    f->radius = gather_params(d, *f->scene, f->maps, false).volume.radius;
    const Timer timer;
    f->beam = std::make_unique<BeamTree>(*f->maps.volume, kK, f->radius);
    f->beam_build_s = timer.seconds();
    f->marcher = std::make_unique<RayMarcher>(f->scene->media, d.march);
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

struct LitStep {
    Vec3 x;
    Color weight, sigma_s;
};
struct DepthStep {
    float t0, t1;
    Color tau0, sigma_t;
};

/// Per-thread state, as PhotonIntegrator::ThreadState.
struct Gatherer {
    const Fixture& f;
    std::vector<Medium::Sampler> samplers;
    NeighborList neighbors;
    std::vector<LitStep> steps;
    std::vector<DepthStep> depth;
    uint64_t queries = 0;  ///< volume_inscattered calls, or photons the beam visited

    explicit Gatherer(const Fixture& fixture) : f(fixture) {
        for (const Medium& m : f.scene->media) samplers.emplace_back(m);
    }

    /// The multiple-scattering radiance along `ray` (photon_integrator.cpp's radiance(), media
    /// part, throughput 1).
    Color radiance(const Ray& ray, Estimate e, Rng& rng) {
        const PhotonMap& map = *f.maps.volume;
        const float g = f.scene->media[0].params().g;
        Color tau(0.0f);
        steps.clear();
        depth.clear();
        const bool beam = e == Estimate::Beam;
        f.marcher->march(samplers, ray, kInfinity, rng.uniform(), [&](const MarchStep& s) {
            const float h = s.t1 - s.t0;
            if (!beam && max_component(s.sigma_s) > 0.0f)
                steps.push_back({s.x, exp_neg(tau) * step_weight(s.sigma_t, h), s.sigma_s});
            if (beam) depth.push_back({s.t0, s.t1, tau, s.sigma_t});
            tau += s.sigma_t * h;
            return max_component(exp_neg(tau)) > 1e-6f;
        });
        Color sum(0.0f);
        auto gather = [&](const LitStep& st, float factor) {
            ++queries;
            sum += factor * st.weight *
                   volume_inscattered(map, st.x, -ray.d, g, kK, f.radius, neighbors);
        };
        switch (e) {
            case Estimate::MarchOnly:
                sum = tau;  // kept, so the march is not optimised away
                break;
            case Estimate::SphereEveryStep:
                for (const LitStep& st : steps) gather(st, 1.0f);
                break;
            case Estimate::Sphere8: {
                const size_t n = steps.size(), m = kLookups;
                if (n <= m) {
                    for (const LitStep& st : steps) gather(st, 1.0f);
                    break;
                }
                double total = 0.0;
                for (const LitStep& st : steps) total += luminance(st.weight * st.sigma_s);
                if (!(total > 0.0)) break;
                size_t k = 0;
                double cumulative = luminance(steps[0].weight * steps[0].sigma_s);
                for (size_t j = 0; j < m; ++j) {
                    const double target = (j + rng.uniform()) * total / m;
                    while (cumulative < target && k + 1 < n) {
                        ++k;
                        cumulative += luminance(steps[k].weight * steps[k].sigma_s);
                    }
                    const double q = luminance(steps[k].weight * steps[k].sigma_s);
                    if (q > 0.0) gather(steps[k], static_cast<float>(total / (m * q)));
                }
                break;
            }
            case Estimate::Beam: {
                if (depth.empty()) break;
                f.beam->for_each_hit(ray, depth.front().t0, depth.back().t1,
                                     [&](const BeamTree::Record& p, float t, float kernel) {
                                         ++queries;
                                         const auto it = std::upper_bound(
                                             depth.begin(), depth.end(), t,
                                             [](float v, const DepthStep& s) { return v < s.t1; });
                                         if (it == depth.end()) return;
                                         const Color tau_t =
                                             it->tau0 + it->sigma_t * std::max(0.0f, t - it->t0);
                                         sum += hg_phase(glm::dot(p.direction, -ray.d), g) *
                                                kernel * exp_neg(tau_t) * p.power;
                                     });
                sum *= map.photon_power;
                break;
            }
        }
        return sum;
    }
};

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
    Gatherer gatherer(f);
    double seconds = 0.0, sum_l = 0.0;
    int64_t rays = 0;
    for (auto _ : state) {
        const double t0 = thread_cpu_seconds();
        for (size_t i = 0; i < f.rays.size(); ++i) {
            Rng rng(kSeed, 1 + i);  // the same jitter for every estimate
            sum_l += luminance(gatherer.radiance(f.rays[i], e, rng));
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
    state.counters[e == Estimate::Beam ? "photons_per_ray" : "lookups_per_ray"] =
        static_cast<double>(gatherer.queries) / static_cast<double>(rays);
    if (const auto it = row.find(Estimate::MarchOnly); it != row.end())
        state.counters["estimate_ns_per_ray"] = ns - it->second;
    if (e != Estimate::Beam) return;
    state.counters["beam_build_ms"] = 1e3 * f.beam_build_s;
    for (Estimate s : {Estimate::SphereEveryStep, Estimate::Sphere8})
        if (const auto it = row.find(s); it != row.end())
            state.counters[std::string("speedup_vs_") + estimate_name(s)] = it->second / ns;
}

void register_all() {
    for (const char* vdb : {kCloudVdb, kSmokeVdb}) {
        for (Estimate e :
             {Estimate::MarchOnly, Estimate::SphereEveryStep, Estimate::Sphere8, Estimate::Beam}) {
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
