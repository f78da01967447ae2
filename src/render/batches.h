#pragma once
// The film's batches (render/film.h, docs/error-estimate.md): which batch a camera sample of a
// pixel falls in, how many of a range of samples each holds, and where a pass's samples sit in
// their pixel and shutter. A pass's samples are N-rooks over the pass (each of its n samples in
// its own of n strata along every dimension), and each batch's samples, n_b of them, take one
// each of n_b equal coarse strata, so a batch is a stratified estimate of the pixel by itself:
// the batches' spread then says the error of the pass's mean, where batches of consecutive
// strata (a strip of the pixel each) would say the pixel's variation across the strips.

#include "core/math.h"
#include "core/rng.h"
#include "render/tiles.h"

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstring>

namespace fogmap {

/// Independent batches of every film: camera sample s of a pixel falls in batch s mod kBatches
/// (render_film: or whole units of samples; a run of many iterations batches whole iterations
/// instead: render/pipeline.cpp), so batches are a function of the sample's index alone, the same
/// at any thread or rank count.
inline constexpr int kBatches = 8;

/// What a film keeps of the photon batches its samples read (render/film.h: FilmSample's
/// photon_delta and bias_half): nothing; the maps' noise (Film::map_variance) and bias
/// (Film::bias_halves); or their bias alone, for an iteration of a run of iterations, whose
/// batches (whole iterations, each with maps of its own) hold the maps' noise already.
enum class PhotonParts { None, NoiseAndBias, Bias };
inline bool keeps_noise(PhotonParts p) { return p == PhotonParts::NoiseAndBias; }
inline bool keeps_bias(PhotonParts p) { return p != PhotonParts::None; }

/// How many of samples [0, m) of a pixel fall in batch b, batched by whole `unit`s: sample s in
/// batch (s / unit) mod kBatches.
inline int batch_upto(int m, int b, int unit) {
    // m / (kBatches unit) whole rounds of every batch, then the rest in order.
    const int round = kBatches * unit;
    return m / round * unit + std::clamp(m % round - b * unit, 0, unit);
}

/// How many of samples [s0, s1) of a pixel fall in each batch.
inline std::array<int, kBatches> batch_counts(int s0, int s1, int unit) {
    std::array<int, kBatches> n{};
    for (int b = 0; b < kBatches; ++b)
        n[size_t(b)] = batch_upto(s1, b, unit) - batch_upto(s0, b, unit);
    return n;
}

/// 1 / count per batch of `counts` (0 for an empty one).
inline std::array<float, kBatches> batch_inverse(const std::array<int, kBatches>& counts) {
    std::array<float, kBatches> inv{};
    for (size_t b = 0; b < size_t(kBatches); ++b)
        inv[b] = counts[b] > 0 ? 1.0f / float(counts[b]) : 0.0f;
    return inv;
}

/// The strata of one pass of a pixel, its samples [s0, s1) batched by `unit`s, along one
/// dimension of [0, 1) (see the top of this file). Sample s, the j-th of its batch b in the pass,
/// takes coarse stratum k of its batch (j itself, or j's place in an order drawn from the key),
/// and its stratum of the pass is the rank of (k + ½) / n_b among all the pass's samples' such
/// values; samples of several batches at one value are ordered by a bijection of the batch
/// indices drawn from the key and that value.
class PassStrata {
public:
    PassStrata(int s0, int s1, int unit)
        : counts_(batch_counts(s0, s1, unit)), n_(s1 - s0), unit_(unit) {
        for (int b = 0; b < kBatches; ++b) before_[size_t(b)] = batch_upto(s0, b, unit);
    }
    int size() const { return n_; }
    /// Sample s's stratum in [0, size()) along the dimension keyed `key`; `shuffle`: its batch's
    /// coarse strata in an order drawn from the key, else in sample order.
    int stratum(int s, uint64_t key, bool shuffle) const {
        const int b = s / unit_ % kBatches;
        const uint32_t nb = uint32_t(counts_[size_t(b)]);
        uint32_t k = uint32_t(batch_upto(s, b, unit_) - before_[size_t(b)]);
        if (shuffle) k = permute(k, nb, mix64(key ^ uint64_t(b)));
        return rank(b, int64_t(k), key);
    }

private:
    /// How many of the pass's samples come before batch b's coarse stratum k.
    int rank(int b, int64_t k, uint64_t key) const {
        const int64_t nb = counts_[size_t(b)], num = 2 * k + 1;
        // Ties are of equal values (2k + 1) / (2 n_b), which divide to the same double; they are
        // ordered by a bijection of the batch indices drawn from the key and that value.
        const double value = double(num) / double(2 * nb);
        uint64_t bits;
        std::memcpy(&bits, &value, sizeof bits);
        const uint64_t h = mix64(key ^ bits);
        const auto order = [h](int c) {
            return ((uint64_t(c) ^ h) * ((h >> 8) | 1) + (h >> 16)) & (kBatches - 1);
        };
        int r = int(k);  // batch b's own strata before k
        for (int c = 0; c < kBatches; ++c) {
            const int64_t nc = counts_[size_t(c)];
            if (nc == 0 || c == b) continue;
            if (nc == nb) {  // strata 0 .. k − 1 before, k tied
                r += int(k) + (order(c) < order(b));
                continue;
            }
            // Batch c's strata i with (2i + 1) / (2 n_c) below num / (2 n_b): 2 i n_b < a.
            const int64_t a = num * nc - nb;
            r += a <= 0 ? 0 : int(std::min(nc, (a + 2 * nb - 1) / (2 * nb)));
            // One of batch c's strata at the same value: i = (num n_c / n_b − 1) / 2.
            if (num * nc % nb == 0 && num * nc / nb % 2 == 1) r += order(c) < order(b);
        }
        return r;
    }

    std::array<int, kBatches> counts_;
    std::array<int, kBatches> before_{};  ///< each batch's samples before the pass
    int n_, unit_;
};

/// Sub-pixel position of sample s of a pass (strata: the pass's), from two uniforms u: its
/// column in sample order, its row shuffled per pixel and batch by `key`.
inline Vec2 pass_jitter(const PassStrata& strata, int s, uint64_t key, Vec2 u) {
    const float inv = 1.0f / static_cast<float>(strata.size());
    const int column = strata.stratum(s, mix64(key ^ 1), false),
              row = strata.stratum(s, mix64(key ^ 2), true);
    return Vec2(std::min((static_cast<float>(column) + u.x) * inv, 0x1.fffffep-1f),
                std::min((static_cast<float>(row) + u.y) * inv, 0x1.fffffep-1f));
}

}  // namespace fogmap
