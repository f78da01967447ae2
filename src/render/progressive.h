#pragma once
// Progressive photon mapping in the probabilistic formulation of Knaus and Zwicker (2011):
// independent iterations of photon pass + render, each gathering with a fixed radius that
// shrinks as r²_{i+1} = r²_i (i + α)/(i + 1) on surfaces and r³_{i+1} = r³_i (i + α)/(i + 1)
// in volumes (starting, where the scene sets no radius, from the median k-th-neighbour distance
// in the first iteration's maps); the image is the mean of the iterations, so it converges
// (consistent) as the time grows. Memory is one iteration's photons, whatever the number of
// iterations.

#include "core/image.h"
#include "render/pipeline.h"

#include <vector>

namespace fogmap {

struct ProgressiveIteration {
    int index = 0;            ///< 1-based
    double elapsed_s = 0.0;   ///< since the start, after this iteration
    GatherRadii radii;        ///< the radii this iteration gathered with
    double rel_mse = -1.0;    ///< of the running mean against the reference (-1: none)
    size_t photon_bytes = 0;  ///< memory of this iteration's maps
};

struct ProgressiveResult {
    AovImages aov;  ///< mean over iterations
    std::vector<ProgressiveIteration> iterations;
    Report report;  ///< phases summed over iterations; one JSON entry per iteration
};

/// The radius for iteration i + 1 from iteration i's (i >= 1), in `dimensions` 2 or 3.
float next_radius(float radius, int i, float alpha, int dimensions);

/// Runs iterations of `desc` (photon integrator) until desc.progressive's budget or count is
/// reached (at least one). Progress per iteration on stderr unless quiet; rel_mse per iteration
/// when a reference is given. run_pipeline calls it when desc.progressive.enabled().
ProgressiveResult run_progressive(const SceneDesc& desc, const Image* reference, bool quiet);

}  // namespace fogmap
