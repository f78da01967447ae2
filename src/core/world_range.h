#pragma once
// The range of world-space quantities fogmap accepts. Every transform, grid index→world map and
// resulting bound that reaches Embree or the renderer is checked at load: finite, non-singular, and
// within ±kMaxWorldCoordinate world units. The range keeps float rays valid for Embree (it asserts
// |origin| < 1.8e18; sun photons start outside the scene's bounding sphere) and leaves float
// precision for ray offsets; voxel sizes of 1e-4 .. 1e4 fit inside it. Header-only, allocation-free
// but for messages, thread-safe.

#include "core/math.h"

#include <cmath>
#include <cstdio>
#include <string>

namespace fogmap {

/// Largest |coordinate| of anything placed in the world, world units.
inline constexpr double kMaxWorldCoordinate = 1e8;
/// Range of a transform's axis scales (the lengths of its linear part's columns) and of a grid's
/// voxel sizes, world units per unit.
inline constexpr double kMinScale = 1e-6;
inline constexpr double kMaxScale = 1e6;

/// Largest emitted power per channel, W: a light's, or what a radiance or irradiance implies over
/// the scene. Photon powers, estimates (a power over a small disc's area) and pixel sums are
/// float: 1e20 leaves 1e18 of headroom below float's 3.4e38 (a sun of 1e6 W/m^2 over a scene a
/// million units across is 3e18 W).
inline constexpr double kMaxLightPower = 1e20;

/// "%g" of x, for messages.
inline std::string g_text(double x) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%g", x);
    return buf;
}

/// True when b is non-empty and every coordinate is finite and within ±kMaxWorldCoordinate.
inline bool within_world(const Box3& b) {
    for (int a = 0; a < 3; ++a)
        if (!(std::abs(double(b.lo[a])) <= kMaxWorldCoordinate &&
              std::abs(double(b.hi[a])) <= kMaxWorldCoordinate && b.lo[a] <= b.hi[a]))
            return false;
    return true;
}

/// "(lo) .. (hi)" for messages.
inline std::string box_text(const Box3& b) {
    return "(" + g_text(b.lo.x) + ", " + g_text(b.lo.y) + ", " + g_text(b.lo.z) + ") .. (" +
           g_text(b.hi.x) + ", " + g_text(b.hi.y) + ", " + g_text(b.hi.z) + ")";
}

/// Why the affine map m (GLM, column-major: columns 0-2 the axes, column 3 the translation)
/// cannot place things in the world, or "" when it can: every entry finite, each axis scale in
/// [min_scale, max_scale], axes not collapsed (|det| at least 1e-6 of the product of the axis
/// scales: a zero or sheared-away axis makes a shape vanish and the inverse non-finite), and the
/// translation within ±kMaxWorldCoordinate. `scale_name` names the axis scale in the message
/// ("axis scale", "voxel size").
template <class M>
std::string affine_problem(const M& m, const char* scale_name = "axis scale",
                           double min_scale = kMinScale, double max_scale = kMaxScale) {
    for (int c = 0; c < 4; ++c)
        for (int r = 0; r < 4; ++r)
            if (!std::isfinite(double(m[c][r]))) return "is not finite";
    double product = 1.0;
    std::string scales;
    bool in_range = true;
    for (int c = 0; c < 3; ++c) {
        const double len = std::sqrt(double(m[c][0]) * m[c][0] + double(m[c][1]) * m[c][1] +
                                     double(m[c][2]) * m[c][2]);
        scales += (c ? " x " : "") + g_text(len);
        // Relative slack 1e-6: a bound written in a scene file arrives rounded to float.
        in_range = in_range && len >= min_scale * (1.0 - 1e-6) && len <= max_scale * (1.0 + 1e-6);
        product *= len;
    }
    if (!in_range)
        return std::string("has ") + scale_name + "s " + scales + "; expected each in [" +
               g_text(min_scale) + ", " + g_text(max_scale) + "]";
    const glm::dmat3 linear(m[0][0], m[0][1], m[0][2], m[1][0], m[1][1], m[1][2], m[2][0], m[2][1],
                            m[2][2]);
    if (!(std::abs(glm::determinant(linear)) >= 1e-6 * product))
        return "is singular (its axes, of " + std::string(scale_name) + "s " + scales +
               ", lie in one plane); expected an invertible transform";
    for (int r = 0; r < 3; ++r)
        if (!(std::abs(double(m[3][r])) <= kMaxWorldCoordinate))
            return "has translation " + g_text(m[3][0]) + ", " + g_text(m[3][1]) + ", " +
                   g_text(m[3][2]) + "; expected each within ±" + g_text(kMaxWorldCoordinate);
    return "";
}

}  // namespace fogmap
