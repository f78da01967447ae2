#pragma once
// Slab validation (`fogmap validate slab`): a constant-density, index-matched slab (no surfaces,
// n = 1) stored as a VDB grid and loaded like any scene's medium, lit by a collimated beam at
// normal incidence, traced by the photon pass's own PhotonTracer. Tallies the power leaving
// through the top (diffuse reflectance Rd) and the bottom (unscattered, diffuse Td; Tt = both),
// each a mean over photons with its standard error, for comparison with the radiative-transfer
// literature (van de Hulst 1980; MCML, Wang, Jacques & Zheng 1995). Deterministic: photon i
// draws from Rng(seed, i, kSlabStream) and tallies merge in index order, for any thread count.

#include "media/march_settings.h"
#include "scene/scene_desc.h"

#include <cstdint>

namespace fogmap {

struct SlabSettings {
    double tau = 1.0;     ///< optical thickness σ_t d, >= 0; +infinity = semi-infinite
    double albedo = 0.9;  ///< σ_s / σ_t in [0, 1]
    double g = 0.0;       ///< Henyey–Greenstein asymmetry in (-1, 1)
    uint64_t photons = 100000;
    FreePathMethod method = FreePathMethod::March;
    float step_voxels = 1.0f;  ///< march step in voxels (the scene default), > 0
    uint64_t seed = 1;
    int max_bounces = PhotonDesc{}.max_bounces;  ///< interactions per photon (the photon
                                                 ///< pass's default safety limit), >= 1
    int voxels = 32;       ///< voxels across the thickness, >= 1
};

/// A mean over photons and its standard error (sample standard deviation / sqrt(n); NaN for n < 2).
struct SlabEstimate {
    double mean = 0.0;
    double standard_error = 0.0;
};

struct SlabResult {
    SlabEstimate rd;           ///< diffuse reflectance: power leaving upwards
    SlabEstimate unscattered;  ///< power leaving downwards without interaction (→ exp(−τ))
    SlabEstimate td;           ///< diffuse transmittance: leaving downwards after scattering
    SlabEstimate tt;           ///< total transmittance: unscattered + td
    uint64_t photons = 0;
    uint64_t absorbed = 0;    ///< ended by Russian roulette
    uint64_t bounce_cap = 0;  ///< still alive after max_bounces interactions (their power is lost)
    double bounce_cap_power = 0.0;  ///< that lost power as a share of the power sent in
    uint64_t edge = 0;        ///< last interaction outside the slab's uniform part (expected 0)
    /// The work traced, deterministic: photon interactions (scatterings and absorptions), and
    /// medium steps (density evaluations and tentative collisions, as the report counts them).
    /// Bounded by photons and albedo, not by tau (tau_model below).
    uint64_t interactions = 0, steps = 0;
    /// Optical thickness traced: tau, or the finite stand-in of a semi-infinite slab when tau is
    /// infinite or thicker than it (semi_infinite_tau: no photon path of at most max_bounces
    /// interactions that survives Russian roulette with a share above 1e-26 tells them apart).
    double tau_model = 0.0;
    double tau_per_voxel = 0.0;   ///< optical depth of one voxel across the thickness
    bool delta_in_march = false;  ///< method march, but the slab is stiff: free paths delta-tracked
    double time_s = 0.0;
};

/// Optical thickness that stands in for a semi-infinite slab: a photon reaches its bottom with
/// probability below 1e-26 — it would need to survive Russian roulette on `albedo` (in [0, 1])
/// past k interactions, or its first k + 1 unit-mean exponential flights to sum past the
/// thickness (Chernoff), with k at most max_bounces; at least 100, at most 1e6 (889 at albedo
/// 0.9, 1e6 at albedo 1 and the default max_bounces).
double semi_infinite_tau(int max_bounces, double albedo = 1.0);

/// Builds the slab (a VDB file in the temp folder, removed once loaded) and traces the beam.
/// Settings must be in range (the CLI checks them); throws std::runtime_error if the temp grid
/// cannot be written or read back.
SlabResult run_slab(const SlabSettings& settings);

}  // namespace fogmap
