#pragma once
// Henyey–Greenstein phase function: p(cos θ) = (1−g²) / (4π (1+g²−2g cos θ)^{3/2}), θ the angle
// between the incoming travel direction and the outgoing one (g > 0: forward). Sampling inverts the
// CDF in a form without division by g and without cancellation near the peak
// (detail::hg_sample_one_minus_cos), in double: exact and finite for g = 0, g = 1e-7 and
// |g| = 0.999. Header-only, thread-safe.

#include "core/math.h"

namespace fogmap {

/// Phase function value (1/sr) for the cosine between travel directions; g in (-1, 1). In float,
/// without cancellation: 1 + g² − 2g cos θ = (1 − |g|)² + 2|g| (1 − sign(g) cos θ), two
/// non-negative terms (photon lookups evaluate it once per photon gathered).
inline float hg_phase(float cos_theta, float g) {
    const float a = std::fabs(g), one_minus_a = 1.0f - a;
    const float side = g >= 0.0f ? 1.0f - cos_theta : 1.0f + cos_theta;
    const float denom = std::max(one_minus_a * one_minus_a + 2.0f * a * side, 1e-30f);
    return one_minus_a * (1.0f + a) / (4.0f * kPi * denom * std::sqrt(denom));
}

namespace detail {

/// Samples HG for |g| and returns 1 − μ' in double without cancellation:
/// 1 − μ' = (1−|g|)(1−s)(q+1−|g|) / (2(1+|g|s)), q = (1−g²)/(1+|g|s), s = 2u−1 (from the textbook
/// μ = (1+g²−q²)/(2g)). Negative g uses the symmetry p(μ; g) = p(−μ; −g) with s → −s, which
/// keeps μ(u) the increasing inverse CDF. *phase receives the pdf, computed from 1 − μ' as
/// (1−g²) / (4π ((1−|g|)² + 2|g|(1−μ'))^{3/2}), exact near the forward peak.
inline double hg_sample_one_minus_cos(double g, double u, double* phase) {
    const double ga = std::abs(g);
    const double s = g < 0.0 ? 1.0 - 2.0 * u : 2.0 * u - 1.0;
    const double gs = 1.0 + ga * s;
    const double q = (1.0 - ga * ga) / gs;
    const double omm =
        std::min(2.0, std::max(0.0, (1.0 - ga) * (1.0 - s) * (q + 1.0 - ga) / (2.0 * gs)));
    const double denom = (1.0 - ga) * (1.0 - ga) + 2.0 * ga * omm;
    *phase = (1.0 - ga * ga) / (4.0 * kPiDouble * denom * std::sqrt(denom));
    return omm;
}

}  // namespace detail

/// Cosine between travel directions, sampled ∝ hg_phase for u in [0, 1).
inline float hg_sample_cos(float g, float u) {
    double phase;
    const double omm = detail::hg_sample_one_minus_cos(g, u, &phase);
    return static_cast<float>(g < 0.0f ? omm - 1.0 : 1.0 - omm);
}

/// New travel direction for a photon or path travelling along unit `dir`; *pdf = hg_phase.
/// sin θ comes from 1 − μ in double, so angles near the forward peak at |g| → 1 keep their
/// resolution (no collapse to θ = 0 through float rounding of μ).
inline Vec3 hg_sample(const Vec3& dir, float g, Vec2 u, float* pdf) {
    double phase;
    const double omm = detail::hg_sample_one_minus_cos(g, u.x, &phase);
    const double mu = g < 0.0f ? omm - 1.0 : 1.0 - omm;
    const double sin_theta = std::sqrt(omm * (2.0 - omm));
    *pdf = static_cast<float>(phase);
    const double phi = 2.0 * kPiDouble * u.y;
    const Vec3 local(static_cast<float>(sin_theta * std::cos(phi)),
                     static_cast<float>(sin_theta * std::sin(phi)), static_cast<float>(mu));
    return glm::normalize(to_world(local, dir));
}

}  // namespace fogmap
