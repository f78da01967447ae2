#pragma once
// Independent references for the slab tests (no fogmap code): an analog Monte Carlo of the
// plane-parallel slab in double precision, the exact diffuse reflectance of a semi-infinite
// isotropically scattering medium from Chandrasekhar's H-function, and an adding-doubling solver
// (van de Hulst 1980; Prahl 1988) for Henyey–Greenstein slabs of any albedo and thickness.

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

/// Gauss–Radau nodes and weights on (0, 1] with a node at μ = 1 (the normal-incidence beam):
/// on [−1, 1] the fixed node is x = −1 and the others the roots of (P_{n−1} + P_n)(x)/(1 + x),
/// weights 2/n² there and (1 − x)/(n² P_{n−1}(x)²) elsewhere (Abramowitz & Stegun 25.4.31);
/// μ = (1 − x)/2, weights halved. Roots by bisection between sign changes on a fine grid.
inline void radau_nodes(int n, std::vector<double>* mu, std::vector<double>* w) {
    auto legendre = [](int k, double x, double* p_km1) {
        double p0 = 1.0, p1 = x;
        if (k == 0) {
            *p_km1 = 0.0;
            return 1.0;
        }
        for (int j = 2; j <= k; ++j) {
            const double p2 = ((2.0 * j - 1.0) * x * p1 - (j - 1.0) * p0) / j;
            p0 = p1;
            p1 = p2;
        }
        *p_km1 = p0;
        return p1;
    };
    auto f = [&](double x) {
        double pm1;
        const double pn = legendre(n, x, &pm1);
        return pm1 + pn;
    };
    mu->assign(1, 1.0);
    w->assign(1, 1.0 / (n * n));
    const int grid = 200 * n;
    double x0 = -1.0 + 1e-12, f0 = f(x0);
    for (int i = 1; i <= grid; ++i) {
        const double x1 = -1.0 + 2.0 * i / grid, f1 = f(x1);
        if ((f0 < 0.0) != (f1 < 0.0)) {
            double lo = x0, hi = x1;
            for (int it = 0; it < 200 && hi - lo > 1e-16; ++it) {
                const double mid = 0.5 * (lo + hi);
                ((f(mid) < 0.0) == (f0 < 0.0) ? lo : hi) = mid;
            }
            const double x = 0.5 * (lo + hi);
            double pm1;
            legendre(n, x, &pm1);
            mu->push_back(0.5 * (1.0 - x));
            w->push_back(0.5 * (1.0 - x) / (double(n) * n * pm1 * pm1));
        }
        x0 = x1;
        f0 = f1;
    }
}

