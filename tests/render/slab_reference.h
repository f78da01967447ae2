#pragma once
// Independent references for the slab tests (no fogmap code): an analog Monte Carlo of the
// plane-parallel slab in double precision, and the exact diffuse reflectance of a semi-infinite
// isotropically scattering medium from Chandrasekhar's H-function.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

namespace fogmap::slab_reference {

struct Value {
    double mean = 0.0;
    double standard_error = 0.0;  ///< 0 for exact values
};

struct SlabValues {
    Value rd, tt;
};

/// Analog Monte Carlo of a laterally infinite slab of optical thickness tau (infinite allowed),
/// index-matched, under a normal collimated beam. Only the depth z and the direction cosine μ to
/// the inward normal matter (the slab is laterally invariant): flights of −ln(1−ξ) optical
/// depths; absorption with probability 1 − albedo; Henyey–Greenstein scattering turns μ into
/// μ cos θ + sqrt(1 − μ²) sin θ cos φ with φ uniform (the spherical cosine rule), cos θ drawn by
/// the textbook inversion (Prahl et al. 1989; isotropic for g = 0). SE: binomial per photon.
inline SlabValues analog_slab(double tau, double albedo, double g, uint64_t photons,
                              uint64_t seed) {
    std::mt19937_64 gen(seed);
    std::uniform_real_distribution<double> uniform(0.0, 1.0);
    constexpr double kTwoPi = 6.283185307179586;
    uint64_t reflected = 0, transmitted = 0;
    for (uint64_t i = 0; i < photons; ++i) {
        double z = 0.0, mu = 1.0;
        for (;;) {
            z += mu * -std::log1p(-uniform(gen));
            if (z < 0.0) {
                ++reflected;
                break;
            }
            if (z > tau) {
                ++transmitted;
                break;
            }
            if (uniform(gen) >= albedo) break;  // absorbed
            double cos_theta;
            const double u = uniform(gen);
            if (g == 0.0) {
                cos_theta = 2.0 * u - 1.0;
            } else {
                const double q = (1.0 - g * g) / (1.0 - g + 2.0 * g * u);
                cos_theta = std::clamp((1.0 + g * g - q * q) / (2.0 * g), -1.0, 1.0);
            }
            const double sin_theta = std::sqrt(std::max(0.0, 1.0 - cos_theta * cos_theta));
            const double phi = kTwoPi * uniform(gen);
            mu = mu * cos_theta +
                 std::sqrt(std::max(0.0, 1.0 - mu * mu)) * sin_theta * std::cos(phi);
            mu = std::clamp(mu, -1.0, 1.0);
        }
    }
    auto binomial = [&](uint64_t k) {
        const double p = double(k) / double(photons);
        return Value{p, std::sqrt(p * (1.0 - p) / double(photons))};
    };
    return {binomial(reflected), binomial(transmitted)};
}

/// Diffuse reflectance of a semi-infinite, isotropically scattering, index-matched medium under
/// a normal beam: the plane albedo 1 − H(1) sqrt(1 − ω) (Chandrasekhar, Radiative Transfer, 1960,
/// ch. IV), with H from its nonlinear integral equation
///   1/H(μ) = sqrt(1 − ω) + (ω/2) ∫₀¹ μ' H(μ') / (μ + μ') dμ'
/// iterated to convergence on 96 Gauss–Legendre nodes (error < 1e-10 here).
inline double semi_infinite_isotropic_rd(double albedo) {
    constexpr int n = 96;
    std::vector<double> mu(n), w(n), h(n, 1.0);
    for (int i = 0; i < n; ++i) {  // Legendre roots on [−1, 1] by Newton, mapped to [0, 1]
        double x = std::cos(3.141592653589793 * (i + 0.75) / (n + 0.5)), dp = 1.0;
        for (int it = 0; it < 100; ++it) {
            double p0 = 1.0, p1 = x;
            for (int k = 2; k <= n; ++k) {
                const double p2 = ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k;
                p0 = p1;
                p1 = p2;
            }
            dp = n * (x * p1 - p0) / (x * x - 1.0);
            const double dx = p1 / dp;
            x -= dx;
            if (std::abs(dx) < 1e-16) break;
        }
        mu[i] = 0.5 * (x + 1.0);
        w[i] = 1.0 / ((1.0 - x * x) * dp * dp);  // 2 / ((1 − x²) P'²), halved for [0, 1]
    }
    const double root = std::sqrt(1.0 - albedo);
    auto h_at = [&](double m) {
        double s = 0.0;
        for (int j = 0; j < n; ++j) s += w[j] * mu[j] * h[j] / (m + mu[j]);
        return 1.0 / (root + 0.5 * albedo * s);
    };
    for (int it = 0; it < 10000; ++it) {
        std::vector<double> next(n);
        double change = 0.0;
        for (int i = 0; i < n; ++i) {
            next[i] = h_at(mu[i]);
            change = std::max(change, std::abs(next[i] - h[i]));
        }
        h = next;
        if (change < 1e-14) break;
    }
    return 1.0 - h_at(1.0) * root;
}

}  // namespace fogmap::slab_reference
