#pragma once
// The volume gather along one camera segment (docs/design.md, Radiance estimates), used by the
// photon integrator and by bench/gather_bench.cpp alike: the segment is marched once into a table
// of steps (σ held constant per step, the same step settings as the photon pass); single scattering
// comes from light_samples shadow rays per light at points drawn ∝ the march's weights, and for
// point and spot lights as many again drawn equi-angularly (Kulla & Fajardo 2012), combined by the
// balance heuristic (a shadow ray at every step when 0); multiple scattering from the volume map,
// either the sphere estimate at lookups_per_ray steps drawn by stratified importance sampling of
// the march's weights (every step when 0) or the beam estimate (Jarosz, Zwicker, Jensen 2008) over
// the whole segment. Where media overlap the phase function is media/phase.h's mixture. Immutable
// and shared const; State is per thread.

#include "core/rng.h"
#include "media/ray_march.h"
#include "photon/beam_tree.h"
#include "photon/estimators.h"
#include "photon/kd_tree.h"
#include "photon/photon_beams.h"
#include "photon/photon_pass.h"
#include "render/gather_params.h"
#include "scene/scene.h"

#include <cstdint>
#include <vector>

namespace fogmap {

/// One march step of the current camera segment (σ held constant over [t0, t1]).
struct MarchedStep {
    float t0, t1;
    Vec3 x;      ///< the march's jittered point in the step
    Color tau0;  ///< optical depth from the segment's start to t0
    Color sigma_t, sigma_s;
    Color weight;  ///< throughput × e^{−τ0} × ∫ over the step of e^{−σ_t s} ds
};

class VolumeGather {
public:
    /// Gathers from `map` (may be null: single scattering only) with `gather`'s volume settings;
    /// `beam` (may be null) is the map's beam hierarchy, used when gather.estimator is beam, and
    /// `beams` its photon beams', used when it is photon_beams.
    VolumeGather(const Scene& scene, const MarchSettings& march, const GatherParams& gather,
                 const PhotonMap* map, const BeamTree* beam, const PhotonBeams* beams = nullptr);

    /// Per-thread state: medium samplers and scratch.
    struct State {
        std::vector<Medium::Sampler> media;
        NeighborList neighbors;
        std::vector<MarchedStep> steps;
        std::vector<double> cdf;  ///< cumulative step weights
        uint64_t rays = 0;        ///< Embree queries of shadow rays
        uint64_t lookups = 0;     ///< volume-map lookups (sphere) or photons visited (beam)
        uint64_t gathered = 0;    ///< photons the sphere lookups gathered
        Color emitted{0.0f};      ///< the marched segment's emission, Σ weight σ_a L_e
    };
    State make_state() const;

    /// Marches `ray` (unit direction) on [0, t_max) from throughput `beta` into st.steps, with
    /// the sample point at `jitter` in [0, 1) of each step; stops where the transmittance falls
    /// below 1e-6. Returns the optical depth of the part marched; st.emitted is the emission seen
    /// along it (weighted by beta), σ_a L_e held constant per step like σ.
    Color march(const Ray& ray, float t_max, const Color& beta, float jitter, State& st) const;

    /// Single scattering over the marched segment (after march()).
    Color single_scattering(const Ray& ray, const Color& beta, Rng& rng, State& st) const;

    /// Multiple scattering over the marched segment (after march()) from the volume map: the
    /// beam or the sphere estimate, already weighted by the throughput. `batches` (may be null;
    /// not for photon beams, which have no batches): what each photon batch gave of it, and the
    /// estimate over r/√2, in its unit with κ applied (BatchSums::bias(1)).
    Color multiple_scattering(const Ray& ray, const Color& beta, Rng& rng, State& st,
                              BatchSums* batches = nullptr) const;

private:
    Color scatter_light(const Light& light, const Vec3& x, const Vec3& dir, Rng& rng,
                        State& st) const;
    Color sphere_estimate(const Vec3& dir, Rng& rng, State& st, BatchSums* batches) const;
    Color beam_estimate(const Ray& ray, State& st, BatchSums* batches) const;
    Color photon_beam_estimate(const Ray& ray, State& st) const;

    const Scene& scene_;
    RayMarcher marcher_;
    const PhotonMap* map_;
    const BeamTree* beam_;
    const PhotonBeams* beams_;
    int k_;  ///< estimator k: 0 = every photon within the radius
    float radius_;
    int lookups_per_ray_, light_samples_;
};

}  // namespace fogmap
