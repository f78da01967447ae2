#pragma once
// Ray marching through superposed media: the ray is cut where it enters and leaves each medium's
// bounds; pieces with no medium are skipped; within a piece the step is the smallest of the media
// present (grids: step_voxels × smallest voxel edge; homogeneous media: step_world, default
// diagonal/128), and σ is sampled once per step at a jittered point and held constant over the
// step. Free paths accumulate optical depth until it reaches −ln ξ and then interpolate within the
// step. Chromatic media: the free path follows the channel average and the photon is reweighted per
// channel (exactly 1 for grey media).
// Stiff media: in a medium whose max σ_t × step exceeds kMaxTauPerStep, free paths are
// delta-tracked from where the ray enters it, and marched on with steps of optical depth <=
// kMaxTauPerStep after 128 null collisions; march() keeps its steps.
// Thread-safety: a RayMarcher is immutable; samplers are per thread.

#include "core/rng.h"
#include "media/march_settings.h"
#include "media/medium.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

namespace fogmap {

struct MarchStep {
    float t0 = 0.0f, t1 = 0.0f;  ///< the step's interval along the ray (world distance)
    Vec3 x{0.0f};                ///< jittered sample point inside the step
    Color sigma_s{0.0f};         ///< scattering coefficient at x, all media (1/world unit)
    Color sigma_t{0.0f};         ///< extinction coefficient at x, all media (1/world unit)
    Color emission{0.0f};        ///< σ_a L_e at x, all emitting media (radiance / world unit)
};

/// e^{−τ} per channel: transmittance of optical depth τ.
inline Color exp_neg(const Color& tau) {
    return Color(std::exp(-tau.x), std::exp(-tau.y), std::exp(-tau.z));
}

/// ∫₀^h e^{−σ s} ds per channel: the weight of a march step of length h whose σ_t is held
/// constant (h itself where σ_t h is too small for the quotient).
inline Color step_weight(const Color& sigma_t, float h) {
    Color w;
    for (int c = 0; c < 3; ++c)
        w[c] = sigma_t[c] * h > 1e-6f ? -std::expm1(-sigma_t[c] * h) / sigma_t[c] : h;
    return w;
}

class RayMarcher {
public:
    /// Steps per medium from the settings; homogeneous media without step_world use their
    /// bounds' diagonal / 128.
    RayMarcher(const std::vector<Medium>& media, const MarchSettings& settings);

    /// Calls f(const MarchStep&) in order for every step on [0, t_max] with σ_t > 0; f returns
    /// false to stop. jitter in [0, 1) places the sample point inside each step. At most
    /// kMaxStepsPerPiece steps per piece (longer pieces get longer steps): bounded work.
    template <class F>
    void march(std::vector<Medium::Sampler>& samplers, const Ray& ray, float t_max, float jitter,
               F&& f) const;

    struct FreePath {
        bool collided = false;
        float t = 0.0f;      ///< collision distance
        Vec3 x{0.0f};        ///< collision point
        Color weight{1.0f};  ///< per-channel reweighting of the photon (1 for grey media)
        Color sigma_s{0.0f}, sigma_t{0.0f};  ///< at the collision
    };
    /// Samples a free path on (0, t_max) by marching (optical depth to −ln ξ); from where the ray
    /// enters a stiff medium on, by delta tracking through all media (the rest of the free path is
    /// independent of the part marched, so joining the two is exact). A collision found by delta
    /// tracking reports the σ_s, σ_t of the medium that collided. A ray that meets no medium's
    /// bounds draws nothing from rng.
    FreePath sample_free_path(std::vector<Medium::Sampler>& samplers, const Ray& ray, float t_max,
                              Rng& rng) const;

    /// World step used inside medium i.
    float step(int i) const { return step_[i]; }
    /// True when medium i's majorant optical depth per step exceeds kMaxTauPerStep: its free
    /// paths are delta-tracked.
    bool stiff(int i) const { return stiff_[i]; }
    /// True when any medium is stiff.
    bool any_stiff() const { return any_stiff_; }

    static constexpr int kMaxStepsPerPiece = 100000;
    /// Largest majorant optical depth per step that is marched. Holding σ constant over a step
    /// errs most where the density jumps within one step (a medium's boundary voxels); at 0.25
    /// a semi-infinite slab's marched Rd stays within 0.3% (`fogmap validate slab --voxels`;
    /// docs/why.md).
    static constexpr float kMaxTauPerStep = 0.25f;

private:
    const std::vector<Medium>* media_;
    std::vector<float> step_;
    std::vector<char> stiff_;
    bool any_stiff_ = false;
};

template <class F>
void RayMarcher::march(std::vector<Medium::Sampler>& samplers, const Ray& ray, float t_max,
                       float jitter, F&& f) const {
    const int n = static_cast<int>(media_->size());
    std::array<float, kMaxMedia> enter, exit;
    std::array<float, 2 * kMaxMedia + 2> cuts;
    int n_cuts = 0;
    cuts[n_cuts++] = 0.0f;
    for (int i = 0; i < n; ++i) {
        const Box3& b = (*media_)[i].world_bounds();
        if (b.empty() || !intersect_box(b, ray, 0.0f, t_max, &enter[i], &exit[i])) {
            enter[i] = exit[i] = -1.0f;
            continue;
        }
        cuts[n_cuts++] = enter[i];
        cuts[n_cuts++] = exit[i];
    }
    if (n_cuts == 1) return;
    std::sort(cuts.begin(), cuts.begin() + n_cuts);
    for (int c = 0; c + 1 < n_cuts; ++c) {
        const float a = cuts[c], b = cuts[c + 1];
        if (!(b > a)) continue;
        const float mid = 0.5f * (a + b);
        float h = kInfinity;
        std::array<int, kMaxMedia> active;
        int n_active = 0;
        for (int i = 0; i < n; ++i) {
            if (enter[i] <= mid && mid <= exit[i] && exit[i] > enter[i]) {
                active[n_active++] = i;
                h = std::min(h, step_[i]);
            }
        }
        if (n_active == 0) continue;
        const float len = b - a;
        const int steps = static_cast<int>(
            std::min<double>(kMaxStepsPerPiece, std::max(1.0, std::ceil(double(len) / h))));
        h = len / steps;
        MarchStep s;
        for (int k = 0; k < steps; ++k) {
            s.t0 = a + k * h;
            s.t1 = k + 1 == steps ? b : a + (k + 1) * h;
            s.x = ray.at(s.t0 + jitter * (s.t1 - s.t0));
            s.sigma_s = s.sigma_t = s.emission = Color(0.0f);
            for (int j = 0; j < n_active; ++j) {
                Medium::Sampler& sampler = samplers[active[j]];
                const float d = sampler.density(s.x);
                if (d <= 0.0f) continue;
                const Medium& m = sampler.medium();
                s.sigma_s += d * sampler.sigma_s_unit(s.x);
                s.sigma_t += d * m.sigma_t();
                if (m.emission()) s.emission += d * m.params().sigma_a * sampler.emission(s.x);
            }
            if (max_component(s.sigma_t) > 0.0f && !f(s)) return;
        }
    }
}

}  // namespace fogmap
