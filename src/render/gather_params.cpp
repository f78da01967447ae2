#include "render/gather_params.h"

#include "photon/estimators.h"
#include "render/run_setup.h"

#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

namespace fogmap {

namespace {

/// Where a progressive run's photons' k-th-neighbour distances (sampled as below) spread more
/// than this between their 10th and 90th percentiles, the map's camera-ray gathers take the k
/// nearest (shrink_k): one fixed radius would leave its sparse parts noisy or blur its dense
/// ones (docs/why.md).
constexpr float kSpreadForNearest = 30.0f;

/// The distances to the k-th nearest photon from up to 256 photons spread through the map,
/// ascending (r_max where fewer lie within it); none where the map holds at most k photons.
std::vector<float> knn_radii(const PhotonMap& map, int k, float r_max) {
    const std::vector<Photon>& photons = map.tree.records();
    if (photons.size() <= static_cast<size_t>(k)) return {};
    const size_t samples = std::min<size_t>(256, photons.size());
    std::vector<Vec3> points(samples);
    for (size_t i = 0; i < samples; ++i)
        points[i] = photons[i * photons.size() / samples].position();
    return knn_distances(map, points, k, r_max);
}

/// `nearest`: the map's gathers may take the k nearest in a progressive run (camera-ray gathers;
/// not the volume map where paths end in it, which VolumeMapEnd gathers within a fixed radius).
MapGather map_gather(int k, float radius, float default_radius, const std::optional<PhotonMap>& map,
                     bool progressive, bool nearest) {
    MapGather g{k, radius > 0.0f ? radius : default_radius, progressive};
    // The photons' distances set a fixed radius the scene leaves open, or pick the k nearest.
    if (!progressive || !map || (radius > 0.0f && !nearest)) return g;
    const std::vector<float> r = knn_radii(*map, k, g.radius);
    const size_t n = r.size();
    if (n == 0) return g;
    if (nearest && r[9 * n / 10] > kSpreadForNearest * r[n / 10]) {
        g.fixed_radius = false;
        g.shrink_k = true;
    } else if (radius == 0.0f) {
        g.radius = r[n / 2];
    }
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
    p.global = map_gather(desc.global.k, desc.global.radius, 0.02f * diag, first.global,
                          progressive, true);
    p.caustic = map_gather(desc.caustic.k, desc.caustic.radius, 0.01f * diag, first.caustic,
                           progressive, true);
    p.gather_depth = desc.volume.gather_depth;
    // Photon beams take their radius as a 2D kernel's (photon_beams.cpp), not k-NN.
    const bool volume_nearest =
        p.gather_depth == 0 && desc.volume.estimator != VolumeEstimator::PhotonBeams;
    p.volume = map_gather(volume_k(desc), desc.volume.radius, 0.05f * media_diag, first.volume,
                          progressive || p.gather_depth > 0, volume_nearest);
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
    for (auto [map, dimensions] : maps) {
        if (!map->fixed_radius && !map->shrink_k) continue;
        const float r = progressive_radius(map->radius, i, alpha, dimensions);
        if (map->shrink_k)
            map->k = std::max(
                1, int(std::lround(float(map->k) * std::pow(r / map->radius, float(dimensions)))));
        map->radius = r;
    }
    return p;
}

}  // namespace fogmap
