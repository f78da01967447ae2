#pragma once
// Visibility of a light sample from a point: 0 when a surface blocks the shadow ray, else the
// transmittance of the media along it; and the direct light a diffuse surface reflects. Shared by
// the path tracer, the photon integrator, the volume gather and the photon pass's bounce stream.
// Thread-safe given per-thread samplers.

#include "core/rng.h"
#include "core/sampling.h"
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

/// Radiance a diffuse surface of `albedo` at p (normal n, facing the viewer) reflects of the
/// lights' direct light (only the sun's and sky's when `sun_and_sky`): one sample per light (the
/// constant sky by cosine sampling, which matches the integrand), each with its shadow ray.
/// Counts Embree queries in *rays.
inline Color direct_diffuse(const Scene& scene, std::vector<Medium::Sampler>& media, const Vec3& p,
                            const Vec3& n, const Color& albedo, Rng& rng, uint64_t* rays,
                            bool sun_and_sky = false) {
    const Vec3 origin = offset_point(p, n, scene.offset_floor);
    Color sum(0.0f);
    for (const Light& light : scene.lights) {
        if (sun_and_sky && !light.is_infinite()) continue;
        const Vec2 u(rng.uniform(), rng.uniform());
        LightSample s;
        if (light.type == LightType::Environment) {
            s.wi = sample_cosine_hemisphere(n, u);
            s.Li = light.radiance;
            s.pdf = std::max(glm::dot(n, s.wi), 0.0f) * kInvPi;
        } else {
            s = sample_light(light, origin, u);
        }
        const float cos = glm::dot(n, s.wi);
        if (s.pdf <= 0.0f || cos <= 0.0f || max_component(s.Li) <= 0.0f) continue;
        const Color T = shadow_transmittance(scene, media, Ray{origin, s.wi},
                                             s.dist * (1.0f - kShadowRayEpsilon), rng, rays);
        sum += s.Li * T * (cos / s.pdf);
    }
    return albedo * kInvPi * sum;
}

}  // namespace fogmap
