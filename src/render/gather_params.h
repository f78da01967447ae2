#pragma once
// How the photon integrator gathers from each map, resolved once per run: per map the k and the
// radius (fixed radius as an explicit flag), and the estimator settings. One function makes the
// first iteration's parameters from the scene settings (default radii from the scene's size; for
// progressive runs, fixed radii from the first maps' photon density); the iteration index alone
// gives every later iteration's (Knaus & Zwicker 2011), so iterations can run anywhere.
// Plain data; thread-safe to read.

#include "photon/photon_pass.h"
#include "scene/scene.h"
#include "scene/scene_desc.h"

namespace fogmap {

/// One map's gather.
struct MapGather {
    int k = 0;                  ///< photons per k-NN estimate (unused with fixed_radius)
    float radius = 0.0f;        ///< world units: the k-NN estimate's largest radius, or the radius
    bool fixed_radius = false;  ///< every photon within radius counts (progressive photon mapping)
    bool shrink_k = false;      ///< k-NN in a progressive run: k shrinks as the radius's power
};

struct GatherParams {
    MapGather global, caustic, volume;
    bool final_gather = false;  ///< global: gather rays at camera hits instead of showing the map
    int gather_rays = 32;       ///< global: rays per final gather
    float cone_filter = 0.0f;   ///< caustic: Jensen's k_f; 0 = box filter
    VolumeEstimator estimator = VolumeEstimator::Sphere;
    int lookups_per_ray = 8;  ///< volume-map lookups per camera segment; 0 = every step
    int light_samples = 4;  ///< single-scattering shadow rays per light and segment; 0 = every step
    int gather_depth = 0;  ///< > 0: paths end in the volume map at this vertex (diffuse ones count)
};

/// Iteration 1's gather. Radii the scene leaves at 0 default to 2% (global) and 1% (caustic) of
/// the scene's diagonal and 5% of the media's. A plain render gathers the k nearest within the
/// radius; a progressive one (`progressive`) every photon within a fixed radius: the scene's, or
/// where it gives none the median distance to the k-th nearest photon over up to 256 photons of
/// `first` (the first iteration's maps; Hachisuka et al. start from a k-NN radius too) — unless
/// those distances spread too far for one radius (kSpreadForNearest), where it gathers the k
/// nearest within its radius (the scene's or the default) as a plain render does, k and the
/// radius shrinking together (shrink_k). Paths that end in the volume map (volume.gather_depth
/// > 0) gather it within a fixed radius found so in a plain render too.
GatherParams gather_params(const SceneDesc& desc, const Scene& scene, const PhotonMaps& first,
                           bool progressive);

/// The radius of progressive iteration i (1-based) that starts from r1, in `dimensions` 2
/// (surfaces) or 3 (volumes): r_i^d = r_1^d Π_{j=1}^{i-1} (j + α)/(j + 1) (Knaus & Zwicker 2011).
float progressive_radius(float r1, int i, float alpha, int dimensions);

/// Iteration i's gather from iteration 1's: fixed radii shrink by progressive_radius, and so do
/// the radii of shrink_k gathers, whose k shrinks as the radius's power (at least 1: the ball's
/// expected photons where the radius caps it); other k-NN gathers stay as they are.
GatherParams gather_at_iteration(const GatherParams& first, int i, float alpha);

}  // namespace fogmap
