#pragma once
// A render's estimate of its own error, without a reference (docs/error-estimate.md): from the
// film's kBatches batch means (render/film.h), each pixel's variance of the mean, and the image's
// relMSE on the scale of --reference's (render/metrics.h), each value normalised by y² estimated
// from two independent halves of the batches, each averaged over the pixel's neighbours in 5 x 5
// but not over the pixel itself (its own noisy mean in the denominator makes the estimate low
// where the error is: 0.55 of the truth on the Disney cloud at 4 spp). The 95% interval is for
// the error of this very image: it adds the spread of one image's error about its expectation to
// the estimate's own, both measured per 16 x 16 block from the batches (blocks are taken as
// independent, pixels within one are not). It holds what the batches repeat: the camera samples,
// and the photon maps when batches are whole iterations with maps of their own; the variance one
// map read by every sample adds where the film has it (Film::map_variance, from photon batches),
// and the square of that map's bias from its radius (Film::bias_halves), reported apart too: the
// products of halves that differ in samples and in photons, each averaged over the pixel's 5 x 5
// neighbourhood within its 8 x 8 block (the bias varies on the scale of the map's radius, its
// estimates' noise from pixel to pixel); not a photon method's bias otherwise, and not fireflies
// that have not been drawn yet (the tail flag says when the drawn ones carry it). Pure and
// deterministic.

#include "core/image.h"
#include "render/film.h"

#include <cstdint>
#include <limits>
#include <optional>
#include <vector>

namespace fogmap {

/// A value with its 95% interval.
struct Interval {
    double value = 0.0, lo = 0.0, hi = 0.0;
};

struct ErrorEstimate {
    bool valid = false;       ///< at least two batches hold samples
    int batches = 0;          ///< batches holding samples
    Interval rel_mse;         ///< lo >= 0; bias² included where estimated
    bool bias_valid = false;  ///< the film has bias_halves
    Interval bias2;           ///< the relMSE's bias² part (lo >= 0)
    double tail_share = 0.0;  ///< the share of rel_mse the top 0.1% of pixels carry
    bool tail = false;        ///< tail_share above one half
    int top_x = -1, top_y = -1;  ///< the pixel that carries the largest part of rel_mse (if valid)
    /// The degrees of freedom of rel_mse's interval (Welch–Satterthwaite over its blocks): few
    /// where a few blocks carry the error, and the interval then widens (student_t95).
    double dof = std::numeric_limits<double>::infinity();
    Image variance;           ///< per pixel and channel, the variance of the mean (if valid)
};

/// The top share of pixels whose part of the estimate the tail flag weighs, and the part of the
/// estimate above which it is raised.
inline constexpr double kTailPixels = 0.001;
inline constexpr double kTailShare = 0.5;

/// The two-sided 95% quantile of Student's t with `dof` (> 0, not necessarily whole) degrees of
/// freedom: 12.71 at 1, 1.96 as dof grows without bound.
double student_t95(double dof);

/// The estimate from `film`'s beauty, batches and batch shares; `spp`: the samples every pixel of
/// the film holds (Film::pixel_spp's own under adaptive sampling).
ErrorEstimate estimate_error(const Film& film, int spp);

/// A valid estimate as integers, for the files that carry iteration 1's to where a run that ends
/// after it ends (a checkpoint, a part file): each field, then the variance's pixels, as the bits
/// of doubles (exact: every value is a double or a float); estimate_value_count(w, h) of them,
/// none without an estimate.
std::vector<int64_t> estimate_values(const std::optional<ErrorEstimate>& estimate);
size_t estimate_value_count(int width, int height);
/// The inverse for a `width` x `height` film, or nothing where `values` are not what
/// estimate_values writes (not valid, or a count, flag, interval or variance out of its range).
std::optional<ErrorEstimate> estimate_of_values(const std::vector<int64_t>& values, int width,
                                                int height);

/// Whether `e` meets a target relMSE: valid, and its 95% upper bound at most `target`.
inline bool meets_target(const ErrorEstimate& e, double target) {
    return e.valid && e.rel_mse.hi <= target;
}

}  // namespace fogmap
