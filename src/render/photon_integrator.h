#pragma once
// The photon-map renderer (DESIGN.md, Radiance estimates): camera rays follow specular surfaces
// by recursion; at the first diffuse surface direct light comes from shadow rays (transmittance
// by ratio tracking), caustics from the caustic map and indirect diffuse light from the global
// map, shown directly or through final gathering with irradiance precomputed at photon positions
// (Christensen 1999). Along the way camera rays march through media (same step settings as the
// photon pass): single scattering from volume.light_samples shadow rays per light at points drawn
// ∝ the march's weights, and for point and spot lights as many again drawn equi-angularly
// (Kulla & Fajardo 2012), combined by the balance heuristic (every step when 0); multiple
// scattering from the volume map at volume.lookups_per_ray steps drawn by stratified importance
// sampling of the march's weights (every step when 0).
// Each term goes to its own AOV. Deterministic per seed: pixel (x, y), sample s draws from
// Rng(seed, y*width+x, s).

#include "media/ray_march.h"
#include "photon/beam_tree.h"
#include "photon/photon_pass.h"
#include "render/film.h"
#include "render/gather_params.h"

namespace fogmap {

class PhotonIntegrator {
public:
    /// Gathers from `maps` as `gather` says, marching camera rays as `march` says, following at
    /// most max_depth specular bounces. Builds the beam hierarchy for the beam estimate and
    /// precomputes irradiance at every fourth global photon when final gathering is on.
    PhotonIntegrator(const Scene& scene, const PhotonMaps& maps, const GatherParams& gather,
                     const MarchSettings& march, int max_depth);
    ~PhotonIntegrator();

    /// One march step of the current camera segment (σ held constant over [t0, t1]).
    struct MarchedStep {
        float t0, t1;
        Vec3 x;      ///< the march's jittered point in the step
        Color tau0;  ///< optical depth from the segment's start to t0
        Color sigma_t, sigma_s;
        Color weight;  ///< throughput × e^{−τ0} × ∫ over the step of e^{−σ_t s} ds
    };
    struct ThreadState {
        std::vector<Medium::Sampler> media;
        NeighborList neighbors;
        std::vector<MarchedStep> steps;
        std::vector<double> cdf;  ///< scratch: cumulative step weights
        uint64_t rays = 0;
        uint64_t capped = 0;  ///< camera paths cut by render.max_depth (specular chains)
    };
    ThreadState make_state() const;

    /// One camera sample along ray (unit direction), split into the film's layers.
    FilmSample radiance(const Ray& ray, Rng& rng, ThreadState& ts) const;

    /// Wall time of the precomputation (beam radii and hierarchy, irradiance points).
    double precompute_s() const { return precompute_s_; }
    const BeamTree* beam_tree() const { return beam_.get(); }

private:
    struct Irradiance;
    Color direct_surface(const Vec3& p, const Vec3& n, const Color& albedo, Rng& rng,
                         ThreadState& ts) const;
    Color scatter_light(const Light& light, const Vec3& x, const Vec3& dir, float g, Rng& rng,
                        ThreadState& ts) const;
    Color single_scattering(const Ray& ray, const Color& beta, Rng& rng, ThreadState& ts) const;
    Color multiple_scattering(const Vec3& dir, Rng& rng, ThreadState& ts) const;
    Color beam_estimate(const Ray& ray, ThreadState& ts) const;
    Color shadow_transmittance(const Ray& ray, float t_max, Rng& rng, ThreadState& ts) const;
    Color final_gather(const Vec3& p, const Vec3& n, Rng& rng, ThreadState& ts) const;
    Color global_irradiance(const Vec3& p, const Vec3& n, ThreadState& ts) const;
    float phase_g(ThreadState& ts, const Vec3& x) const;

    /// k as the estimators take it: 0 = every photon within the radius.
    static int estimator_k(const MapGather& g) { return g.fixed_radius ? 0 : g.k; }

    const Scene& scene_;
    const PhotonMaps& maps_;
    GatherParams gather_;
    RayMarcher marcher_;
    int max_depth_;
    std::unique_ptr<Irradiance> irradiance_;
    std::unique_ptr<BeamTree> beam_;
    double precompute_s_ = 0.0;
};

/// Renders scene.camera with the photon integrator into a layered film: settings.spp samples
/// per pixel, settings.seed, settings.max_depth (the worker count is the caller's ThreadLimit).
/// *precompute_s (may be null) gets the integrator's precomputation time.
Film render_photon(const Scene& scene, const PhotonMaps& maps, const GatherParams& gather,
                   const MarchSettings& march, const RenderSettings& settings, bool quiet,
                   RenderStats* stats, double* precompute_s);

}  // namespace fogmap
