#pragma once
// The whole run of one scene description (DESIGN.md, Pipeline): Plan → load → photon pass →
// kd-trees → render, timed by phase, with no files written. `fogmap render` and `fogmap bench`
// both call it, so every run is measured the same way.

#include "render/photon_integrator.h"
#include "render/report.h"
#include "scene/plan.h"
#include "scene/scene.h"
#include "scene/scene_desc.h"

#include <memory>

namespace fogmap {

struct PipelineResult {
    AovImages aov;         ///< beauty always; the other layers only for the photon integrator
    bool layered = false;  ///< aov holds AOV layers
    Report report;         ///< plan, settings, phases, maps, stats, image mean
};

/// A planned and loaded scene: the first two stages of every run.
struct LoadedScene {
    Plan plan;
    std::unique_ptr<Scene> scene;
};

/// Makes the plan (printed on stderr unless quiet) and loads the scene, filling the report's
/// plan and its "load" phase. Throws InputError for unreadable scene data.
LoadedScene plan_and_load(const SceneDesc& desc, bool quiet, Report* report);

/// One report entry per map built (global, caustic, volume order).
std::vector<MapReport> map_reports(const PhotonMaps& maps);

/// Runs `desc` with desc.render.threads threads — progressive iterations (render/progressive.h)
/// when desc.progressive asks for them and the integrator is the photon map. Progress and
/// warnings on stderr unless quiet; `reference` (optional) only feeds the per-iteration error of
/// progressive runs. Throws InputError for unreadable scene data (meshes, VDB files).
PipelineResult run_pipeline(const SceneDesc& desc, bool quiet, const Image* reference = nullptr);

}  // namespace fogmap
