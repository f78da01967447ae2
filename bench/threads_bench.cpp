// 1 thread against 2 threads for the photon pass and the render: run_pipeline on
// scenes/smoke.json at 160×90, 2 spp, 50k volume and 10k global photons (render.threads = 1,
// then 2; the pipeline sets the TBB limit itself). Each iteration is one whole run; the phase
// times come from its Report, and the fastest of the iterations counts (the machine is shared).
// The 2-thread benchmark sets `speedup_<phase>` against the 1-thread run of the same binary.
// Wall time; load is excluded (it is single-threaded file reading). `cores_used` (process CPU
// time / wall time) shows how much of the machine the run actually got.
// Machine baseline: before each pipeline benchmark, `spin` runs an embarrassingly parallel
// arithmetic loop (tbb::parallel_for, no memory traffic) at the same thread count; its speed-up
// is what the shared machine offers at that moment, and the pipeline's speed-ups are also given
// relative to it (`efficiency_<phase>` = speed-up ÷ spin speed-up).

#include "core/parallel.h"
#include "render/pipeline.h"
#include "scene/scene_desc_json.h"

#include <benchmark/benchmark.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <ctime>
#include <map>
#include <string>
#include <vector>

namespace fogmap::bench {
namespace {

/// Phases compared; "total" = photon pass + tree builds + precompute + render.
const char* const kPhases[] = {"photon pass", "render", "total"};

/// Same-run results: thread count → phase → fastest seconds ("spin": the machine baseline).
std::map<int, std::map<std::string, double>> g_results;

double process_cpu_seconds() {
    timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

double wall_seconds() {
    return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch())
        .count();
}

std::string counter_name(const std::string& phase) {
    std::string s = phase;
    std::replace(s.begin(), s.end(), ' ', '_');
    return s;
}

void bm_pipeline(benchmark::State& state, int threads) {
    const std::string path = std::string(FOGMAP_SOURCE_DIR) + "/scenes/smoke.json";
    const SceneDesc desc = load_scene_desc(
        path, {"camera.width=160", "camera.height=90", "render.spp=2", "photons.volume=50000",
               "photons.global=10000", "render.threads=" + std::to_string(threads)});
    std::map<std::string, double> best;
    double cpu = 0.0, wall = 0.0;
    for (auto _ : state) {
        const double cpu0 = process_cpu_seconds(), wall0 = wall_seconds();
        const PipelineResult run = run_pipeline(desc, /*quiet=*/true);
        cpu += process_cpu_seconds() - cpu0;
        wall += wall_seconds() - wall0;
        std::map<std::string, double> t;
        for (const auto& [phase, seconds] : run.report.phases_s) {
            t[phase] += seconds;
            if (phase != "load") t["total"] += seconds;
        }
        for (const auto& [phase, seconds] : t)
            best[phase] = best.count(phase) ? std::min(best[phase], seconds) : seconds;
        state.counters["threads_used"] = run.report.threads;
    }
    for (const auto& [phase, seconds] : best) g_results[threads][phase] = seconds;
    // Cores this process got (CPU time / wall time over the runs, load included): below the
    // thread count when other processes share the machine, which caps any speed-up.
    state.counters["cores_used"] = cpu / wall;
    for (const char* phase : kPhases) state.counters[counter_name(phase) + "_s"] = best[phase];
    if (threads == 1) return;
    const auto one = g_results.find(1);
    if (one == g_results.end()) return;
    const std::map<std::string, double>& two = g_results[threads];
    const bool have_spin = one->second.count("spin") && two.count("spin");
    for (const char* phase : kPhases) {
        if (!(best[phase] > 0.0) || !one->second.count(phase)) continue;
        const double speedup = one->second.at(phase) / best[phase];
        state.counters["speedup_" + counter_name(phase)] = speedup;
        if (have_spin)
            state.counters["efficiency_" + counter_name(phase)] =
                speedup / (one->second.at("spin") / two.at("spin"));
    }
}

/// 64 independent chunks of dependent integer arithmetic (~5 ms each on one core).
uint64_t spin_work() {
    constexpr int kChunks = 64;
    std::vector<uint64_t> out(kChunks);
    tbb::parallel_for(tbb::blocked_range<int>(0, kChunks, 1), [&](const auto& r) {
        for (int c = r.begin(); c != r.end(); ++c) {
            uint64_t x = static_cast<uint64_t>(c) + 1;
            for (int i = 0; i < 4000000; ++i)
                x = x * 6364136223846793005ull + 1442695040888963407ull;
            out[static_cast<size_t>(c)] = x;
        }
    });
    uint64_t sum = 0;
    for (const uint64_t x : out) sum ^= x;
    return sum;
}

void bm_spin(benchmark::State& state, int threads) {
    const ThreadLimit limit(threads);
    double best = 0.0;
    for (auto _ : state) {
        const double t0 = wall_seconds();
        benchmark::DoNotOptimize(spin_work());
        const double s = wall_seconds() - t0;
        best = best == 0.0 ? s : std::min(best, s);
    }
    g_results[threads]["spin"] = best;
    state.counters["spin_s"] = best;
    if (threads == 1 || !g_results.count(1) || !g_results[1].count("spin")) return;
    state.counters["speedup_spin"] = g_results[1]["spin"] / best;
}

void register_all() {
    for (int threads : {1, 2}) {
        benchmark::RegisterBenchmark(
            ("threads/spin_baseline/threads:" + std::to_string(threads)).c_str(), bm_spin, threads)
            ->Unit(benchmark::kMillisecond)
            ->UseRealTime()
            ->Iterations(3);
        benchmark::RegisterBenchmark(
            ("threads/smoke.json/pipeline/threads:" + std::to_string(threads)).c_str(), bm_pipeline,
            threads)
            ->Unit(benchmark::kMillisecond)
            ->UseRealTime()
            ->Iterations(3);
    }
}

const bool g_registered = (register_all(), true);

}  // namespace
}  // namespace fogmap::bench
