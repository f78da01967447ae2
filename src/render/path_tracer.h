#pragma once
// Reference integrator (docs/design.md, The path tracer): an unbiased volumetric path tracer.
// Weighted delta tracking finds scattering events in media; next-event estimation to every light
// uses residual ratio-tracked transmittance (point and spot lights in media: equi-angular samples
// per segment); area, sun-disc and environment lights are combined with phase/BSDF sampling by
// multiple importance sampling (power heuristic); the environment (constant radiance) is
// light-sampled by the phase function at medium vertices and by the cosine at diffuse surfaces,
// so its estimate varies only with the transmittance (docs/why.md); the first vertex's
// direction and sky sample are stratified over groups of a pixel's samples (Latin hypercube, as
// the sub-pixel positions); Russian roulette once the throughput falls below 1;
// max_depth caps the number of scattering/bounce vertices. Emissive media: every delta-tracking
// segment adds β σ_a L_e / μ at each tentative collision (media/medium.h, delta_track).
// The medium-vertex behaviour is a PathPolicy (below). PathPolicy::end_in_map (the photon
// integrator's volume.gather_depth): paths end at their D-th medium vertex in the volume map
// (render/volume_map_end.h), and the camera segment is not delta-tracked: one ratio-tracking walk
// picks an in-scattering point ∝ T σ_s (media/medium.h, ratio_track_pick) and the path continues
// from it with weight ≈ 1 − T *and* from the surface or sky behind with the walk's
// transmittance. That removes the camera ray's scatter-or-pass-through coin (docs/why.md); the
// plain path tracer keeps delta tracking, where the two branches cost more time than they save.
// The photon integrator's policy also carries its SunShadows: shadow rays to a sun then take
// the media's transmittance from a grid of optical depth along it (render/sun_shadows.h;
// surfaces still occlude), which the plain path tracer never does. PathPolicy::guided: paths
// split at medium vertices where the volume map has more light to come than their pixel's share
// (AdjointSplit, below).
// Deterministic: pixel (x, y), sample s draws from Rng(seed, y*width+x, s) whatever the thread.

#include "core/rng.h"
#include "render/film.h"
#include "render/sun_shadows.h"
#include "render/tiles.h"
#include "render/volume_guide.h"
#include "render/volume_map_end.h"
#include "scene/scene.h"

#include <cstdint>
#include <optional>
#include <vector>

