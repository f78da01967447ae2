#pragma once
// Settings of ray marching through media, kept in media/ (a hot layer) as a plain struct; the
// scene file reads them as "march" (scene/scene_desc_json.cpp).

namespace fogmap {

enum class FreePathMethod { March, Delta };

/// Ray marching of density grids: used for photon free paths (unless method = delta) and for camera
/// rays of the photon integrator.
struct MarchSettings {
    FreePathMethod method = FreePathMethod::March;
    float step_voxels = 1.0f;  ///< step through grids, in voxels (smallest voxel edge), > 0
    float step_world = 0.0f;   ///< step through homogeneous media, world units; 0 = diagonal/128
};

}  // namespace fogmap
