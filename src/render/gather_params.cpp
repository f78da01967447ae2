#include "render/gather_params.h"

#include "photon/estimators.h"
#include "render/run_setup.h"

#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

namespace fogmap {

namespace {

// Median distance to the k-th nearest photon over up to 256 photons spread through the map.
float median_knn_radius(const PhotonMap& map, int k, float fallback) {
    const std::vector<Photon>& photons = map.tree.records();
    if (photons.size() <= static_cast<size_t>(k)) return fallback;
    const size_t samples = std::min<size_t>(256, photons.size());
    std::vector<Vec3> points(samples);
    for (size_t i = 0; i < samples; ++i)
        points[i] = photons[i * photons.size() / samples].position();
    return median_knn_distance(map, points, k, fallback);
}

MapGather map_gather(int k, float radius, float default_radius, const std::optional<PhotonMap>& map,
                     bool progressive) {
    MapGather g{k, radius > 0.0f ? radius : default_radius, progressive};
    if (progressive && radius == 0.0f && map) g.radius = median_knn_radius(*map, k, g.radius);
    return g;
}

}  // namespace

GatherParams gather_params(const SceneDesc& desc, const Scene& scene, const PhotonMaps& first,
                           bool progressive) {
    const float diag = scene.bounds.empty() ? 1.0f : glm::length(scene.bounds.extent());
    Box3 media;
    for (const Medium& m : scene.media) media.extend(m.world_bounds());
    const float media_diag = media.empty() ? diag : glm::length(media.extent());
    GatherParams p;
    p.global =
        map_gather(desc.global.k, desc.global.radius, 0.02f * diag, first.global, progressive);
    p.caustic =
        map_gather(desc.caustic.k, desc.caustic.radius, 0.01f * diag, first.caustic, progressive);
    p.gather_depth = desc.volume.gather_depth;
    p.volume = map_gather(volume_k(desc), desc.volume.radius, 0.05f * media_diag, first.volume,
                          progressive || p.gather_depth > 0);
    p.final_gather = desc.global.final_gather;
    p.gather_rays = desc.global.gather_rays;
    p.cone_filter = desc.caustic.cone_filter;
    p.estimator = desc.volume.estimator;
    p.lookups_per_ray = desc.volume.lookups_per_ray;
    p.light_samples = desc.volume.light_samples;
    return p;
}

float progressive_radius(float r1, int i, float alpha, int dimensions) {
    // Π_{j=1}^{i-1} (j + α)/(j + 1) = Γ(i + α) / (Γ(1 + α) Γ(i + 1)), in logs: exact to ~1e-13
    // for any i, and a function of i alone.
    const double a = alpha;
    const double log_product = std::lgamma(i + a) - std::lgamma(1.0 + a) - std::lgamma(i + 1.0);
    return static_cast<float>(r1 * std::exp(log_product / dimensions));
}

GatherParams gather_at_iteration(const GatherParams& first, int i, float alpha) {
    GatherParams p = first;
    // Photon beams are blurred across their axis only: a 2D kernel.
    const int volume_dimensions = p.estimator == VolumeEstimator::PhotonBeams ? 2 : 3;
    const std::pair<MapGather*, int> maps[] = {
        {&p.global, 2}, {&p.caustic, 2}, {&p.volume, volume_dimensions}};
    for (auto [map, dimensions] : maps)
        if (map->fixed_radius) map->radius = progressive_radius(map->radius, i, alpha, dimensions);
    return p;
}

}  // namespace fogmap