namespace fogmap {

/// The first vertex's direction and sky sample are stratified within groups of this many
/// consecutive samples of a pixel (path_tracer.cpp, stratified): the error estimate's batches
/// take whole groups (strata_unit), and then see the variance per sample the render has.
inline constexpr int kStrataGroup = 4;

/// The unit of the film's batches (render_film) at `spp`: whole strata groups, so that batches
/// are independent, when there are two or more; else single samples (the batches' variance then
/// holds the strata's gain only in part: it comes out a little high).
inline int strata_unit(int spp) { return spp >= 2 * kStrataGroup ? kStrataGroup : 1; }

/// Adjoint-driven splitting at medium vertices (after Vorba & Křivánek 2016; docs/design.md,
/// Guided path tracing): after the direct light at a medium vertex x, the path's expected
/// contribution β (L̃(x) + D) — L̃ the light to come from the volume map (AdjointGrid), D the
/// direct light just estimated (its MIS share is still to come) — against its pixel's estimate Ĩ
/// decides: above Vorba's weight window [kBelow, kAbove] (s = 5) the path splits into
/// ⌈β (L̃ + D) / Ĩ⌉ copies (at most kMaxSplit, and kSplitBudget extra copies a camera sample),
/// each weighted 1/n; within it the path goes on without roulette (the plain roulette would end
/// most of a split's copies at the next vertex); below it the plain roulette, not Vorba's
/// (survival β L̃ / Ĩ): L̃ is too rough a picture to end paths by (docs/why.md).
/// Any such choice from the path so far is unbiased; this one spends samples where the light
/// is. Ĩ's own render (PathPolicy::pixel_estimate) ends paths at their first medium vertex with
/// its direct light plus β L̃ (render_pixel_estimate).
struct AdjointSplit {
    const AdjointGrid* grid = nullptr;  ///< L̃
    const Image* pixels = nullptr;      ///< Ĩ (null in Ĩ's own render)
    static constexpr float kBelow = 1.0f / 3.0f, kAbove = 5.0f / 3.0f;
    static constexpr int kMaxSplit = 8;
    static constexpr int kSplitBudget = 32;
};

/// What a camera path does at a medium vertex (docs/design.md, The path tracer and Guided path
/// tracing).
enum class MediumVertex {
    Continue,   ///< direct light, a phase-sampled direction, Russian roulette
    Guided,     ///< as Continue, split by AdjointSplit, directions guided by a VolumeGuide if any
    EndInGrid,  ///< direct light plus L̃ from an AdjointGrid, then the path ends (Ĩ's render)
    EndInMap,   ///< ends in the volume map where VolumeMapEnd::ends_at; camera segments by
                ///< ratio_track_pick (see the top of this file)
};

/// A PathTracer's integrator: a MediumVertex kind and the collaborators that kind reads, made
/// only by the named factories. Non-owning: the collaborators must outlive every tracer using
/// it. Accessors of a collaborator are valid only for the kinds named on them.
class PathPolicy {
public:
    /// The plain path tracer; `sun` (may be null): shadow rays to the suns it covers read its
    /// grids.
    static PathPolicy plain(const SunShadows* sun = nullptr);
    /// The guided tracer: paths split by `split` (grid and pixels both set); `guide` (may be
    /// null: the phase alone) samples directions at path depths up to guide->settings().vertices.
    static PathPolicy guided(const VolumeGuide* guide, const AdjointSplit& split);
    /// render_pixel_estimate's paths: they end at their first medium vertex with L̃ from `grid`.
    static PathPolicy pixel_estimate(const AdjointGrid& grid);
    /// The photon integrator's camera paths: they end in `end`'s volume map; `sun` as in plain.
    static PathPolicy end_in_map(const VolumeMapEnd& end, const SunShadows* sun);

    MediumVertex kind() const { return kind_; }
    /// Guided, with a guide whose vertices reach path depth `depth` (this vertex included).
    bool guides(int depth) const {
        return kind_ == MediumVertex::Guided && guide_ && depth <= guide_->settings().vertices;
    }
    const VolumeGuide& guide() const { return *guide_; }  ///< when guides(some depth)
    const AdjointSplit& split() const { return split_; }  ///< Guided; EndInGrid (grid only)
    const VolumeMapEnd& end() const { return *end_; }     ///< EndInMap
    /// Shadow rays to light `li` take the media's transmittance from the SunShadows grid.
    bool sun_covers(size_t li) const { return sun_ && sun_->covers(li); }
    const SunShadows& sun() const { return *sun_; }  ///< when sun_covers(some light)

private:
    explicit PathPolicy(MediumVertex kind) : kind_(kind) {}
    MediumVertex kind_;
    const VolumeGuide* guide_ = nullptr;
    AdjointSplit split_;
    const VolumeMapEnd* end_ = nullptr;
    const SunShadows* sun_ = nullptr;
};

class PathTracer {
public:
    /// `policy`: what paths do at medium vertices (PathPolicy's factories).
    PathTracer(const Scene& scene, int max_depth, const PathPolicy& policy = PathPolicy::plain());

