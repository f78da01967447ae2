#pragma once
// Radiance estimates from photon maps (docs/design.md, Radiance estimates). Surface: disc estimate
// over the k nearest photons (or all within r_max), r = distance to the k-th photon or r_max,
// optional cone filter (Jensen, normalised by 1 − 2/(3 k_f)); when r is the k-th photon's
// distance that photon is left out ((k−1)/V, the unbiased k-NN density estimate). k <= 0: every
// photon within r_max (fixed radius, as progressive photon mapping uses). Volume: spherical
// estimate of the in-scattered radiance σ_s L_i = Σ p ΔΦ / ((4/3) π r³). Photon power = relative
// RGBE power × the map's photon_power. Thread-safe given a NeighborList per thread.

#include "media/phase.h"
#include "photon/photon_pass.h"

#include <array>
#include <vector>

namespace fogmap {

/// What an estimate's photon batches (Photon::batch) gave of its sum, the channels' averages in
/// any common unit, added to what is there: each batch's part, and each half's (batches 0-3,
/// 4-7) of the same estimate over radius r/√2 (render/volume_map_end.h, PhotonBatches and
/// RadiusBias), its kernel's normalisation left out unless said (κ, below).
struct BatchSums {
    std::array<float, Photon::kBatches> all{};
    std::array<float, 2> inner{};
    /// A photon's part c at squared distance d2 of a lookup of squared radius r2 (a uniform
    /// kernel: its part over r/√2 is c within it).
    void add(const Photon& p, const Color& c, float d2, float r2) {
        add(p, c, 2.0f * d2 < r2 ? c : Color(0.0f));
    }
    /// A photon's part c, and c_inner of the estimate over r/√2.
    void add(const Photon& p, const Color& c, const Color& c_inner) {
        add(size_t(p.batch()), average(c), average(c_inner));
    }
    /// Batch `batch`'s part, and its part of the estimate over r/√2.
    void add(size_t batch, float part, float inner_part) {
        all[batch] += part;
        inner[size_t(Photon::half_of(int(batch)))] += inner_part;
    }
    /// Adds `sums`, an estimate's, in the unit of that estimate's value (its channels' average),
    /// their inner parts times κ: a sum of estimates then has the sums of its terms', κ applied.
    void add_scaled(const BatchSums& sums, float value, float kappa) {
        const float total = sums.total();
        if (!(total > 0.0f)) return;
        const float scale = value / total;
        for (size_t b = 0; b < all.size(); ++b) all[b] += sums.all[b] * scale;
        for (size_t h = 0; h < inner.size(); ++h) inner[h] += sums.inner[h] * scale * kappa;
    }
    /// RadiusBias: each photon half's estimate of the bias of the estimate E these sums made, over
    /// E: 2 (E_h(ρ) − E_h(ρ/√2)) / E with E_h(ρ) = 2 E × (the half's part) / total and
    /// E_h(ρ/√2) = 2 E κ (its inner part) / total, κ the kernel's volume at ρ over its volume at
    /// ρ/√2 (1 where the inner parts hold it); 0 where nothing was gathered.
    std::array<float, 2> bias(float kappa) const {
        const float sum = total();
        std::array<float, 2> out{};
        if (!(sum > 0.0f)) return out;
        std::array<float, 2> half{};
        for (size_t b = 0; b < all.size(); ++b) half[size_t(Photon::half_of(int(b)))] += all[b];
        for (size_t h = 0; h < 2; ++h) out[h] = 4.0f * (half[h] - kappa * inner[h]) / sum;
        return out;
    }
    /// The sum over batches.
    float total() const {
        float sum = 0.0f;
        for (float part : all) sum += part;
        return sum;
    }
    /// Each batch's share, kBatches × its part of the sum (1 each where the sum is 0): the
    /// estimate from that batch's photons alone is the whole times its share.
    std::array<float, Photon::kBatches> shares() const {
        std::array<float, Photon::kBatches> out;
        const float sum = total();
        for (size_t b = 0; b < out.size(); ++b)
            out[b] = sum > 0.0f ? float(Photon::kBatches) * all[b] / sum : 1.0f;
        return out;
    }
};

/// BatchSums::bias's κ for the inner parts surface_irradiance and volume_inscattered give: the
/// disc's area, and the ball's volume, at r over r/√2.
inline constexpr float kDiscKappa = 2.0f;
inline constexpr float kBallKappa = 2.8284271f;  // 2^{3/2}

/// Irradiance (W/m²) at surface point x with unit normal n from photons that arrived on the side
/// n faces. Photons whose flags intersect skip_flags are left out (the global map shown directly
/// skips caustic photons, which the caustic map shows). cone_kf = 0: box filter. `batches` (may
/// be null): what each photon batch gave.
Color surface_irradiance(const PhotonMap& map, const Vec3& x, const Vec3& n, int k, float r_max,
                         float cone_kf, uint8_t skip_flags, NeighborList& scratch,
                         BatchSums* batches = nullptr);

/// The distance from each of `points` to its k-th nearest photon of `map`, r_max for a point with
/// fewer than k within r_max, in ascending order. Points in parallel; deterministic.
std::vector<float> knn_distances(const PhotonMap& map, const std::vector<Vec3>& points, int k,
                                 float r_max);

/// Their median (`points` not empty): the radius a map's gathers share (progressive and
/// end-of-path gathers, photon beams).
float median_knn_distance(const PhotonMap& map, const std::vector<Vec3>& points, int k,
                          float r_max);

/// Each photon half's (batches 0-3, 4-7) power-weighted sum of the photons' offsets from a
/// lookup's point, and its power (the channels' averages, relative): the halves' centroids
/// (render/volume_map_end.h, BlurCorrection).
struct HalfCentroids {
    std::array<DVec3, 2> moment{DVec3(0.0), DVec3(0.0)};
    std::array<double, 2> power{0.0, 0.0};
    void add(const Photon& p, const Vec3& offset, float p_power) {
        const int half = Photon::half_of(p.batch());
        moment[half] += double(p_power) * DVec3(offset);
        power[half] += p_power;
    }
};

/// In-scattered radiance σ_s L_i (W/(m³ sr)) towards unit direction wo at x, with the phase
/// function at x applied to each photon's travel direction. `batches` (may be null): what each
/// photon batch gave; `centroids` (may be null): the photon halves' centroids about x.
Color volume_inscattered(const PhotonMap& map, const Vec3& x, const Vec3& wo, const PhaseMix& phase,
                         int k, float r_max, NeighborList& scratch, BatchSums* batches = nullptr,
                         HalfCentroids* centroids = nullptr);

}  // namespace fogmap
