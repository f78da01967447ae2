#pragma once
// The whole run of one scene description (DESIGN.md, Pipeline): plan and load once, then one loop
// of iterations — photon pass with the iteration's seed, kd-trees, render with the iteration's
// gather — accumulated into one film; timed by phase, with no files written. A plain render is one
// iteration; progressive photon mapping (Knaus & Zwicker 2011) runs until its count or time
// budget. `fogmap render` and `fogmap bench` both call it, so every run is measured the same way.

#include "core/image.h"
#include "render/checkpoint.h"
#include "render/film.h"
#include "render/report.h"
#include "scene/scene_desc.h"

#include <cstdint>
#include <functional>

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
    Film film;      ///< mean over iterations; layered for the photon integrator
    Report report;  ///< plan, settings, phases (summed over iterations), maps, iterations, mean
};

/// The seed of iteration i (1-based), a function of the run's seed and i alone: a plain render
/// uses the seed itself, progressive iterations independent streams derived from it.
uint64_t iteration_seed(uint64_t seed, int i, bool progressive);

/// The median optical depth (channel average) of the camera rays through a 32 × 24 grid of the
/// film that meet the media with depth above 0.01 (0 when none does), by midpoint sums at half
/// each medium's voxel (homogeneous media: 256 steps across its bounds; at most 4096 steps per
/// medium and ray). Deterministic.
float camera_optical_depth(const Scene& scene, const CameraDesc& camera);

/// After load_scene (run_pipeline calls it): auto's choice of photon for media under sun, sky or
/// area lights (render.auto_media) becomes the path tracer where camera_optical_depth is below
/// kThinMediaDepth (scene/plan.h), unless progressive iterations are asked for; the reason gives
/// the depth either way. Any other description is returned unchanged.
SceneDesc refine_auto(SceneDesc desc, const Scene& scene);

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
PipelineResult run_pipeline(const SceneDesc& desc, bool quiet, const Image* reference = nullptr,
                            Ranks* ranks = nullptr, const Checkpoints* checkpoints = nullptr);

}  // namespace fogmap
