#pragma once
// Lights as the integrators see them: point and spot (W/sr), quad area lights (radiance, one-sided,
// also present as black geometry in the Embree scene), sun (irradiance on a surface facing it,
// a delta direction or a uniform disc of angular radius θ with radiance E / (π sin²θ)) and a
// constant environment (radiance). Sampling returns solid-angle pdfs; delta lights report
// delta = true and pdf 1. Plain data, thread-safe.

#include "core/math.h"
#include "core/rng.h"
#include "scene/scene_desc.h"

namespace fogmap {

struct Light {
    LightType type = LightType::Point;
    Color intensity{0.0f};              ///< point, spot (W/sr)
    Color radiance{0.0f};               ///< quad, environment; sun disc radiance when not a delta
    Color irradiance{0.0f};             ///< sun (W/m^2)
    Vec3 position{0.0f};                ///< point, spot
    Vec3 direction{0.0f, -1.0f, 0.0f};  ///< spot axis, sun travel direction (unit)
    float cos_outer = 0.0f, cos_inner = 1.0f;  ///< spot
    float sun_one_minus_cos = 0.0f;            ///< sun cone 1 − cos θ_max (0 = delta)
    Vec3 corner{0.0f}, edge_u{0.0f}, edge_v{0.0f}, normal{0.0f, 1.0f, 0.0f};  ///< quad
    float area = 0.0f;                                                        ///< quad

    bool is_delta() const {
        return type == LightType::Point || type == LightType::Spot ||
               (type == LightType::Sun && sun_one_minus_cos == 0.0f);
    }
    bool is_infinite() const { return type == LightType::Sun || type == LightType::Environment; }
};

/// Converts a validated description.
Light make_light(const LightDesc& desc);

/// 1 − cos θ of a sun cone of angular radius θ (degrees), without cancellation: Light's
/// sun_one_minus_cos.
float sun_one_minus_cos(float angular_radius_deg);

struct LightSample {
    Vec3 wi{0.0f};           ///< unit direction from the shading point towards the light
    float dist = kInfinity;  ///< distance to the light point (infinite lights: kInfinity)
    Color Li{0.0f};          ///< incident radiance (delta lights: irradiance-like weight)
    float pdf = 0.0f;        ///< solid-angle pdf (1 for delta lights; 0 = no contribution)
};

/// Samples light arriving at p (visibility and media not included).
LightSample sample_light(const Light& light, const Vec3& p, Vec2 u);

/// Solid-angle pdf of sample_light choosing wi at p, for a ray that reached the light at `dist`
/// (area lights) or escaped (infinite lights). 0 for delta lights or directions it never picks.
float light_pdf(const Light& light, const Vec3& p, const Vec3& wi, float dist);

/// Radiance an escaping ray with direction d receives from an infinite light.
Color escaped_radiance(const Light& light, const Vec3& d);

/// Radiance a quad light sends back along a ray with direction d that hit it (front side only).
Color quad_radiance(const Light& light, const Vec3& d);

/// Emitted power (W per channel). Sun and environment count what crosses the bounding sphere of
/// `scene_bounds` (projection onto the scene, as Jensen's projection maps): E·πR² and 4π²R²·L.
Color light_power(const Light& light, const Box3& scene_bounds);

}  // namespace fogmap
