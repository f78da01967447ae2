#pragma once
// The whole run of one scene description (docs/design.md, Pipeline): resolve it once
// (render/run_setup.h) and load it, then one loop of iterations — photon pass with the iteration's
// seed, kd-trees, the method's render with the iteration's gather — accumulated into one film,
// reduced over ranks; timed by phase, with no files written. A plain render is one iteration;
// progressive photon mapping runs until its count or time budget. `fogmap render` and `fogmap
// bench` both call it, so every run is measured the same way.

#include "core/image.h"
#include "render/checkpoint.h"
#include "render/error_estimate.h"
#include "render/film.h"
#include "render/report.h"
#include "render/run_setup.h"
#include "render/tiles.h"
#include "scene/scene_desc.h"

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <vector>

namespace fogmap {

struct Scene;

class Ranks;

/// Checkpointing of a progressive run (render/checkpoint.h).
struct Checkpoints {
    const Checkpoint* resume = nullptr;  ///< start after its iterations (rank 0 takes its sums)
    double every_s = 0.0;                ///< 0 = never
    std::function<void(const Checkpoint&)> write;  ///< on rank 0; fingerprint left 0
};

/// What one part of a run split into parts (`fogmap render --part`) adds to the run: its sums as
/// an MPI rank adds its own to rank 0's, and its report before the counts are in.
struct PartSums {
    Report report;                ///< the part's own: phases, plan, maps, iterations, warnings
    std::vector<int64_t> counts;  ///< the run's counts (kRunCounts), the part's own
    /// A plain render's film as the bits of its values, 0 outside the part's tiles; a progressive
    /// run's fixed-point sum of the part's iterations (render/film.h, FixedFilm).
    std::vector<int64_t> values;
    /// A plain render's film's shape beside its layers and batches: whether it has a map
    /// variance, how many bias halves, each batch's share of a pixel's samples.
    struct FilmShape {
        bool map_variance = false;
        int bias_halves = 0;
        std::array<double, kBatches> batch_share{};
        bool operator==(const FilmShape& o) const {
            return map_variance == o.map_variance && bias_halves == o.bias_halves &&
                   batch_share == o.batch_share;
        }
    } shape;
    /// Iteration 1's own estimate, where this part ran it, the run may end after it and it was
    /// valid: a merge of a run of one iteration states it.
    std::optional<ErrorEstimate> first;
};

/// An empty sum of `setup`'s progressive iterations: layered, with bias halves where they read
/// their maps in photon batches.
FixedFilm empty_sum(const RunSetup& setup);

/// PartSums::values' length for a part of `setup`'s run of a film of `shape`.
size_t part_value_count(const RunSetup& setup, const PartSums::FilmShape& shape);

struct PipelineResult {
    Film film;      ///< mean over iterations, layered
    Report report;  ///< plan, settings, phases (summed over iterations), maps, iterations, mean
    /// With a part to run: its sums (film and report then unfinished: PartMerge finishes them).
    std::optional<PartSums> part;
    RunSetup setup;  ///< the run as it ran
    /// A target run stopped as its maps' bias² alone was above the target (on every rank).
    bool bias_stopped = false;
};

/// The seed of iteration i (1-based), a function of the run's seed and i alone: a plain render
/// uses the seed itself, progressive iterations independent streams derived from it.
uint64_t iteration_seed(uint64_t seed, int i, bool progressive);

/// Runs `desc` with desc.render.threads threads (one ThreadLimit for every phase). Progress on
/// stderr unless quiet; warnings on stderr always (and in the report). `reference` (optional)
/// feeds the per-iteration error of progressive runs. Throws InputError for unreadable scene data
/// (meshes, VDB files).
/// With `ranks` (core/ranks.h), every rank calls it: progressive iterations are split by index
/// (rank r runs i ≡ r + 1 mod ranks) and summed in fixed point on rank 0; a plain render is
/// shared: each rank traces a share of every photon round, all build the same maps, and each
/// renders every ranks-th tile, rank 0 receiving the others' pixels exactly. Either way the image
/// is the same bits for any rank count. Only rank 0's result (film, report with the summed
/// counts) is meaningful; the other ranks print nothing.
/// With `checkpoints` (progressive runs): starts after the iterations of checkpoints->resume (its
/// sum and counts), and every checkpoints->every_s seconds, after a whole round, and at the end,
/// passes rank 0's totals to checkpoints->write.
/// `decided` (may be null): the run as already resolved; else resolve_run(desc).
/// With `part` (`fogmap render --part`, no ranks, no checkpoints, a progressive run by count
/// alone): runs what rank part.index of part.count would, tracing every photon round itself,
/// and returns its sums in PipelineResult::part for PartMerge.
PipelineResult run_pipeline(const SceneDesc& desc, bool quiet, const Image* reference = nullptr,
                            Ranks* ranks = nullptr, const Checkpoints* checkpoints = nullptr,
                            const RunSetup* decided = nullptr,
                            std::optional<TileShare> part = std::nullopt);

/// A run put together from its parts' sums, added one part at a time in part order (their
/// shapes agree: the caller checks), then ended as rank 0 of as many MPI ranks ends that run:
/// the same film, bit for bit, and the report with the parts' counts summed (merged_report in
/// pipeline.cpp says how the rest is put together).
class PartMerge {
public:
    void add(PartSums part);
    /// The film and report; warnings of the end on stderr when `speak`.
    PipelineResult finish(const RunSetup& setup, bool speak);

private:
    PartSums sum_;                       ///< counts and values summed; part 1's film shape
    std::vector<Report> reports_;        ///< each part's
    std::vector<int64_t> first_counts_;  ///< part 1's own
};

}  // namespace fogmap
