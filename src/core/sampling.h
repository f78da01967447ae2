#pragma once
// Direction sampling shared by lights, surfaces and the integrators: cosine-weighted hemisphere
// and uniform sphere, from two uniforms in [0, 1). Pure functions; thread-safe.

#include "core/math.h"

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

}  // namespace fogmap
