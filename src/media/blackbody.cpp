#include "media/blackbody.h"

#include <algorithm>
#include <cmath>

namespace fogmap {

namespace {

// CODATA 2018 exact constants (SI).
constexpr double kPlanck = 6.62607015e-34;   // J s
constexpr double kLight = 299792458.0;       // m/s
constexpr double kBoltzmann = 1.380649e-23;  // J/K

// A piecewise Gaussian: different widths below and above the mean (Wyman et al. 2013, eq. 1).
double lobe(double x, double mean, double inv_width_below, double inv_width_above) {
    const double t = (x - mean) * (x < mean ? inv_width_below : inv_width_above);
    return std::exp(-0.5 * t * t);
}

}  // namespace

double planck(double lambda_nm, double kelvin) {
    if (!(kelvin > 0.0)) return 0.0;
    const double l = lambda_nm * 1e-9;
    const double x = kPlanck * kLight / (l * kBoltzmann * kelvin);
    // W/(m²·sr·m) → per nm.
    const double l2 = l * l;
    return 2.0 * kPlanck * kLight * kLight / (l2 * l2 * l * std::expm1(x)) * 1e-9;
}

double planck_total(double kelvin) {
    if (!(kelvin > 0.0)) return 0.0;
    // Simpson's rule in u = ln λ: ∫ B dλ = ∫ B λ du. 10 nm .. 1 mm holds all but ~1e-7 of the
    // power from 100 K up (the tails: Wien below, Rayleigh–Jeans above).
    constexpr int kIntervals = 600;  // even
    const double u0 = std::log(10.0), u1 = std::log(1e6), h = (u1 - u0) / kIntervals;
    double sum = 0.0;
    for (int i = 0; i <= kIntervals; ++i) {
        const double lambda = std::exp(u0 + i * h);
        const double w = (i == 0 || i == kIntervals) ? 1.0 : (i % 2 ? 4.0 : 2.0);
        sum += w * planck(lambda, kelvin) * lambda;
    }
    return sum * h / 3.0;
}

DVec3 cie_1931(double l) {
    const double x = 1.056 * lobe(l, 599.8, 1.0 / 37.9, 1.0 / 31.0) +
                     0.362 * lobe(l, 442.0, 1.0 / 16.0, 1.0 / 26.7) -
                     0.065 * lobe(l, 501.1, 1.0 / 20.4, 1.0 / 26.2);
    const double y = 0.821 * lobe(l, 568.8, 1.0 / 46.9, 1.0 / 40.5) +
                     0.286 * lobe(l, 530.9, 1.0 / 16.3, 1.0 / 31.1);
    const double z = 1.217 * lobe(l, 437.0, 1.0 / 11.8, 1.0 / 36.0) +
                     0.681 * lobe(l, 459.0, 1.0 / 26.0, 1.0 / 13.8);
    return DVec3(x, y, z);
}

DVec3 blackbody_xyz(double kelvin) {
    DVec3 xyz(0.0);  // 5 nm steps, as CIE 15 tabulates
    for (int l = 360; l <= 830; l += 5) xyz += planck(l, kelvin) * cie_1931(l);
    return 5.0 * xyz;
}

DVec3 xyz_to_rec709(const DVec3& c) {
    return DVec3(3.2404542 * c.x - 1.5371385 * c.y - 0.4985314 * c.z,
                 -0.9692660 * c.x + 1.8760108 * c.y + 0.0415560 * c.z,
                 0.0556434 * c.x - 0.2040259 * c.y + 1.0572252 * c.z);
}

Color blackbody_radiance(double kelvin) {
    if (!(kelvin > 0.0)) return Color(0.0f);
    const DVec3 xyz = blackbody_xyz(kelvin);
    if (!(xyz.y > 0.0)) return Color(0.0f);  // too cold for the visible: nothing to see
    const DVec3 rgb = glm::max(xyz_to_rec709(xyz), DVec3(0.0));
    const double lum = 0.2126 * rgb.x + 0.7152 * rgb.y + 0.0722 * rgb.z;
    if (!(lum > 0.0)) return Color(0.0f);
    // ∫ B dλ scales exactly as T⁴ (substitute λT): one quadrature serves every temperature.
    static const double total_per_t4 = planck_total(1000.0) * 1e-12;
    const double t2 = kelvin * kelvin;
    return Color(rgb * (1e-6 * total_per_t4 * t2 * t2 / lum));
}

}  // namespace fogmap
