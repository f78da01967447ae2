#pragma once
// Black-body emission (docs/design.md, Emission): Planck's law, integrated against the CIE 1931 2°
// observer and converted to linear Rec.709. fogmap's normalisation: a voxel at T kelvin emits
// radiance whose luminance is 1e-6 × σT⁴/π — the whole spectrum's radiance in W/(mm²·sr), Blender
// Cycles' convention for blackbody volumes, so Houdini and Blender caches render as bright as there
// — with the colour of Planck's spectrum in the visible: 1000 K gives luminance 0.018 (deep red),
// 1500 K 0.091, 6500 K 32 (white). Pure functions; thread-safe.

#include "core/math.h"

namespace fogmap {

/// Highest temperature fogmap accepts (kelvin); scene loading refuses hotter voxels.
constexpr double kMaxKelvin = 1e5;
/// The Draper point: below about this temperature a black body gives no visible glow.
constexpr double kDraperKelvin = 798.0;

/// Planck's spectral radiance B(λ, T) in W/(m²·sr·nm), λ in nm; 0 for T <= 0.
double planck(double lambda_nm, double kelvin);

/// ∫ B(λ, T) dλ by quadrature on a logarithmic grid over 10 nm .. 1 mm, W/(m²·sr); equals σT⁴/π
/// (Stefan–Boltzmann) to the quadrature's accuracy. 0 for T <= 0.
double planck_total(double kelvin);

/// CIE 1931 2° colour matching functions (x̄, ȳ, z̄) at λ (nm): the multi-lobe Gaussian fit of
/// Wyman, Sloan & Shirley, "Simple Analytic Approximations to the CIE XYZ Color Matching
/// Functions" (JCGT 2013).
DVec3 cie_1931(double lambda_nm);

/// Tristimulus values X, Y, Z of Planck's spectrum at T: ∫ B x̄ dλ ... over 360–830 nm in 5 nm
/// steps (CIE 15's practice).
DVec3 blackbody_xyz(double kelvin);

/// CIE XYZ → linear Rec.709 (sRGB primaries, D65 white), IEC 61966-2-1's matrix.
DVec3 xyz_to_rec709(const DVec3& xyz);

/// fogmap's black-body radiance at T (see the header): linear Rec.709 with luminance
/// 1e-6 · planck_total(T), channels below 0 (out of gamut under ~1900 K) clamped to 0 and the
/// luminance restored. 0 for T <= 0. T in (0, kMaxKelvin].
Color blackbody_radiance(double kelvin);

}  // namespace fogmap
