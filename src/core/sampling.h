#pragma once
// Sampling shared by lights, surfaces and the integrators: cosine-weighted hemisphere and uniform
// sphere directions from two uniforms in [0, 1), and equi-angular distances along a ray. Pure
// functions and plain values; thread-safe.

#include "core/math.h"

#include <algorithm>
#include <cmath>

namespace fogmap {

/// Cosine-weighted direction about unit n; pdf = cos/π.
inline Vec3 sample_cosine_hemisphere(const Vec3& n, Vec2 u) {
    const float r = std::sqrt(u.x);
    const float phi = kTwoPi * u.y;
    const Vec3 local(r * std::cos(phi), r * std::sin(phi), std::sqrt(std::max(0.0f, 1.0f - u.x)));
    return glm::normalize(to_world(local, n));
}

/// Uniform direction on the unit sphere; pdf = 1/(4π).
inline Vec3 sample_uniform_sphere(Vec2 u) {
    const float z = 1.0f - 2.0f * u.x;
    const float r = std::sqrt(std::max(0.0f, 1.0f - z * z));
    const float phi = kTwoPi * u.y;
    return Vec3(r * std::cos(phi), r * std::sin(phi), z);
}

/// Equi-angular distances on [ta, tb] along a unit-direction ray for a point p (a point or spot
/// light; Kulla & Fajardo 2012): t uniform in the angle seen from p, pdf D / ((θ_b − θ_a)(D² +
/// (t − Δ)²)) with Δ the ray's closest approach to p and D its distance there. Unusable (valid()
/// false) when the segment passes through p or has no length.
struct EquiAngular {
    EquiAngular(const Ray& ray, const Vec3& p, float ta, float tb)
        : ta(ta),
          tb(tb),
          delta(glm::dot(p - ray.o, ray.d)),
          D(glm::length(p - ray.at(delta))),
          th_a(std::atan2(ta - delta, D)),
          th_b(std::atan2(tb - delta, D)) {}
    bool valid() const { return D > 1e-4f * (tb - ta) && th_b > th_a; }
    /// The distance at fraction v in [0, 1) of the angle.
    float sample(float v) const {
        return std::clamp(delta + D * std::tan(th_a + v * (th_b - th_a)), ta, tb);
    }
    float pdf(float t) const {
        const float u = t - delta;
        return D / ((th_b - th_a) * (D * D + u * u));
    }
    float ta, tb, delta, D, th_a, th_b;
};

}  // namespace fogmap
