#pragma once
// The phase function where media overlap — one rule for the photon pass and both integrators: the
// σ_s-weighted mixture of the media's Henyey–Greenstein functions,
//   p(x; cos θ) = Σ_i w_i p_HG(cos θ; g_i) / Σ_i w_i,  w_i = density_i(x) · avg(sigma_s,i),
// sampled by choosing medium i with probability w_i / Σ w (one uniform, drawn only when more than
// one medium is present) and then its HG, so a sampled direction's pdf is the mixture itself and
// its weight p/pdf is 1. With one medium it is that medium's HG. Per thread (it reads the
// thread's samplers); cheap to make.

#include "core/rng.h"
#include "media/henyey_greenstein.h"
#include "media/medium.h"

#include <array>
#include <cmath>
#include <vector>

namespace fogmap {

/// Largest |g| for which the end of a camera path in the volume map reads its photons' moments
/// cut after the l = 2 Legendre term (render/volume_map_end.h); the plan reports the same rule.
constexpr float kMomentGridMaxG = 0.4f;
/// A medium with asymmetry g lets those lookups read the moments.
inline bool fits_moment_grid(float g) { return std::abs(g) <= kMomentGridMaxG; }

/// The share of the photons gathered that a Henyey–Greenstein phase function with asymmetry g
/// effectively weighs, for light from every direction: (E p)² / E p² = (1 − g²)² / (1 + g²)
/// (0.61 at g 0.4, 0.45 at 0.5, 0.08 at 0.8, 0.045 at 0.85).
inline float hg_effective_share(float g) {
    return (1.0f - g * g) * (1.0f - g * g) / (1.0f + g * g);
}
/// Below this share a lookup's volume.k photons weigh as fewer than a fifth of them, and the
/// volume map's default k doubles (render/run_setup.h, volume_k): |g| above 0.678.
constexpr float kPeakedPhaseShare = 0.2f;
inline bool peaked_phase(float g) { return hg_effective_share(g) < kPeakedPhaseShare; }

class PhaseMix {
public:
    /// One Henyey–Greenstein function.
    explicit PhaseMix(float g) : n_(1) {
        g_[0] = g;
        w_[0] = total_ = 1.0f;
    }

    /// The mixture at world point x (density lookups only when there are several media).
    PhaseMix(std::vector<Medium::Sampler>& samplers, const Vec3& x) {
        if (samplers.size() == 1) {
            g_[0] = samplers[0].medium().params().g;
            w_[0] = total_ = 1.0f;
            n_ = 1;
            return;
        }
        for (Medium::Sampler& s : samplers) {
            const float w = s.density(x) * average(s.sigma_s_unit(x));
            if (!(w > 0.0f)) continue;
            g_[n_] = s.medium().params().g;
            w_[n_++] = w;
            total_ += w;
        }
        if (n_ == 0) {  // no scattering medium at x: the first medium's (only reached at edges)
            g_[0] = samplers.empty() ? 0.0f : samplers[0].medium().params().g;
            w_[0] = 1.0f;
            n_ = 1;
        }
        if (n_ == 1) total_ = w_[0] = 1.0f;
    }

    /// Phase value (1/sr) for the cosine between travel directions.
    float eval(float cos_theta) const {
        if (n_ == 1) return hg_phase(cos_theta, g_[0]);
        float sum = 0.0f;
        for (int i = 0; i < n_; ++i) sum += w_[i] * hg_phase(cos_theta, g_[i]);
        return sum / total_;
    }

    /// The l-th coefficient a_l of the mixture's Legendre series
    /// p(cos θ) = Σ_l (2l + 1) / (4π) a_l P_l(cos θ): a_l = Σ_i w_i g_i^l / Σ_i w_i (an HG's: g^l).
    float legendre(int l) const {
        float sum = 0.0f;
        for (int i = 0; i < n_; ++i) {
            float g_l = 1.0f;
            for (int k = 0; k < l; ++k) g_l *= g_[i];
            sum += w_[i] * g_l;
        }
        return sum / total_;
    }

    /// New travel direction after scattering of a path travelling along unit `dir`; *pdf = eval.
    Vec3 sample(const Vec3& dir, Rng& rng, float* pdf) const {
        const float pick_u = n_ > 1 ? rng.uniform() : 0.0f;
        const Vec2 u(rng.uniform(), rng.uniform());
        return sample(dir, pick_u, u, pdf);
    }
    /// The same from given uniforms: `pick_u` picks the mixture's component (unused for one), `u`
    /// the direction about it.
    Vec3 sample(const Vec3& dir, float pick_u, Vec2 u, float* pdf) const {
        int pick = 0;
        if (n_ > 1) {
            float v = pick_u * total_;
            while (pick + 1 < n_ && v >= w_[pick]) v -= w_[pick++];
        }
        float component_pdf;
        const Vec3 d = hg_sample(dir, g_[pick], u, &component_pdf);
        *pdf = n_ == 1 ? component_pdf : eval(glm::dot(dir, d));
        return d;
    }

private:
    std::array<float, kMaxMedia> g_{}, w_{};
    float total_ = 0.0f;
    int n_ = 0;
};

}  // namespace fogmap