/// Total diffuse reflectance Rd and total transmittance Tt (unscattered included) of an
/// index-matched slab of optical thickness tau (infinite allowed: 2^60 optical depths, far past
/// any diffusion length here), albedo and HG asymmetry g under a normal collimated beam, by
/// adding-doubling (van de Hulst 1980, Prahl 1988) with `n` Radau directions per hemisphere and
/// the δ-M method with n moments (f = g^n of the forward peak folded into the unscattered beam:
/// τ* = (1 − a f) τ, a* = a (1 − f)/(1 − a f), χ*_k = (g^k − f)/(1 − f)). Radiance operators act
/// on the quadrature directions; a thin starting layer of δ ≤ 1e-9 (single scattering) is
/// doubled to τ*.
inline SlabValues adding_doubling(double tau, double albedo, double g, int n = 24) {
    std::vector<double> mu, w;
    radau_nodes(n, &mu, &w);
    const double f = std::pow(g, n);
    const double a = albedo * (1.0 - f) / (1.0 - albedo * f);
    const double tau_star = std::isinf(tau) ? std::ldexp(1.0, 60) : tau * (1.0 - albedo * f);
    // Azimuth-averaged phase h(μ, μ') = Σ_k (2k+1)/2 χ*_k P_k(μ) P_k(μ') over directions
    // ±μ_i (cosines to the downward normal), normalised so that ∫_{-1}^{1} h dμ' = 1.
    auto legendre_all = [](int m, double x) {
        std::vector<double> p(m);
        p[0] = 1.0;
        if (m > 1) p[1] = x;
        for (int k = 2; k < m; ++k)
            p[k] = ((2.0 * k - 1.0) * x * p[k - 1] - (k - 1.0) * p[k - 2]) / k;
        return p;
    };
    std::vector<double> chi(n);
    for (int k = 0; k < n; ++k) chi[k] = f < 1.0 ? (std::pow(g, k) - f) / (1.0 - f) : 1.0;
    std::vector<std::vector<double>> pl(n);
    for (int i = 0; i < n; ++i) pl[i] = legendre_all(n, mu[i]);
    auto h = [&](int i, int j, bool same) {  // same: both down (transmission); else one reversed
        double s = 0.0;
        for (int k = 0; k < n; ++k)
            s += (2.0 * k + 1.0) / 2.0 * chi[k] * pl[i][k] * pl[j][k] *
                 (same || k % 2 == 0 ? 1 : -1);
        return s;
    };
    using Matrix = std::vector<double>;  // n x n, row-major
    auto at = [n](Matrix& m, int i, int j) -> double& { return m[size_t(i) * n + j]; };
    auto mul = [&](const Matrix& x, const Matrix& y) {
        Matrix z(size_t(n) * n, 0.0);
        for (int i = 0; i < n; ++i)
            for (int k = 0; k < n; ++k)
                for (int j = 0; j < n; ++j)
                    z[size_t(i) * n + j] += x[size_t(i) * n + k] * y[size_t(k) * n + j];
        return z;
    };
    auto inverse = [&](Matrix m) {  // Gauss–Jordan with partial pivoting
        Matrix inv(size_t(n) * n, 0.0);
        for (int i = 0; i < n; ++i) at(inv, i, i) = 1.0;
        for (int c = 0; c < n; ++c) {
            int piv = c;
            for (int r = c + 1; r < n; ++r)
                if (std::abs(at(m, r, c)) > std::abs(at(m, piv, c))) piv = r;
            for (int j = 0; j < n; ++j) {
                std::swap(at(m, c, j), at(m, piv, j));
                std::swap(at(inv, c, j), at(inv, piv, j));
            }
            const double d = at(m, c, c);
            for (int j = 0; j < n; ++j) {
                at(m, c, j) /= d;
                at(inv, c, j) /= d;
            }
            for (int r = 0; r < n; ++r) {
                if (r == c) continue;
                const double e = at(m, r, c);
                if (e == 0.0) continue;
                for (int j = 0; j < n; ++j) {
                    at(m, r, j) -= e * at(m, c, j);
                    at(inv, r, j) -= e * at(inv, c, j);
                }
            }
        }
        return inv;
    };
    // Operators on radiance vectors: L_out(μ_i) = Σ_j R_ij (2 μ_j w_j) L_in(μ_j), stored with the
    // weight folded in. Single scattering in the thin layer δ (derived from the RTE):
    // R(μ, μ') = a h(μ↑, μ'↓) (1 − e^{−δ(1/μ + 1/μ')}) / (2 (μ + μ')),
    // T(μ, μ') = a h(μ↓, μ'↓) (e^{−δ/μ} − e^{−δ/μ'}) / (2 (μ − μ')) (→ a h δ e^{−δ/μ} / (2 μ²)),
    // plus the unscattered e^{−δ/μ} on the diagonal of T.
    const int doublings = std::max(0, int(std::ceil(std::log2(tau_star / 1e-9))));
    const double delta = std::ldexp(tau_star, -doublings);
    Matrix R(size_t(n) * n), T(size_t(n) * n);
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
            const double mi = mu[i], mj = mu[j], cj = 2.0 * mj * w[j];
            at(R, i, j) = a * h(i, j, false) * -std::expm1(-delta * (1.0 / mi + 1.0 / mj)) /
                          (2.0 * (mi + mj)) * cj;
            // e^{−δ/μ_i} − e^{−δ/μ_j} = −e^{−δ/μ_i} expm1(δ/μ_i − δ/μ_j): no cancellation.
            const double t =
                i == j ? delta * std::exp(-delta / mi) / (mi * mi)
                       : -std::exp(-delta / mi) * std::expm1(delta / mi - delta / mj) / (mi - mj);
            at(T, i, j) = a * h(i, j, true) * t / 2.0 * cj + (i == j ? std::exp(-delta / mi) : 0.0);
        }
    Matrix identity(size_t(n) * n, 0.0);
    for (int i = 0; i < n; ++i) at(identity, i, i) = 1.0;
    for (int d = 0; d < doublings; ++d) {
        // Two equal layers: R' = R + T (I − R R)^{-1} R T, T' = T (I − R R)^{-1} T.
        Matrix rr = mul(R, R);
        for (size_t k = 0; k < rr.size(); ++k) rr[k] = identity[k] - rr[k];
        const Matrix g_inv = inverse(rr);
        const Matrix tg = mul(T, g_inv);
        const Matrix r_next = mul(mul(tg, R), T);
        for (size_t k = 0; k < R.size(); ++k) R[k] += r_next[k];
        T = mul(tg, T);
    }
    // Normal incidence: unit flux in direction μ_0 = 1 (index 0); outgoing flux Σ_i 2 μ_i w_i L_i.
    auto flux = [&](const Matrix& m) {
        double s = 0.0;
        for (int i = 0; i < n; ++i)
            s += 2.0 * mu[i] * w[i] * m[size_t(i) * n] / (2.0 * mu[0] * w[0]);
        return s;
    };
    return {{flux(R), 0.0}, {flux(T), 0.0}};
}

}  // namespace fogmap::slab_reference
