// Photons traced per second through real grids (smoke1.vdb, the Disney cloud at 1/16), one
// thread, against the raw rate of OpenVDB GridSampler trilinear samples on the same grid.
// The scene (bench_volumes.h): the grid lit by a sun, σ_t sized so free paths are marched
// (1-voxel steps), volume map only. Each case registers the sampler baseline first
// (`gridsampler/coherent`: samples/s at march points in march order, march_bench.cpp's points),
// then `trace_photons` with 65536 photons emitted per pass, seed 1; the trace sets photons_per_s
// (emitted) and `samples_per_photon` = GridSampler samples/s ÷ photons/s: what one photon costs, in
// raw trilinear samples.

#include "bench_volumes.h"
#include "core/parallel.h"
#include "photon/photon_pass.h"
#include "render/run_setup.h"

#include <benchmark/benchmark.h>

#include <chrono>
#include <map>
#include <memory>
#include <string>

namespace fogmap::bench {
namespace {

/// Photons emitted per pass (two of the pass's batches); the volume map's budget is larger, so
/// every pass does the same work whatever the grid scatters.
constexpr uint64_t kEmitted = 65536;
constexpr uint64_t kVolumeBudget = 1u << 20;

/// Same-run GridSampler rates per volume: samples per second.
std::map<std::string, double> g_samples_per_s;

double wall_seconds() {
    return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch())
        .count();
}

void bm_gridsampler(benchmark::State& state, std::string vdb) {
    if (!shared_volume_exists(vdb)) {
        state.SkipWithError((shared_volume(vdb) + " not found").c_str());
        return;
    }
    double ns = 0.0;
    for (auto _ : state) ns = gridsampler_ns_per_sample(shared_volume(vdb), SampleOrder::Coherent);
    g_samples_per_s[vdb] = 1e9 / ns;
    state.counters["ns_per_sample"] = ns;
    state.counters["samples_per_s"] = 1e9 / ns;
}

void bm_trace(benchmark::State& state, std::string vdb) {
    if (!shared_volume_exists(vdb)) {
        state.SkipWithError((shared_volume(vdb) + " not found").c_str());
        return;
    }
    const VdbScene vs = vdb_scene(vdb, kVolumeBudget, kEmitted);
    const std::unique_ptr<Scene>& scene = vs.scene;
    const Plan plan = make_plan(vs.desc);
    const ThreadLimit one(1);
    double seconds = 0.0;
    uint64_t emitted = 0, stored = 0;
    for (auto _ : state) {
        const double t0 = wall_seconds();
        const PhotonPassResult pass = trace_photons(*scene, plan, vs.desc.photons, vs.desc.march,
                                                     vs.desc.render.seed, /*quiet=*/true);
        seconds += wall_seconds() - t0;
        emitted += pass.emitted;
        stored += pass.volume ? pass.volume->photons.size() : 0;
    }
    if (stored == 0) {
        state.SkipWithError("the photon pass stored no volume photon");
        return;
    }
    const double photons_per_s = static_cast<double>(emitted) / seconds;
    state.counters["photons_per_s"] = photons_per_s;
    state.counters["stored_per_s"] = static_cast<double>(stored) / seconds;
    state.counters["emitted_per_pass"] =
        static_cast<double>(emitted) / static_cast<double>(state.iterations());
    state.counters["sigma_t"] = scene->media[0].sigma_t().x;
    if (const auto it = g_samples_per_s.find(vdb); it != g_samples_per_s.end()) {
        state.counters["samples_per_s"] = it->second;
        state.counters["samples_per_photon"] = it->second / photons_per_s;
    }
}

void register_all() {
    for (const char* vdb : {kSmokeVdb, kCloudVdb}) {
        const std::string prefix = std::string("photon_trace/") + vdb;
        benchmark::RegisterBenchmark((prefix + "/gridsampler/coherent").c_str(), bm_gridsampler,
                                     std::string(vdb))
            ->Unit(benchmark::kMillisecond)
            ->Iterations(1);
        benchmark::RegisterBenchmark((prefix + "/trace_photons/1thread").c_str(), bm_trace,
                                     std::string(vdb))
            ->Unit(benchmark::kMillisecond)
            ->UseRealTime()
            ->MinTime(1.0);
    }
}

const bool g_registered = (register_all(), true);

}  // namespace
}  // namespace fogmap::bench
