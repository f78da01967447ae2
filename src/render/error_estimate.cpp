#include "render/error_estimate.h"

#include "core/error.h"
#include "render/metrics.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <functional>
#include <limits>
#include <vector>

namespace fogmap {

namespace {

constexpr int kBlock = 16;         ///< pixels a side of the blocks taken as independent
/// The bias part's blocks: smaller, as each gives its variance one degree of freedom.
constexpr int kBiasBlock = 8;
constexpr double kZ95 = 1.959964;  ///< two-sided 95% quantile of the normal distribution
/// The neighbourhoods whose means stand for a pixel's in y²: squares of 3 x 3 and 5 x 5 less the
/// pixel (calibrated: docs/error-estimate.md). The bias part averages over the outer one.
constexpr int kInner = 1, kOuter = 2;
/// The two means' extrapolation stands for a pixel's y where the pixel holds at least
/// kExtrapolateSpp samples and the extrapolation's y² varies by less than kExtrapolateNoise of
/// itself (squared); elsewhere the outer mean (docs/error-estimate.md, The denominator).
constexpr int kExtrapolateSpp = 32;
constexpr double kExtrapolateNoise = 0.05;

/// Each batch's share of the image's samples: batch_share, or under adaptive sampling (a share
/// per pixel) the pixels' together.
std::array<double, kBatches> image_shares(const Film& film) {
    if (film.pixel_spp.empty()) return film.batch_share;
    std::array<double, kBatches> sum{};
    double all = 0.0;
    for (size_t p = 0; p < film.pixel_spp.size(); ++p) {
        const std::array<int, kBatches> counts = film.batch_samples(p);
        for (size_t b = 0; b < size_t(kBatches); ++b) sum[b] += counts[b];
        all += film.pixel_spp[p];
    }
    for (double& s : sum) s = all > 0.0 ? s / all : 0.0;
    return sum;
}

/// The batches of `film` that hold samples (in some pixel).
std::vector<int> active_batches(const std::array<double, kBatches>& shares) {
    std::vector<int> active;
    for (int b = 0; b < kBatches; ++b)
        if (shares[size_t(b)] > 0.0) active.push_back(b);
    return active;
}

/// The mean of every other of `film`'s `active` batches from `parity` on, by their shares (each
/// pixel's own).
Image half_mean(const Film& film, const std::vector<int>& active, size_t parity) {
    Image out(film.beauty.width, film.beauty.height);
    for (size_t p = 0; p < out.pixels.size(); ++p) {
        const std::array<double, kBatches> share = film.shares(p);
        double weight = 0.0;
        for (size_t i = parity; i < active.size(); i += 2) weight += share[size_t(active[i])];
        if (!(weight > 0.0)) continue;
        for (size_t i = parity; i < active.size(); i += 2) {
            const float w = float(share[size_t(active[i])] / weight);
            out.pixels[p] += w * film.batches[size_t(active[i])].pixels[p];
        }
    }
    return out;
}

/// The window along one axis about c within `radius`, clipped to [0, n) and, for `block` > 0, to
/// c's block of that many.
void axis_window(int c, int n, int radius, int block, int* lo, int* hi) {
    const int start = block > 0 ? c / block * block : 0, end = block > 0 ? start + block : n;
    *lo = std::max(start, c - radius);
    *hi = std::min({n, end, c + radius + 1}) - 1;
}

/// Each pixel's mean over its neighbours within `radius` pixels (a square less the pixel; fewer
/// at the edges); `block` > 0: with the pixel, and only those in its block x block block (so that
/// blocks stay independent). The square's sum by rows, then columns.
Image neighbour_mean(const Image& in, int radius, int block = 0) {
    const bool with_pixel = block > 0;
    const auto window = [&](int c, int n, int* lo, int* hi) {
        axis_window(c, n, radius, block, lo, hi);
    };
    Image rows(in.width, in.height), out(in.width, in.height);
    for (int y = 0; y < in.height; ++y)
        for (int x = 0; x < in.width; ++x) {
            int lo, hi;
            window(x, in.width, &lo, &hi);
            Color sum(0.0f);
            for (int u = lo; u <= hi; ++u) sum += in.at(u, y);
            rows.at(x, y) = sum;
        }
    for (int y = 0; y < in.height; ++y)
        for (int x = 0; x < in.width; ++x) {
            int x_lo, x_hi, y_lo, y_hi;
            window(x, in.width, &x_lo, &x_hi);
            window(y, in.height, &y_lo, &y_hi);
            Color sum(0.0f);
            for (int v = y_lo; v <= y_hi; ++v) sum += rows.at(x, v);
            int n = (x_hi - x_lo + 1) * (y_hi - y_lo + 1);
            if (!with_pixel) {
                sum -= in.at(x, y);
                --n;
            }
            out.at(x, y) = n > 0 ? sum / float(n) : in.at(x, y);
        }
    return out;
}

/// The variance of the mean of value (p, c) of `film` from its `active` batches that hold the
/// pixel's samples (`share`: the pixel's); sets each of `draws` (one per active batch) to its
/// batch's scaled squared deviation, whose expectation is that variance (one draw of the squared
/// error of an image).
double pixel_variance(const Film& film, const std::vector<int>& active,
                      const std::array<double, kBatches>& share, size_t p, int c,
                      std::array<double, kBatches>* draws) {
    double v = 0.0;
    int held = 0;
    const double x = film.beauty.pixels[p][c];
    for (size_t i = 0; i < active.size(); ++i) {
        const double s = share[size_t(active[i])];
        (*draws)[i] = 0.0;
        if (!(s > 0.0)) continue;
        const double d = double(film.batches[size_t(active[i])].pixels[p][c]) - x;
        v += s * d * d;
        (*draws)[i] = d * d * s / (1.0 - s);
        ++held;
    }
    return held > 1 ? v / double(held - 1) : 0.0;
}

/// The pixels of a square of `radius` about (x, y) less the pixel, clipped to a w x h image: the
/// count neighbour_mean divides by.
int ring_count(int x, int y, int w, int h, int radius) {
    int x_lo, x_hi, y_lo, y_hi;
    axis_window(x, w, radius, 0, &x_lo, &x_hi);
    axis_window(y, h, radius, 0, &y_lo, &y_hi);
    return (x_hi - x_lo + 1) * (y_hi - y_lo + 1) - 1;
}

/// The per-axis second moment of a square of `radius` less its centre: its mean of dx².
constexpr double ring_moment(int radius) {
    const double side = 2.0 * radius + 1.0;
    return side * radius * (radius + 1.0) * side / 3.0 / (side * side - 1.0);
}

/// y² of one value, the product of its two halves' neighbour means A and B, and that product's
/// variance: A and B are independent, each of variance Σ c² d / 2 over its neighbours q (c_q their
/// weights in the mean, d_q the squared difference of q's two halves, whose expectation is the
/// two halves' variances), so var(AB) ≈ (A² + B²) Σ c² d / 2.
struct Denominator {
    double y2 = 0.0, noise = 0.0;
    Denominator(double a, double b, double sum_c2d)
        : y2(std::max(a * b, 0.0)), noise((a * a + b * b) * 0.5 * sum_c2d) {}
    /// var / (y² + floor)²: how much of itself the denominator varies by.
    double relative_noise() const {
        const double q = y2 + kRelMseFloor;
        return noise / (q * q);
    }
    /// 1 / (y² + floor), less its noise's part: a noisy y² of expectation μ gives 1 / (y² + f)
    /// an expectation of about 1 / (μ + f) + var / (μ + f)³, which 1 / (q + var / q) takes out
    /// (q = y² + f), staying positive.
    double weight() const {
        const double q = y2 + kRelMseFloor;
        return 1.0 / (q + noise / q);
    }
};

/// relMSE's weight 1 / (y² + floor) per pixel and channel, y² the product of two independent
/// halves' neighbour means: its expectation is the neighbourhood's mean squared, with no noise
/// term added, and it does not depend on the pixel's own samples (a firefly would weigh its own
/// pixel's error down). A neighbourhood's mean differs from the pixel's by the image's curvature
/// times the square's second moment (on smoke1's plume at 64 spp the 5 x 5 mean took the estimate
/// 4% low), so the 3 x 3 and 5 x 5 means are extrapolated to a square of no extent (Richardson)
/// where that is precise (kExtrapolateSpp, kExtrapolateNoise): the extrapolation weighs the
/// nearest eight by 1.56 and the rest by -0.56, six times the 5 x 5 mean's noise, and from fewer
/// samples the halves' means are skewed (a few bright samples) and its y² comes out low,
/// whatever its measured noise says (the Disney cloud's path tracer at 4 spp: 1.27 times the
/// truth). Except where the pixel's own mean less its standard error is above kOwnFloor times y:
/// a bright feature of a pixel or two (a spot's apex, a caustic's focus), whose neighbours say
/// nothing of its scale; there y² is its own, its mean squared less the mean's variance (without
/// bias). Its samples may have missed the feature's core, so the upper bound takes the weight by
/// that lower bound (Weight::upper). A firefly's own bound is about 0 (one batch holds it, and the
/// mean's standard error is then the mean), so fireflies still weigh by their neighbours.
class Weights {
public:
    /// `spp`: estimate_error's.
    Weights(const Film& film, const std::vector<int>& active, int spp)
        : x_(film.beauty),
          weight_(film.beauty.width, film.beauty.height),
          y2_(film.beauty.width, film.beauty.height) {
        // Each image's two means, the halves and their squared difference freed once averaged.
        const auto rings = [](Image* in) {
            std::array<Image, 2> m{neighbour_mean(*in, kInner), neighbour_mean(*in, kOuter)};
            *in = Image();
            return m;
        };
        Image a = half_mean(film, active, 0), b = half_mean(film, active, 1);
        Image d(a.width, a.height);
        for (size_t p = 0; p < d.pixels.size(); ++p)
            d.pixels[p] = square(a.pixels[p] - b.pixels[p]);
        const std::array<Image, 2> md = rings(&d), ma = rings(&a), mb = rings(&b);
        // Extrapolated mean: m1 − M1 (m2 − m1) / (M2 − M1) = α m1 − β m2.
        const double beta = ring_moment(kInner) / (ring_moment(kOuter) - ring_moment(kInner)),
                     alpha = 1.0 + beta;
        const int w = x_.width, h = x_.height;
        for (int py = 0; py < h; ++py)
            for (int px = 0; px < w; ++px) {
                const size_t p = size_t(py) * w + px;
                const double n1 = ring_count(px, py, w, h, kInner),
                             n2 = ring_count(px, py, w, h, kOuter);
                // Σ c² d: the inner ring's pixels weigh α / n1 − β / n2, the outer's −β / n2.
                const double ci = alpha / n1 - beta / n2, co = beta / n2;
                const int held = film.pixel_spp.empty() ? spp : film.pixel_spp[p];
                for (int c = 0; c < 3; ++c) {
                    const double inner = n1 * md[0].pixels[p][c], all = n2 * md[1].pixels[p][c];
                    Denominator y(ma[1].pixels[p][c], mb[1].pixels[p][c], all / (n2 * n2));
                    if (held >= kExtrapolateSpp) {
                        const Denominator e(alpha * ma[0].pixels[p][c] - beta * ma[1].pixels[p][c],
                                            alpha * mb[0].pixels[p][c] - beta * mb[1].pixels[p][c],
                                            ci * ci * inner + co * co * std::max(all - inner, 0.0));
                        if (e.relative_noise() < kExtrapolateNoise) y = e;
                    }
                    weight_.pixels[p][c] = float(y.weight());
                    y2_.pixels[p][c] = float(y.y2);
                }
            }
    }
    /// The weight of value (p, c), whose variance of the mean (batches and maps) is `variance`.
    double operator()(size_t p, int c, double variance) const {
        return weighs(p, c, variance).value;
    }
    /// The weight, and the most it can be by the value's own samples (the same except at a
    /// bright feature: there by its mean less its standard error, (x − s)² <= x² − s²).
    struct Weight {
        double value, upper;
    };
    Weight weighs(size_t p, int c, double variance) const {
        const double x = x_.pixels[p][c], v = std::max(variance, 0.0), bound = x - std::sqrt(v);
        if (!(bound > kOwnFloor * std::sqrt(double(y2_.pixels[p][c]))))
            return {weight_.pixels[p][c], weight_.pixels[p][c]};
        return {1.0 / (x * x - v + kRelMseFloor), relative_squared_error(1.0, bound)};
    }

private:
    static constexpr double kOwnFloor = 3.0;
    static Color square(const Color& c) { return c * c; }
    const Image& x_;
    Image weight_, y2_;
};

double sample_variance(const double* g, size_t n) {
    double mean = 0.0, sum = 0.0;
    for (size_t i = 0; i < n; ++i) mean += g[i];
    mean /= double(n);
    for (size_t i = 0; i < n; ++i) sum += (g[i] - mean) * (g[i] - mean);
    return sum / double(n - 1);
}

/// Welch–Satterthwaite: the degrees of freedom of a sum of independent variance estimates, each
/// with its own, (Σ V)² / Σ (V² / ν). A sum that a few blocks carry has about their few.
struct Satterthwaite {
    double sum = 0.0, spread = 0.0;
    void add(double variance, double dof) {
        sum += variance;
        spread += variance * variance / dof;
    }
    double dof() const {
        return spread > 0.0 ? sum * sum / spread : std::numeric_limits<double>::infinity();
    }
};

/// The share of the sum of `parts` that its largest kTailPixels carry.
double top_share(std::vector<double> parts) {
    double total = 0.0;
    for (double v : parts) total += v;
    if (!(total > 0.0)) return 0.0;
    const size_t top = std::max<size_t>(1, size_t(std::ceil(kTailPixels * double(parts.size()))));
    std::nth_element(parts.begin(), parts.begin() + long(top - 1), parts.end(),
                     std::greater<double>());
    double sum = 0.0;
    for (size_t i = 0; i < top; ++i) sum += parts[i];
    return sum / total;
}

/// A block's part of the estimate from Film::map_variance, which no batch draws, signed per
/// value as its estimate is (a pixel's is noisy about a small mean).
struct BlockPart {
    double sum = 0.0, squares = 0.0;
    int n = 0;
    void add(double v) {
        sum += v;
        squares += v * v;
        ++n;
    }
    /// The variance of the block's sum of the estimates: their values' spread, as if independent
    /// (which the image's heterogeneity only widens).
    double spread() const { return n > 1 ? (squares - sum * sum / n) * n / (n - 1) : 0.0; }
    /// The normal model's variance of the block's error from a variance: 2 (Σ v)², the block's
    /// values' errors one (a map's error is shared by the lookups that read the same photons,
    /// over the gather radius and across the channels), where 2 Σ v², their errors independent,
    /// held smoke.json's truth under the upper bound in 15 of 20 seeds at 64 spp.
    double normal() const { return 2.0 * sum * sum; }
};

/// The bias part: Σ over values of bias² w, and that sum's variance, block by block.
struct BiasSum {
    bool valid = false;  ///< the film has bias_halves
    double sum = 0.0;
    Satterthwaite blocks;
};

/// From Film::bias_halves (none: zero): each half averaged over 5 x 5 within its kBiasBlock
/// block, bias² the mean of the two products of halves that differ in samples and in photons.
/// The two are independent given the bias (no factor shared), so per block their mean varies
/// as a quarter of their squared difference does; blocks are independent.
/// `variance`: each value's variance of the mean (the weights' own bound).
BiasSum bias_sum(const Film& film, const Weights& weight, const Image& variance) {
    BiasSum out;
    out.valid = film.bias_halves.size() == 4;
    if (!out.valid) return out;
    std::vector<Image> h;
    for (const Image& half : film.bias_halves)
        h.push_back(neighbour_mean(half, kOuter, kBiasBlock));
    const int w = film.beauty.width, height = film.beauty.height;
    const int bx = (w + kBiasBlock - 1) / kBiasBlock, by = (height + kBiasBlock - 1) / kBiasBlock;
    std::vector<std::array<double, 2>> blocks(size_t(bx) * by, {0.0, 0.0});
    for (int py = 0; py < height; ++py)
        for (int px = 0; px < w; ++px) {
            const size_t p = size_t(py) * w + px;
            auto& block = blocks[size_t(py / kBiasBlock) * bx + px / kBiasBlock];
            for (int c = 0; c < 3; ++c) {
                const auto at = [&](int i) { return double(h[size_t(i)].pixels[p][c]); };
                const double w = weight(p, c, variance.pixels[p][c]);
                block[0] += at(0) * at(3) * w;
                block[1] += at(1) * at(2) * w;
            }
        }
    for (const auto& [a, b] : blocks) {
        out.sum += 0.5 * (a + b);
        out.blocks.add(0.25 * (a - b) * (a - b), 1.0);
    }
    return out;
}

/// The estimate, its per-pixel variance and the tail flag; `shares`: image_shares.
void estimate_variance(const Film& film, const std::array<double, kBatches>& shares,
                       const std::vector<int>& active, const Weights& weight, ErrorEstimate* e) {
    const Image& x = film.beauty;
    const size_t k = active.size();
    const int bx = (x.width + kBlock - 1) / kBlock, by = (x.height + kBlock - 1) / kBlock;
    // Per block and batch: the draws of the block's relative squared error.
    std::vector<double> draws(size_t(bx) * by * k, 0.0), parts(x.pixels.size(), 0.0);
    // Per block, the variance of one draw were the values normal: 2 (v w)² a value. A floor under
    // the draws' spread, and alone where they cannot tell (two batches deviate alike).
    std::vector<double> gauss(size_t(bx) * by, 0.0), gauss_squares(gauss.size(), 0.0);
    std::vector<BlockPart> maps(size_t(bx) * by);
    const bool map_part = !film.map_variance.pixels.empty();
    e->variance = Image(x.width, x.height);
    double total = 0.0, unsure = 0.0;  // unsure: what bright features' upper weights add
    for (int py = 0; py < x.height; ++py)
        for (int px = 0; px < x.width; ++px) {
            const size_t p = size_t(py) * x.width + px, b = size_t(py / kBlock) * bx + px / kBlock;
            double* const block = &draws[b * k];
            const std::array<double, kBatches> share = film.shares(p);
            for (int c = 0; c < 3; ++c) {
                std::array<double, kBatches> g{};
                const double m = map_part ? film.map_variance.pixels[p][c] : 0.0;
                const double v = pixel_variance(film, active, share, p, c, &g) + m;
                e->variance.pixels[p][c] = float(std::max(v, 0.0));
                const Weights::Weight both = weight.weighs(p, c, e->variance.pixels[p][c]);
                const double w = both.value;
                unsure += v * (both.upper - w);
                for (size_t i = 0; i < k; ++i) block[i] += g[i] * w;
                parts[p] += v * w;
                const double normal = 2.0 * (v * w) * (v * w);
                gauss[b] += normal;
                gauss_squares[b] += normal * normal;
                if (map_part) maps[b].add(m * w);
            }
            total += parts[p];
        }
    // The estimate is sum_i a_i G_i over the batches' draws G: its variance is var(G) sum a_i²,
    // times k / (k − 1) as the draws deviate from the batches' own mean (for normal values and
    // equal shares, var(G) / (k − 1): the sample variance's 2 v² / (k − 1)); this image's error
    // is one more draw.
    // Each block's variance is measured from its k draws (k − 1 degrees of freedom; also where
    // the normal model's floor is above their spread, which heavy tails make no surer), or with
    // two batches from the normal model alone, from its values' variances (one each, their
    // Welch–Satterthwaite sum's); each bias block's from its two products (one): the quantile is
    // Student's t at the sum's degrees of freedom.
    double a2 = 0.0;
    for (int i : active) a2 += std::pow((1.0 - shares[size_t(i)]) / double(k - 1), 2);
    a2 *= double(k) / double(k - 1);
    const BiasSum bias = bias_sum(film, weight, e->variance);
    Satterthwaite all = bias.blocks;
    for (size_t t = 0; t < draws.size(); t += k) {
        const size_t b = t / k;
        const double spread = k > 2 ? sample_variance(&draws[t], k) : 0.0;
        const double dof = k > 2 || !(gauss_squares[b] > 0.0)
                               ? double(k - 1)
                               : gauss[b] * gauss[b] / gauss_squares[b];
        all.add((std::max(spread, gauss[b]) + maps[b].normal() + maps[b].spread()) * (1.0 + a2),
                dof);
    }
    const double values = 3.0 * double(x.pixels.size());
    const auto interval = [&](double sum, const Satterthwaite& variance) {
        const double half = student_t95(variance.dof()) * std::sqrt(variance.sum);
        return Interval{sum / values, std::max(0.0, (sum - half) / values), (sum + half) / values};
    };
    e->bias_valid = bias.valid;
    e->rel_mse = interval(total + bias.sum, all);
    e->rel_mse.hi += std::max(unsure, 0.0) / values;
    e->dof = all.dof();
    e->bias2 = interval(bias.sum, bias.blocks);
    for (double& part : parts) part = std::max(part, 0.0);
    const size_t top = size_t(std::max_element(parts.begin(), parts.end()) - parts.begin());
    e->top_x = int(top % size_t(x.width));
    e->top_y = int(top / size_t(x.width));
    e->tail_share = top_share(std::move(parts));
    e->tail = e->tail_share > kTailShare;
}

}  // namespace

double student_t95(double dof) {
    if (!(dof < 1e7)) return kZ95;
    // With t = √ν tan θ, P(|T| <= t) = ∫₀^θ cos^(ν−1) / ∫₀^(π/2) cos^(ν−1), the latter
    // √π Γ(ν/2) / (2 Γ((ν+1)/2)); the numerator by Simpson's rule, θ by bisection.
    const double nu = std::max(dof, 1.0), half_pi = 2.0 * std::atan(1.0);
    const double whole = 0.5 * std::sqrt(2.0 * half_pi) *
                         std::exp(std::lgamma(0.5 * nu) - std::lgamma(0.5 * (nu + 1.0)));
    const auto mass = [&](double theta) {
        constexpr int kSteps = 512;
        const double h = theta / kSteps;
        double sum = 0.0;
        for (int i = 0; i <= kSteps; ++i) {
            const double f = std::pow(std::cos(i * h), nu - 1.0);
            sum += f * (i == 0 || i == kSteps ? 1.0 : i % 2 ? 4.0 : 2.0);
        }
        return sum * h / 3.0 / whole;
    };
    double lo = 0.0, hi = std::atan(13.0 / std::sqrt(nu));  // t <= 12.71 from ν = 1 on
    for (int i = 0; i < 60; ++i) {
        const double mid = 0.5 * (lo + hi);
        (mass(mid) < 0.95 ? lo : hi) = mid;
    }
    return std::sqrt(nu) * std::tan(0.5 * (lo + hi));
}

ErrorEstimate estimate_error(const Film& film, int spp) {
    ErrorEstimate e;
    const std::array<double, kBatches> shares = image_shares(film);
    const std::vector<int> active = active_batches(shares);
    e.batches = int(active.size());
    if (active.size() < 2 || film.beauty.pixels.empty()) return e;
    e.valid = true;
    const Weights weight(film, active, spp);
    estimate_variance(film, shares, active, weight, &e);
    return e;
}

namespace {

/// estimate_values' fields before the variance's pixels.
constexpr size_t kEstimateFields = 14;

int64_t bits_of(double x) {
    int64_t v;
    std::memcpy(&v, &x, sizeof v);
    return v;
}

double double_of(int64_t v) {
    double x;
    std::memcpy(&x, &v, sizeof x);
    return x;
}

}  // namespace

size_t estimate_value_count(int width, int height) {
    return kEstimateFields + size_t(3) * size_t(width) * size_t(height);
}

std::vector<int64_t> estimate_values(const std::optional<ErrorEstimate>& estimate) {
    std::vector<int64_t> v;
    if (!estimate) return v;
    const ErrorEstimate& e = *estimate;
    FOGMAP_ASSERT(e.valid && !e.variance.pixels.empty(), "a valid estimate has its variance");
    const auto put = [&v](double x) { v.push_back(bits_of(x)); };
    for (double x : {double(e.valid), double(e.batches), e.rel_mse.value, e.rel_mse.lo,
                     e.rel_mse.hi, double(e.bias_valid), e.bias2.value, e.bias2.lo, e.bias2.hi,
                     e.tail_share, double(e.tail), double(e.top_x), double(e.top_y), e.dof})
        put(x);
    for (const Color& c : e.variance.pixels)
        for (int k = 0; k < 3; ++k) put(double(c[k]));
    return v;
}

std::optional<ErrorEstimate> estimate_of_values(const std::vector<int64_t>& values, int width,
                                                int height) {
    if (values.size() != estimate_value_count(width, height)) return std::nullopt;
    size_t at = 0;
    const auto next = [&values, &at] { return double_of(values[at++]); };
    const auto flag = [](double x) { return x == 0.0 || x == 1.0; };
    const auto whole = [](double x, double lo, double hi) {
        return x >= lo && x <= hi && x == std::floor(x);
    };
    const auto interval = [&next](Interval* i) {
        *i = {next(), next(), next()};
        return std::isfinite(i->value) && i->lo >= 0.0 && i->lo <= i->hi && std::isfinite(i->hi);
    };
    ErrorEstimate e;
    const double valid = next(), batches = next();
    bool ok = valid == 1.0 && whole(batches, 0.0, double(kBatches)) && interval(&e.rel_mse);
    const double bias_valid = next();
    ok = ok && flag(bias_valid) && interval(&e.bias2);
    e.tail_share = next();
    const double tail = next(), x = next(), y = next();
    e.dof = next();
    ok = ok && e.tail_share >= 0.0 && e.tail_share <= 1.0 && flag(tail) &&
         whole(x, -1.0, width - 1.0) && whole(y, -1.0, height - 1.0) && e.dof > 0.0;
    if (!ok) return std::nullopt;
    e.valid = true;
    e.batches = int(batches);
    e.bias_valid = bias_valid == 1.0;
    e.tail = tail == 1.0;
    e.top_x = int(x);
    e.top_y = int(y);
    e.variance = Image(width, height);
    for (Color& c : e.variance.pixels)
        for (int k = 0; k < 3; ++k) {
            const double v = next();
            if (!(v >= 0.0 && v <= std::numeric_limits<float>::max())) return std::nullopt;
            c[k] = float(v);
        }
    return e;
}

}  // namespace fogmap
