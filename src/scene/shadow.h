#pragma once
// Visibility of a light sample from a point: 0 when a surface blocks the shadow ray, else the
// transmittance of the media along it. Shared by the path tracer, the photon integrator and the
// volume gather. Thread-safe given per-thread samplers.

#include "core/rng.h"
#include "media/medium.h"
#include "scene/scene.h"

#include <cstdint>
#include <vector>

namespace fogmap {

/// Transmittance along unit-direction `ray` on (0, t_max): 0 if a surface of `scene` lies there,
/// else the media's (an unbiased estimate). Counts the Embree query in *rays.
inline Color shadow_transmittance(const Scene& scene, std::vector<Medium::Sampler>& media,
                                  const Ray& ray, float t_max, Rng& rng, uint64_t* rays) {
    if (scene.surfaces) {
        ++*rays;
        if (scene.surfaces->occluded(ray, 0.0f, t_max)) return Color(0.0f);
    }
    return media.empty() ? Color(1.0f) : ratio_track(media, ray, t_max, rng);
}

}  // namespace fogmap
