#pragma once
// The whole run of one scene description (docs/design.md, Pipeline): resolve it once
// (render/run_setup.h) and load it (where auto leaves it to a pilot, pick the method:
// render/pilot.h), then one loop of iterations — photon pass with the iteration's seed, kd-trees,
// the method's render with the iteration's gather — accumulated into one film, reduced over ranks;
// timed by phase, with no files written. A plain render is one iteration; progressive photon
// mapping runs until its count or time budget. `fogmap render` and `fogmap bench` both call it, so
// every run is measured the same way.

#include "core/image.h"
#include "render/checkpoint.h"
#include "render/film.h"
#include "render/report.h"
#include "render/run_setup.h"
#include "render/sun_shadows.h"
#include "scene/scene_desc.h"

#include <cstdint>
#include <functional>
#include <optional>

namespace fogmap {

struct Scene;

class Ranks;

/// Checkpointing of a progressive run (render/checkpoint.h).
struct Checkpoints {
    const Checkpoint* resume = nullptr;  ///< start after its iterations (rank 0 takes its sums)
    double every_s = 0.0;                ///< 0 = never
    std::function<void(const Checkpoint&)> write;  ///< on rank 0; fingerprint left 0
};

struct PipelineResult {
    Film film;      ///< mean over iterations, layered
    Report report;  ///< plan, settings, phases (summed over iterations), maps, iterations, mean
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
/// `decided` (may be null): the run as already resolved and piloted (a sequence's frames take
/// the first frame's pick); else resolve_run(desc).
PipelineResult run_pipeline(const SceneDesc& desc, bool quiet, const Image* reference = nullptr,
                            Ranks* ranks = nullptr, const Checkpoints* checkpoints = nullptr,
                            const RunSetup* decided = nullptr);

/// Tables that runs on one loaded scene share, each built by the first run that needs it (and
/// counted in its report's work alone): the suns' shadow grids (their light, media and
/// advanced.sun_grid must be the same for every run).
struct SharedTables {
    std::optional<SunShadows> sun;
};

/// The run of `setup` (no pilot pending) on `scene`, already loaded from it, on one process,
/// printing nothing (warnings are in the report): auto's pilot runs (render/pilot.h). The
/// report's load time is 0.
PipelineResult run_on_scene(const RunSetup& setup, const Scene& scene,
                            SharedTables* shared = nullptr);

}  // namespace fogmap
