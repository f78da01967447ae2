#pragma once
// Scene: the loaded resources of a validated SceneDesc — the camera, lights, materials, the Embree
// scene (only when there are surfaces), media with their VDB grids, and the world bounds. Settings
// are not here: each stage takes its own as arguments. Immutable after load_scene; shared const by
// all render threads.

#include "media/medium.h"
#include "scene/light.h"
#include "scene/scene_desc.h"
#include "surface/embree_scene.h"
#include "surface/material.h"

#include <memory>
#include <string>
#include <vector>

namespace fogmap {

struct Scene {
    CameraDesc camera;
    std::vector<Light> lights;
    std::vector<Material> materials;
    std::unique_ptr<EmbreeScene> surfaces;  ///< null when the scene has no surfaces
    std::vector<Medium> media;
    Box3 bounds;  ///< surfaces, media, camera and point/spot light positions
    /// Least distance a ray leaves a surface by (offset_point): 1e-6 of the bounds' diagonal.
    float offset_floor = 1e-6f;
    /// One line per emitting medium, in scene order: "medium 0: blackbody from grid
    /// 'temperature' (found in the file), 2.1 W". For the Plan.
    std::vector<std::string> emitters;
    /// VDB media without "emission" whose file has a grid named temperature, heat, flame or
    /// flames: "medium 0's file has grid 'temperature'". For the Plan.
    std::vector<std::string> emission_hints;
    /// What loading the data found (DensityGrid::warnings, each grid once): the pipeline prints
    /// them with its own warnings.
    std::vector<std::string> warnings;
};

/// A data file named in the scene (mesh, VDB) as load_scene opens it: relative paths are relative
/// to the scene file's folder.
std::string resolve(const SceneDesc& desc, const std::string& file);

/// Whether a medium moves within the camera's shutter (a velocity grid and a shutter).
bool media_move(const Scene& scene);

/// Σ over media of emitted_power (W).
double emitted_power(const Scene& scene);

/// Opens mesh and VDB files and builds Embree. A homogeneous medium without "bounds" fills the
/// bounds of the rest of the scene. Throws InputError{desc.path or the data file, field, reason}.
std::unique_ptr<Scene> load_scene(const SceneDesc& desc);

}  // namespace fogmap