    /// Per-thread mutable state: medium samplers and counters. One per task.
    struct ThreadState {
        std::vector<Medium::Sampler> media;
        NeighborList neighbors;  ///< guide photons, or the photons ending a path
        GuideLobes lobes;        ///< the guide at the current vertex
        uint64_t rays = 0;
        uint64_t capped = 0;          ///< paths cut by max_depth
        uint64_t lookups = 0;         ///< volume-map, guide and sun-grid lookups
        uint64_t gathered = 0;        ///< photons those lookups gathered from the kd-tree
        float pixel_estimate = 0.0f;  ///< AdjointSplit's Ĩ for the current camera sample
        int splits_left = 0;          ///< AdjointSplit's extra copies left to the camera sample
        /// The camera sample's FilmSample::photon_delta and bias_half so far (a batched
        /// VolumeMapEnd's).
        std::array<Color, kBatches> photon_delta{};
        std::array<Color, 2> bias_half{};
        bool batched = false;  ///< the camera sample ended in a batched map (FilmSample's)
        /// Set by the caller: the camera sample's radiance is also split into layers (by the
        /// path's vertices, layer_of) and summed here.
        bool layered = false;
        std::array<Color, kLayerCount> layers{};
    };
    ThreadState make_state() const;

    /// Radiance arriving along -ray.d at ray.o (unit direction), one sample; `strata` (may be
    /// null): which sample of its pixel it is, to stratify the first vertex's samples.
    Color radiance(const Ray& ray, Rng& rng, ThreadState& ts,
                   const PixelSample* strata = nullptr) const;

private:
    struct Lobe;
    /// A vertex of a camera path, as the layers tell them apart.
    enum class Vertex : uint8_t { None, Medium, Diffuse, Specular };
    /// What a term of the radiance adds to its path's vertices: nothing (light from a light,
    /// `Emitted` from a medium along a segment) or one or more scattering vertices in a medium
    /// (a point light's single scattering over a segment, the volume map's light).
    enum class Term { Light, Emitted, Scattered };
    /// A camera path's state between vertices.
    struct Path {
        Ray ray;
        Color beta{1.0f};
        bool specular = true;   ///< the last vertex was the camera or a specular bounce: no MIS
        float prev_pdf = 0.0f;  ///< of the direction sampled at the last vertex
        float env_pdf = 0.0f;   ///< the environment's light-sample pdf of that direction there
        Vec3 prev_p{0.0f};
        int depth = 0;
        /// Scattering vertices in media and on diffuse surfaces: a path ends in the volume map
        /// at a medium vertex that makes them volume.gather_depth (a diffuse bounce blurs the
        /// map as a medium's scattering does; specular bounces do not count).
        int gather_vertices = 0;
        const PixelSample* strata = nullptr;  ///< the camera sample's (radiance)
        Vertex first = Vertex::None;          ///< the first medium or diffuse vertex (the layers')
        int scatters = 0;                     ///< medium and diffuse vertices so far
        bool specular_after = false;  ///< a specular bounce after the first (a caustic's path)
    };
    /// The layer of a term of kind `term` added to the radiance of path p: light with no
    /// scattering vertex is emission (from media) or direct (a light seen); with one, direct or
    /// volume_single by the vertex's kind (caustic when specular bounces led from a diffuse
    /// vertex to the light); with more, volume_multiple or indirect by the first vertex's kind.
    static Layer layer_of(const Path& p, Term term);
    /// *L += c, and the sample's layers when ts.layered.
    static void add(const Path& p, Term term, const Color& c, Color* L, ThreadState& ts);
    /// The path's next segment by ratio_track_pick: both the picked medium vertex and what lies
    /// behind (the point lights' segment estimate and the media's emission included).
    Color pick_segment(Path p, Rng& rng, ThreadState& ts) const;
    /// A medium vertex at x: direct light, then the end (false) or a new direction for p
    /// (false when Russian roulette ends it); a split's other copies traced into *L.
    bool scatter(Path& p, const Vec3& x, Color* L, Rng& rng, ThreadState& ts) const;
    /// Counts a vertex of p of kind v; false past max_depth. *strata: the pixel's at the first
    /// vertex.
    bool new_vertex(Path& p, Vertex v, ThreadState& ts, const PixelSample** strata) const;
    /// True: the policy ends p at its medium vertex x (EndInMap: counts it as a gather vertex).
    bool ends_here(Path& p, const Vec3& x) const;
    /// Into *L, the light of a path ending at medium vertex x: its direct light and the map's
    /// (EndInMap) or L̃ (EndInGrid).
    void end_path(const Path& p, const Vec3& x, const PhaseMix& phase, Color* L, Rng& rng,
                  ThreadState& ts) const;
    /// q's direction out of medium vertex x: guide and phase by one-sample MIS (guided), else
    /// the phase, stratified when `strata` (may be null) is given.
    void next_direction(Path& q, const Vec3& x, const PhaseMix& phase, bool guided,
                        const PixelSample* strata, Rng& rng, ThreadState& ts) const;
    /// AdjointSplit at a medium vertex x with direct light `direct`: how many paths go on from p
    /// (0: the roulette ended it), p.beta reweighted.
    int split(Path& p, const Vec3& x, const PhaseMix& phase, const Color& direct, Rng& rng,
              ThreadState& ts) const;
    /// The rest of path p; with first_hit, its first segment's surface hit and media were done
    /// by pick_segment.
    Color trace(Path p, Rng& rng, ThreadState& ts,
                const std::optional<SurfaceHit>* first_hit = nullptr) const;
    /// How a path's segment through the media ended.
    enum class Segment { Passed, Scattered, Ended };
    /// Delta tracking of p's segment up to t_max (with the point lights' segment estimate and
    /// the media's emission, into *L): Passed through, Scattered (p goes on from a medium
    /// vertex) or Ended.
    Segment media_segment(Path& p, float t_max, Color* L, Rng& rng, ThreadState& ts) const;
    /// Into *L, the infinite lights seen by p, which has left the scene.
    void add_escaped(const Path& p, Color* L, ThreadState& ts) const;
    /// A surface vertex `hit` with a material: direct light and a new direction for p. False:
    /// max_depth or Russian roulette ended the path.
    bool bounce(Path& p, const SurfaceHit& hit, Color* L, Rng& rng, ThreadState& ts) const;
    Color direct_light(const Vec3& x, const Lobe& lobe, Rng& rng, ThreadState& ts) const;
    /// Transmittance of the shadow ray from `origin` to sample s of light li.
    Color shadow(size_t li, const Vec3& origin, const LightSample& s, Rng& rng,
                 ThreadState& ts) const;
    Color point_lights_in_segment(const Ray& ray, float t_max, Rng& rng, ThreadState& ts) const;
    Vec3 offset(const Vec3& p, const Vec3& n) const;

