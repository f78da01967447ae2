#pragma once
// Pipeline sweeps for `fogmap bench` (docs/measurements.md): the cross product of
// swept settings, one timed and error-measured run per combination, CSV rows, the Pareto
// frontier of (time, error) and the text summary. Times are wall seconds, medians over repeats.
// Pure functions apart from run_bench_case, which renders; nothing here writes files.

#include "core/image.h"
#include "scene/scene_desc.h"

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace fogmap {

class Ranks;

/// One `--sweep KEY=V1,V2,...`: a dotted settings key and its values as override text.
struct SweepAxis {
    std::string key;
    std::vector<std::string> values;
};

/// The cross product of `axes` as override lists {"k1=v", "k2=w", ...}, one per run, the first
/// axis varying slowest (nested loops in axis order). No axes → one empty run.
std::vector<std::vector<std::string>> sweep_runs(const std::vector<SweepAxis>& axes);

/// Phases reported by run_pipeline, in CSV order; a phase a run does not have is 0.
/// "photon exchange" and "reduce" are the communication between MPI ranks (0 for one process).
inline constexpr std::array<const char*, 9> kBenchPhases{
    "load",       "photon pass", "build global",    "build caustic", "build volume",
    "precompute", "render",      "photon exchange", "reduce"};
/// Photon maps, in CSV order.
inline constexpr std::array<const char*, 3> kBenchMaps{"global", "caustic", "volume"};

/// One run of the sweep: its settings, median times and error against the reference.
struct BenchRow {
    std::string method;              ///< render.integrator as it ran ("photon", "path", "guided")
    std::vector<std::string> swept;  ///< value of each swept key ("" = not swept here)
    int spp = 0;                     ///< render.spp of the run (an iteration's: iteration_size)
    int repeats = 0;                 ///< runs the medians are taken over
    int ranks = 1;                   ///< MPI ranks the run was spread over
    int threads = 0;                 ///< worker threads per rank
    std::array<double, kBenchPhases.size()> phase_s{};  ///< median wall time per phase
    double total_s = 0.0;  ///< median wall time of the whole run_pipeline
    std::array<uint64_t, kBenchMaps.size()> stored{};  ///< photons stored per map
    uint64_t bytes = 0;                                ///< all maps: records + trees
    bool measured = true;  ///< a reference was given: rmse, rel_mse and bias hold
    double rmse = 0.0, rel_mse = 0.0, bias = 0.0;      ///< against the reference (medians)
    /// The run's own estimate of its relMSE and its 95% interval (render/error_estimate.h);
    /// est_valid false when the run could not estimate it (one sample a pixel).
    bool est_valid = false;
    double est_rel_mse = 0.0, est_lo = 0.0, est_hi = 0.0;
    /// The error the summary and plot weigh: against the reference, else the estimate.
    double error() const { return measured ? rel_mse : est_rel_mse; }
};

/// Runs `desc` `repeats` (>= 1) times through run_pipeline (quietly) and measures each image
/// against `reference` (same size, checked by the caller; empty: none, row.measured false) and
/// keeps its own error estimate; times and errors are medians over the repeats (images are
/// deterministic per seed, so normally only the times vary). Throws what run_pipeline throws. With
/// `ranks` (core/ranks.h) all of them run it and rank 0's row is the measurement (the others' rows
/// hold no error).
BenchRow run_bench_case(const SceneDesc& desc, int repeats, const Image& reference,
                        Ranks* ranks = nullptr);

/// Median of `v` (mean of the middle two for an even count); 0 for an empty vector.
double median(std::vector<double> v);

/// CSV header: method, the swept keys, spp, repeats, ranks, threads, <phase>_s..., total_s,
/// stored_<map>..., bytes, rmse, rel_mse, bias (empty without a reference), est_rel_mse,
/// est_lo, est_hi (empty where the run could not estimate it).
std::string bench_csv_header(const std::vector<std::string>& swept_keys);
/// One CSV line (with '\n'); fields with ',' or '"' are quoted.
std::string bench_csv_row(const BenchRow& row);

/// Indices of the Pareto frontier of (time_s[i], error[i]), both minimised: the points no other
/// point beats or equals in both with one strictly better, sorted by time. Among exact
/// duplicates the first index is kept. The sizes must match.
std::vector<size_t> pareto_frontier(const std::vector<double>& time_s,
                                    const std::vector<double>& error);

/// "photons.volume=25000 volume.k=20" for a row; "path 64 spp" for a path row without sweeps.
std::string bench_label(const BenchRow& row, const std::vector<std::string>& swept_keys);

/// The stdout summary: the photon frontier (best setting at each time budget, with the path
/// tracer's relMSE at the same time interpolated log-log between its runs) and the path rows.
std::string bench_summary(const std::vector<BenchRow>& rows,
                          const std::vector<std::string>& swept_keys);

/// For rows run at several rank counts (the same method, spp and swept values, in the order
/// run): each count's time, its speed against the fewest ranks' (time ratio), the share of the
/// run spent communicating (photon exchange + reduce) and relMSE. "" when all rows have one count.
std::string ranks_summary(const std::vector<BenchRow>& rows,
                          const std::vector<std::string>& swept_keys);

}  // namespace fogmap
