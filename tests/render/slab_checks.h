#pragma once
// Comparisons shared by slab_test.cpp (~1e5 photons) and slab_heavy_test.cpp (1e6+): fogmap's
// slab (photon/slab.h) against a reference value within 3 combined standard errors,
// sqrt(SE_fogmap² + SE_reference²); each SE comes from its estimator (per-photon sample variance
// for fogmap, binomial for the analog reference, 0 for exact or published values).

#include "photon/slab.h"
#include "slab_reference.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

namespace fogmap::slab_checks {

using slab_reference::Value;

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr FreePathMethod kMethods[] = {FreePathMethod::March, FreePathMethod::Delta};
/// Large enough that no path of these tests reaches it (each test checks bounce_cap == 0).
constexpr int kMaxBounces = 1000;

inline SlabSettings settings(double tau, double albedo, double g, FreePathMethod method,
                             uint64_t photons, uint64_t seed = 7) {
    SlabSettings s;
    s.tau = tau;
    s.albedo = albedo;
    s.g = g;
    s.method = method;
    s.photons = photons;
    s.seed = seed;
    s.max_bounces = kMaxBounces;
    return s;  // default step (1 voxel) and 32 voxels across
}

inline std::string label(const SlabSettings& s, const char* what) {
    return std::string(what) + " at tau " + std::to_string(s.tau) + ", albedo " +
           std::to_string(s.albedo) + ", g " + std::to_string(s.g) + ", " +
           (s.method == FreePathMethod::March ? "march" : "delta");
}

inline void expect_match(const SlabEstimate& got, const Value& ref, const std::string& what) {
    const double tol = 3.0 * std::sqrt(got.standard_error * got.standard_error +
                                       ref.standard_error * ref.standard_error);
    EXPECT_NEAR(got.mean, ref.mean, tol)
        << what << ": fogmap " << got.mean << " ± " << got.standard_error << ", reference "
        << ref.mean << " ± " << ref.standard_error;
}

/// MCML's validation slab (Wang, Jacques & Zheng 1995, Table 2): μa = 10/cm, μs = 90/cm,
/// g = 0.75, d = 0.02 cm, n = 1, i.e. τ = 2, albedo 0.9: Rd = 0.09739, Tt = 0.66096 (van de Hulst
/// 1980, by adding-doubling).
inline void check_mcml(FreePathMethod method, uint64_t photons) {
    const SlabSettings s = settings(2.0, 0.9, 0.75, method, photons);
    const SlabResult r = run_slab(s);
    EXPECT_EQ(r.bounce_cap, 0u);
    expect_match(r.rd, {0.09739, 0.0}, label(s, "Rd"));
    expect_match(r.tt, {0.66096, 0.0}, label(s, "Tt"));
}

/// Albedo 1: nothing is absorbed, so Rd + Tt = 1 for every photon (exactly, up to float power
/// rounding); Rd against the analog reference, computed once for both methods.
inline void check_conservative(double tau, double g, uint64_t photons, uint64_t reference_photons) {
    const slab_reference::SlabValues ref =
        slab_reference::analog_slab(tau, 1.0, g, reference_photons, 11);
    for (FreePathMethod method : kMethods) {
        const SlabSettings s = settings(tau, 1.0, g, method, photons);
        const SlabResult r = run_slab(s);
        EXPECT_EQ(r.absorbed, 0u) << label(s, "absorbed");
        EXPECT_EQ(r.bounce_cap, 0u) << label(s, "bounce cap");
        EXPECT_NEAR(r.rd.mean + r.tt.mean, 1.0, 1e-6) << label(s, "Rd + Tt");
        expect_match(r.rd, ref.rd, label(s, "Rd"));
    }
}

/// Albedo 0: every collision absorbs; Rd = Td = 0 exactly and Tt = exp(−τ).
inline void check_black(double tau, FreePathMethod method, uint64_t photons) {
    const SlabSettings s = settings(tau, 0.0, 0.0, method, photons);
    const SlabResult r = run_slab(s);
    EXPECT_EQ(r.rd.mean, 0.0) << label(s, "Rd");
    EXPECT_EQ(r.td.mean, 0.0) << label(s, "Td");
    expect_match(r.tt, {std::exp(-tau), 0.0}, label(s, "Tt"));
}

/// Rd, Tt and the unscattered part against the analog reference, computed once for both methods.
inline void check_against_analog(double tau, double albedo, double g, uint64_t photons,
                                 uint64_t reference_photons) {
    const slab_reference::SlabValues ref =
        slab_reference::analog_slab(tau, albedo, g, reference_photons, 13);
    for (FreePathMethod method : kMethods) {
        const SlabSettings s = settings(tau, albedo, g, method, photons);
        const SlabResult r = run_slab(s);
        EXPECT_EQ(r.bounce_cap, 0u) << label(s, "bounce cap");
        EXPECT_EQ(r.edge, 0u) << label(s, "edge");
        expect_match(r.rd, ref.rd, label(s, "Rd"));
        expect_match(r.tt, ref.tt, label(s, "Tt"));
        expect_match(r.unscattered, {std::exp(-tau), 0.0}, label(s, "T unscattered"));
    }
}

/// Isotropic scattering, semi-infinite (tau = inf) or so thick that nothing gets through
/// (τ = 100, 1000 at albedo < 1: Tt = 0): Rd = 1 − H(1) sqrt(1 − ω) (Chandrasekhar 1960).
/// These slabs are stiff (τ per voxel > 0.25), so march mode delta-tracks them.
inline void check_semi_infinite(double tau, double albedo, FreePathMethod method,
                                uint64_t photons) {
    const SlabSettings s = settings(tau, albedo, 0.0, method, photons);
    const SlabResult r = run_slab(s);
    EXPECT_EQ(r.bounce_cap, 0u) << label(s, "bounce cap");
    EXPECT_EQ(r.tt.mean, 0.0) << label(s, "Tt");
    EXPECT_EQ(r.delta_in_march, method == FreePathMethod::March) << label(s, "stiff switch");
    expect_match(r.rd, {slab_reference::semi_infinite_isotropic_rd(albedo), 0.0}, label(s, "Rd"));
}

/// Adding-doubling values (slab_reference::adding_doubling, whose own accuracy ~1e-5 is taken as
/// its standard error) with fogmap's *default* settings — free paths, march step and the bounce
/// limit as a user gets them — and nothing lost to the bounce limit above 0.1% of the power.
inline void check_adding_doubling(double tau, double albedo, double g, uint64_t photons,
                                  uint64_t seed = 7) {
    SlabSettings s;  // defaults, but for the medium and the photon count
    s.tau = tau;
    s.albedo = albedo;
    s.g = g;
    s.photons = photons;
    s.seed = seed;
    const SlabResult r = run_slab(s);
    const slab_reference::SlabValues ref = slab_reference::adding_doubling(tau, albedo, g);
    EXPECT_LE(r.bounce_cap_power, 0.001) << label(s, "bounce cap");
    expect_match(r.rd, {ref.rd.mean, 1e-5}, label(s, "Rd vs adding-doubling"));
    expect_match(r.tt, {ref.tt.mean, 1e-5}, label(s, "Tt vs adding-doubling"));
}

}  // namespace fogmap::slab_checks
