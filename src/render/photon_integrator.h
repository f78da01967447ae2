#pragma once
// The photon-map renderer (docs/design.md, Radiance estimates): camera rays follow specular
// surfaces by recursion; at the first diffuse surface direct light comes from shadow rays
// (transmittance by ratio tracking), caustics from the caustic map and indirect diffuse light from
// the global map, shown directly or through final gathering with irradiance precomputed at photon
// positions (Christensen 1999). Along the way camera rays march through media and gather single and
// multiple scattering there (render/volume_gather.h). Each term goes to its own film layer.
// Deterministic per seed: pixel (x, y), sample s draws from Rng(seed, y*width+x, s).

#include "photon/beam_tree.h"
#include "photon/photon_pass.h"
#include "render/film.h"
#include "render/gather_params.h"
#include "render/tiles.h"
#include "render/volume_gather.h"

#include <memory>

namespace fogmap {

class PhotonIntegrator {
public:
    /// Gathers from `maps` as `gather` says, marching camera rays as `march` says, following at
    /// most max_depth specular bounces. Builds the beam hierarchy for the beam estimate and
    /// precomputes irradiance at every fourth global photon when final gathering is on.
    /// `photon_batches`: samples say what each photon batch gave (FilmSample::photon_delta);
    /// only where batches_supported.
    PhotonIntegrator(const Scene& scene, const PhotonMaps& maps, const GatherParams& gather,
                     const MarchSettings& march, int max_depth, bool photon_batches = false);

    /// Whether every map lookup of `gather`'s settings can say what each photon batch gave: not
    /// photon beams (they have no batches) nor final gathering (its irradiance is precomputed).
    static bool batches_supported(VolumeEstimator estimator, bool final_gather) {
        return estimator != VolumeEstimator::PhotonBeams && !final_gather;
    }
    ~PhotonIntegrator();

    /// Per-thread state: the volume gather's (samplers, scratch, ray count) and the cap count.
    struct ThreadState : VolumeGather::State {
        uint64_t capped = 0;  ///< camera paths cut by render.max_depth (specular chains)
    };
    ThreadState make_state() const;

    /// One camera sample along ray (unit direction), split into the film's layers. Its photon-map
    /// lookups (volume, caustic, global) weigh map_weight; 0 leaves them out (advanced.map_spp).
    FilmSample radiance(const Ray& ray, Rng& rng, ThreadState& ts, float map_weight = 1.0f) const;

    /// Wall time of the precomputation (beam radii and hierarchy, irradiance points).
    double precompute_s() const { return precompute_s_; }
    const BeamTree* beam_tree() const { return beam_.get(); }

private:
    struct Irradiance;
    Color final_gather(const Vec3& p, const Vec3& n, Rng& rng, ThreadState& ts) const;
    Color global_irradiance(const Vec3& p, const Vec3& n, ThreadState& ts) const;

    /// k as the estimators take it: 0 = every photon within the radius.
    static int estimator_k(const MapGather& g) { return g.fixed_radius ? 0 : g.k; }

    const Scene& scene_;
    const PhotonMaps& maps_;
    GatherParams gather_;
    int max_depth_;
    bool photon_batches_;
    double precompute_s_ = 0.0;  ///< before beam_, whose construction adds to it
    std::unique_ptr<Irradiance> irradiance_;
    std::unique_ptr<BeamTree> beam_;
    std::unique_ptr<PhotonBeams> beams_;
    VolumeGather volume_;    ///< after beam_ and beams_, which it points to
    bool emissive_ = false;  ///< some medium emits: gather rays collect its emission
};

/// The weight of sample ps's photon-map lookups when one sample in each block of `step`
/// consecutive samples makes them (step = map_step of the render's spp; 1: every sample, weight
/// 1). The block is the batches' unit (render_photon), and step is the render's, not the pixel's
/// own count (ps.spp), which adaptive sampling sets pixel by pixel: a pixel reads the maps once
/// in each unit of its samples, however many it takes. Sample s of block B = s / step is chosen
/// when (s + offset + shift_B) % step == 0, with the pixel's offset uniform in [0, step) (from
/// ps.key), so every sample is chosen with probability 1/step and weighs step (Horvitz–Thompson:
/// unbiased). shift_B = batch(B) step / min(blocks, kBatches), blocks the pixel's, spreads the
/// chosen samples of the batches' blocks, which share their coarse columns (render/batches.h),
/// over the pixel. 0 for the others.
float map_weight(const PixelSample& ps, int step);
/// The step of a render of spp samples a pixel of which about map_spp read the photon maps
/// (advanced.map_spp; 0 = all): spp / map_spp, at least 1.
int map_step(int spp, int map_spp);

/// Renders scene.camera with the photon integrator into a layered film: settings.spp samples
/// per pixel (or their work, with settings.adaptive: render_film), settings.seed,
/// settings.max_depth (the worker count is the caller's ThreadLimit).
/// *precompute_s (may be null) gets the integrator's precomputation time. `parts` other than
/// None: the integrator's photon_batches, of which the film keeps `parts`. `given`: adaptive
/// sampling across iterations (render_film).
Film render_photon(const Scene& scene, const PhotonMaps& maps, const GatherParams& gather,
                   const MarchSettings& march, const RenderSettings& settings, bool quiet,
                   RenderStats* stats, double* precompute_s, TileShare tiles = {},
                   PhotonParts parts = PhotonParts::None, GivenSamples given = {});

}  // namespace fogmap
