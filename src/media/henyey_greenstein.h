#pragma once
// Henyey–Greenstein phase function (DESIGN.md, Media): p(cos θ) = (1−g²) / (4π (1+g²−2g cos θ)^{3/2}),
// θ the angle between the incoming travel direction and the outgoing one (g > 0: forward).
// Sampling inverts the CDF in a form without division by g (derived from the textbook
// cos θ = (1+g²−((1−g²)/(1−g+2gξ))²)/(2g)), evaluated in double: exact and finite for g = 0,
// g = 1e-7 and |g| = 0.999. Header-only, thread-safe.

#include "core/math.h"

namespace fogmap {

/// Phase function value (1/sr) for the cosine between travel directions; g in (-1, 1).
inline float hg_phase(float cos_theta, float g) {
    const double gd = g;
    const double denom = 1.0 + gd * gd - 2.0 * gd * static_cast<double>(cos_theta);
    return static_cast<float>((1.0 - gd * gd) / (4.0 * 3.14159265358979323846 * denom *
                                                  std::sqrt(std::max(denom, 1e-300))));
}

/// Cosine between travel directions, sampled ∝ hg_phase for u in [0, 1).
inline float hg_sample_cos(float g, float u) {
    const double gd = g;
    const double s = 2.0 * static_cast<double>(u) - 1.0;
    const double gs = 1.0 + gd * s;
    const double num = s + 0.5 * gd * (3.0 + s * s + 2.0 * gd * s + gd * gd * (s * s - 1.0));
    const double c = num / (gs * gs);
    return static_cast<float>(std::min(1.0, std::max(-1.0, c)));
}

/// New travel direction for a photon or path travelling along unit `dir`; *pdf = hg_phase.
inline Vec3 hg_sample(const Vec3& dir, float g, Vec2 u, float* pdf) {
    const float cos_theta = hg_sample_cos(g, u.x);
    const float sin_theta = std::sqrt(std::max(0.0f, 1.0f - cos_theta * cos_theta));
    const float phi = kTwoPi * u.y;
    *pdf = hg_phase(cos_theta, g);
    const Vec3 local(sin_theta * std::cos(phi), sin_theta * std::sin(phi), cos_theta);
    return glm::normalize(to_world(local, dir));
}

}  // namespace fogmap