    const Scene& scene_;
    int max_depth_;
    PathPolicy policy_;
    bool has_point_lights_ = false;
    bool emissive_ = false;
};

/// Renders scene.camera with the path tracer: settings.spp samples per pixel, settings.seed,
/// settings.max_depth (the worker count is the caller's ThreadLimit), medium vertices as
/// `policy` says. A layered film (PathTracer::layer_of) when `layered`. Progress on stderr
/// unless quiet. `given`: adaptive sampling across iterations (render_film).
Film render_path(const Scene& scene, const RenderSettings& settings, bool quiet, RenderStats* stats,
                 const PathPolicy& policy = PathPolicy::plain(), TileShare tiles = {},
                 bool layered = false, GivenSamples given = {});

/// AdjointSplit's Ĩ: a render of kPixelEstimateSpp samples a pixel whose paths end at their first
/// medium vertex with L̃ from `grid`, its average over each pixel's 3 × 3 neighbourhood within its
/// tile (settings' tile share: only those tiles).
inline constexpr int kPixelEstimateSpp = 4;
/// `stats` (may be null): its counts.
Image render_pixel_estimate(const Scene& scene, const RenderSettings& settings,
                            const AdjointGrid& grid, RenderStats* stats = nullptr,
                            TileShare tiles = {});

}  // namespace fogmap
