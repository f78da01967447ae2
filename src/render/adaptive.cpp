// Adaptive sampling (render/film.h, render_film): where a first pass of every pixel's samples
// shows the relative error per unit of work, the rest of the render's work goes.

#include "core/error.h"
#include "core/ranks.h"
#include "core/rng.h"
#include "render/film.h"
#include "render/metrics.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <vector>

namespace fogmap {

namespace {

/// A pixel's neighbours in its allocation: within this many pixels, in its tile.
constexpr int kRing = 2;

/// A pixel's first-pass figures, or a sum of pixels': the mean, the per-sample variance (per
/// channel) and the work per sample.
struct Figures {
    DVec3 mean{0.0}, variance{0.0};
    double work = 0.0;
    int count = 0;
    Figures& operator+=(const Figures& o) {
        mean += o.mean;
        variance += o.variance;
        work += o.work;
        count += o.count;
        return *this;
    }
    Figures operator-(const Figures& o) const {
        Figures d = *this;
        d.mean -= o.mean;
        d.variance -= o.variance;
        d.work -= o.work;
        d.count -= o.count;
        return d;
    }
};

Figures own_figures(const Image& first, const PassMeasure& m, int n, size_t p) {
    Figures f;
    for (int c = 0; c < 3; ++c) {
        const double mean = first.pixels[p][c];
        f.mean[c] = mean;
        f.variance[c] = std::max(0.0, (double(m.squares[p][c]) - n * mean * mean) / (n - 1));
    }
    f.work = m.work[p];
    f.count = 1;
    return f;
}

/// What a pixel whose neighbours sum to `ring` needs: a, the relative deviation per sample
/// (σ² / (y² + 0.01) averaged over the channels, square-rooted), and c, the work per sample.
struct Need {
    double a = 0.0, c = 1.0;
    double spread() const { return a * std::sqrt(c); }  ///< its share of the extra work
};

Need need_of(const Figures& ring) {
    Need need;
    if (ring.count <= 0) return need;
    const double inv = 1.0 / ring.count;
    double a2 = 0.0;
    for (int c = 0; c < 3; ++c) {
        const double y = ring.mean[c] * inv;
        a2 += relative_squared_error(std::max(ring.variance[c], 0.0), y);
    }
    need.a = std::sqrt(a2 * inv / 3.0);
    need.c = std::max(ring.work * inv, 1.0);
    return need;
}

/// Per pixel of one tile: its weight a / sqrt(c), and what its own samples add to the image's
/// two sums (through its neighbours' rings, and its own work), to be taken out again for it.
struct PixelAllocation {
    double weight = 0.0, lift = 0.0, own_work = 0.0, ring_work = 0.0;
};

/// The tile's pixels' allocations (in `out`, by pixel index) and its two sums: Σ a sqrt(c) and
/// Σ c over its pixels (each pixel's own work).
std::array<double, 2> allocate_tile(const Image& first, const PassMeasure& m, int n1, int x0,
                                    int y0, int x1, int y1, std::vector<PixelAllocation>* out) {
    const int w = first.width, tw = x1 - x0, th = y1 - y0;
    std::vector<Figures> own(size_t(tw) * th), ring(size_t(tw) * th);
    const auto at = [&](int x, int y) { return size_t(y - y0) * tw + size_t(x - x0); };
    for (int y = y0; y < y1; ++y)
        for (int x = x0; x < x1; ++x) own[at(x, y)] = own_figures(first, m, n1, size_t(y) * w + x);
    // Each pixel's ring, and the pixels it holds (ring membership is mutual within a tile).
    const auto for_ring = [&](int x, int y, auto&& f) {
        for (int v = std::max(y0, y - kRing); v <= std::min(y1 - 1, y + kRing); ++v)
            for (int u = std::max(x0, x - kRing); u <= std::min(x1 - 1, x + kRing); ++u)
                if (u != x || v != y) f(u, v);
    };
    for (int y = y0; y < y1; ++y)
        for (int x = x0; x < x1; ++x)
            for_ring(x, y, [&](int u, int v) { ring[at(x, y)] += own[at(u, v)]; });
    std::vector<Need> need(own.size());
    for (size_t i = 0; i < own.size(); ++i) need[i] = need_of(ring[i]);
    std::array<double, 2> sums{0.0, 0.0};
    for (int y = y0; y < y1; ++y)
        for (int x = x0; x < x1; ++x) {
            const Need& mine = need[at(x, y)];
            PixelAllocation& a = (*out)[size_t(y) * w + x];
            a.weight = mine.a / std::sqrt(mine.c);
            a.own_work = std::max(own[at(x, y)].work, 1.0);
            a.ring_work = mine.c;
            for_ring(x, y, [&](int u, int v) {
                a.lift +=
                    need[at(u, v)].spread() - need_of(ring[at(u, v)] - own[at(x, y)]).spread();
            });
            sums[0] += mine.spread();
            sums[1] += a.own_work;
        }
    return sums;
}

/// Every tile's two sums from the processes rendering them (tile t is share t mod count's).
void share_tile_sums(TileShare share, std::vector<double>* sums) {
    if (share.count == 1) return;
    FOGMAP_ASSERT(share.ranks, "adaptive sampling of a share of the tiles needs its ranks");
    std::vector<uint8_t> mine(sums->size() * sizeof(double));
    std::memcpy(mine.data(), sums->data(), mine.size());
    const std::vector<std::vector<uint8_t>> all = share.ranks->all_gather(mine);
    const size_t tiles = sums->size() / 2;
    for (size_t t = 0; t < tiles; ++t)
        std::memcpy(&(*sums)[2 * t], all[t % size_t(share.count)].data() + 2 * t * sizeof(double),
                    2 * sizeof(double));
}

}  // namespace

int first_pass_spp(int spp, int unit) {
    if (spp < kAdaptiveMinSpp) return spp;
    return std::min(spp, std::max(2 * unit, spp / 4 / unit * unit));
}

namespace {

/// Every pixel's count in `share`'s tiles: `base` plus the work of spp − base more samples of
/// every pixel at its measured cost, spread as a / sqrt(c) from a measure of n1 samples a pixel
/// (allocate_tile), in whole units by a dither of (seed, pixel), at least one unit, and at most
/// kAdaptiveMax spp.
std::vector<int> spread_work(const Image& first, const PassMeasure& measure, int n1, int spp,
                             int base, int unit, uint64_t seed, TileShare share) {
    const int w = first.width, h = first.height;
    const int tiles = tile_count(w, h);
    std::vector<PixelAllocation> pixels(size_t(w) * h);
    std::vector<double> sums(2 * size_t(tiles), 0.0);  // per tile: Σ a sqrt(c), Σ c
    tbb::parallel_for(0, tiles, [&](int tile) {
        if (tile % share.count != share.index) return;
        const auto [x0, y0, x1, y1] = tile_rect(w, h, tile);
        const std::array<double, 2> s = allocate_tile(first, measure, n1, x0, y0, x1, y1, &pixels);
        sums[2 * size_t(tile)] = s[0];
        sums[2 * size_t(tile) + 1] = s[1];
    });
    share_tile_sums(share, &sums);
    double spread = 0.0, work = 0.0;  // in tile order: the same sums on every rank
    for (int t = 0; t < tiles; ++t) {
        spread += sums[2 * size_t(t)];
        work += sums[2 * size_t(t) + 1];
    }
    // The rest of a uniform render's work, (spp - base) samples of every pixel at its measured
    // cost, spread as a / sqrt(c); for each pixel, the sums without what its own samples added
    // (its own work replaced by its neighbours'), so that its count does not depend on them (up
    // to the sums' rounding).
    const double most =
        std::min(double(kAdaptiveMax) * spp, double(std::numeric_limits<int>::max() - unit)) - base;
    std::vector<int> n(size_t(w) * h, 0);
    for (int tile = share.index; tile < tiles; tile += share.count) {
        const auto [x0, y0, x1, y1] = tile_rect(w, h, tile);
        for (int y = y0; y < y1; ++y)
            for (int x = x0; x < x1; ++x) {
                const size_t p = size_t(y) * w + x;
                const PixelAllocation& a = pixels[p];
                const double others = spread - a.lift;
                const double rest = double(spp - base) * (work - a.own_work + a.ring_work);
                double extra = std::min(rest * a.weight / others, most);
                if (!(others > 0.0) || !std::isfinite(others) || !(extra >= 0.0))
                    extra = double(spp - base);  // nothing to go by (or overflowed): as uniform
                const double dither = Rng(derive_seed(seed, stream::kAdaptive, p), 0).uniform();
                n[p] = std::max(unit, base + unit * int(std::floor(extra / unit + dither)));
            }
    }
    return n;
}

}  // namespace

std::vector<int> allocate_samples(const Film& first, const PassMeasure& measure, int spp, int n1,
                                  int unit, uint64_t seed, TileShare share) {
    return spread_work(first.beauty, measure, n1, spp, n1, unit, seed, share);
}

namespace {

int64_t to_fixed(double x) {
    constexpr double kMost = 576460752303423488.0;  // 2^59: eight such sums stay in range
    const double v = x * IterationMeasure::kUnit;
    return std::isfinite(v) ? std::llround(std::clamp(v, -kMost, kMost)) : 0;
}

}  // namespace

void IterationMeasure::add(const PassMeasure& measure) {
    const Image& means = measure.means;
    const size_t pixels = means.pixels.size();
    if (values.empty()) zero(means.width, means.height);
    FOGMAP_ASSERT(values.size() == 7 * pixels && measure.squares.size() == pixels,
                  "a measure adds films of its own shape");
    for (size_t p = 0; p < pixels; ++p) {
        int64_t* v = &values[7 * p];
        for (int c = 0; c < 3; ++c) {
            v[c] = saturating_add(v[c], to_fixed(means.pixels[p][c]));
            v[3 + c] = saturating_add(v[3 + c], to_fixed(measure.squares[p][c]));
        }
        v[6] = saturating_add(v[6], to_fixed(measure.work[p]));
    }
}

std::vector<int> IterationMeasure::allocate(int iterations, int measured, int spp, int unit,
                                            uint64_t seed) const {
    Image mean(width, height);
    PassMeasure m;
    const size_t pixels = size_t(width) * height;
    m.squares.resize(pixels);
    m.work.resize(pixels);
    const double inv = 1.0 / (kUnit * iterations);
    for (size_t p = 0; p < pixels; ++p) {
        const int64_t* v = &values[7 * p];
        for (int c = 0; c < 3; ++c) {
            mean.pixels[p][c] = float(double(v[c]) * inv);
            m.squares[p][c] = float(double(v[3 + c]) / kUnit);
        }
        m.work[p] = float(double(v[6]) * inv);
    }
    return spread_work(mean, m, iterations * measured, spp, 0, unit, seed, TileShare{});
}

void merge_pixel(Film* film, size_t p, const PixelMeans& later, int n1, int n, int unit) {
    Film& f = *film;
    const float w1 = float(n1) / float(n), w2 = float(n - n1) / float(n);
    const auto mix = [&](Image& a, const Color& b, float x, float y) {
        a.pixels[p] = a.pixels[p] * x + b * y;
    };
    mix(f.beauty, later.beauty, w1, w2);
    for (size_t l = 0; l < f.layers.size(); ++l) mix(f.layers[l], later.layers[l], w1, w2);
    const std::array<int, kBatches> c1 = batch_counts(0, n1, unit), c2 = batch_counts(n1, n, unit);
    std::array<int, 2> k1{}, k2{};  // per sample half (batch parity)
    int later_batches = 0;
    for (size_t b = 0; b < size_t(kBatches); ++b) {
        k1[b % 2] += c1[b];
        k2[b % 2] += c2[b];
        later_batches += c2[b] > 0;
        const int all = c1[b] + c2[b];
        if (all > 0) mix(f.batches[b], later.batches[b], float(c1[b]) / all, float(c2[b]) / all);
    }
    if (!f.map_variance.pixels.empty() && later_batches >= 2)
        mix(f.map_variance, later.map_variance, w1, w2);
    for (size_t i = 0; i < f.bias_halves.size(); ++i) {
        const int s = int(i / 2), all = k1[s] + k2[s];
        if (all > 0) mix(f.bias_halves[i], later.halves[i], float(k1[s]) / all, float(k2[s]) / all);
    }
}

}  // namespace fogmap
