#pragma once
// The photon pass (DESIGN.md, Photons): photons leave the lights in streams (photon/streams.h)
// that aim at what the maps need — the specular surfaces, the media, the ground around them, the
// rest — and every photon of a stream in a map carries the same power; Russian roulette on
// albedo decides survival at every interaction; free paths in media by ray marching (default) or
// delta tracking. Storage: global map at diffuse hits after at least one interaction, caustic map
// for L S+ D, volume map at scattering events after at least one interaction (the first
// interaction from a light is left to shadow rays; emitting media's photons are stored from
// their first). A pilot of every stream measures what each
// deposits in each map and what it costs; the streams then emit in the proportions that minimise
// the maps' summed relative variance per unit of work, each map's budget split into per-stream
// quotas, until every quota is met or photons.max_emitted attempts have been made. A global map
// still open when the volume map fills closes with it if its photons carry under a quarter of the
// volume map's power (the light surfaces get only through the media: an open ground under smoke).
// Where camera paths end in the volume map, the only map, it closes after
// kVolumeAttemptsPerSample (0.25) attempts per camera sample, and at least its budget of attempts
// (scene/plan.h, volume_attempts; a preview of a few samples keeps a usable map): the
// map's share of the error falls as 1/photons and the camera's as 1/samples, so the photons that
// balance the pass's cost against the render's grow in proportion to the samples. Calibrated on
// smoke1 over a 10 km ground (64 spp): the rule leaves its relMSE × time as it was (0.35 attempts
// per sample fill 100 000 photons; 0.00160 against 0.00159, 4 seeds), where the same smoke at a
// tenth of its σ spent 2.4 million attempts and 83% of the render on 100 000 photons, 6.1× the
// path tracer's relMSE × time; closed at 0.25 per sample, 1.4×.
// Deterministic: attempt i of a stream draws from Rng(seed, i, the stream's key) and chunks merge
// in a fixed order, whatever the thread count.
// PhotonTracer, the per-photon part, is public so that `fogmap validate` traces its beams with
// exactly this code.

#include "media/ray_march.h"
#include "photon/kd_tree.h"
#include "photon/photon.h"
#include "photon/streams.h"
#include "scene/plan.h"
#include "scene/scene.h"

#include <array>
#include <optional>
#include <string>
#include <vector>

namespace fogmap {

/// One map's photons before its tree is built.
struct StoredPhotons {
    std::vector<Photon> photons;  ///< relative powers, scaled so that photon_power is the unit
    /// Volume map with photons.volume_beams: the paths' beams, weighted as the photons.
    std::vector<PhotonBeam> beams;
    uint64_t budget = 0;
    uint64_t emitted = 0;       ///< attempts, over all streams, behind the map's photons
    float photon_power = 0.0f;  ///< W of a photon whose relative power is 1
    std::string stopped;        ///< why the map closed below its budget by rule ("" if it did not)
};

/// One stream's figures, for the report.
struct StreamReport {
    std::string name;
    uint64_t attempts = 0;   ///< paths sampled (emitted photons count only when accepted)
    uint64_t photons = 0;    ///< attempts that yielded a photon
    uint64_t met_media = 0;  ///< photon paths that entered the media's bounds
    std::array<uint64_t, 3> stored{0, 0, 0};  ///< photons kept per map (global, caustic, volume)
    uint64_t longest = 0;                     ///< the most interactions of one of its paths
    uint64_t capped = 0;
    double capped_power = 0.0;  ///< Σ average relative power of the paths the limit cut
};

struct PhotonPassResult {
    std::optional<StoredPhotons> global, caustic, volume;  ///< absent when the Plan leaves it out
    std::vector<StreamReport> streams;
    uint64_t emitted = 0;  ///< attempts of all streams
    /// Work traced (deterministic, auto's pilot counts it: render/pilot.h): medium density
    /// evaluations and tentative collisions, and photon path interactions.
    uint64_t steps = 0, interactions = 0;
    /// Photon paths cut by photons.max_bounces while still carrying power, and that power as a
    /// share of all emitted power (what the cap removed from the maps' sources).
    uint64_t capped = 0;
    double capped_power = 0.0;
    float total_power = 0.0f;  ///< Σ over lights of the channel-average power (W)
    double time_s = 0.0;
    double exchange_s = 0.0;  ///< of time_s, spent exchanging chunks between ranks
    std::vector<std::string> warnings;
};

class Ranks;

/// Runs the photon pass for the maps the plan turns on, with `settings`' budgets, free paths as
/// `march` says (delta-tracked whatever it says with settings.volume_beams: a short beam takes
/// its photon's presence for the transmittance, so free paths must be exact; photon_beams.h),
/// and photon i drawing from Rng(seed, i, kPhotonStream). Progress on stderr
/// unless quiet. With `ranks` (core/ranks.h) every rank calls it with the same arguments, each
/// traces a share of the photons, and every rank returns the maps one process would build.
PhotonPassResult trace_photons(const Scene& scene, const Plan& plan, const PhotonSettings& settings,
                               const MarchSettings& march, uint64_t seed, bool quiet,
                               Ranks* ranks = nullptr);

/// The maps a path deposits photons into.
enum class PhotonMapId : uint8_t { Global = 0, Caustic = 1, Volume = 2 };

/// A photon a path deposits: its emission index within the batch, its map and the record.
struct TaggedPhoton {
    uint32_t index;
    PhotonMapId map;
    Photon photon;
};

/// A volume-map beam a path deposits, with its emission index within the batch.
struct TaggedBeam {
    uint32_t index;
    PhotonBeam beam;
};

/// Where a photon starts: a light whose paths the bounce stream may own (sun, sky), another
/// light, the bounce stream (photon/streams.h), or an emitting medium. No light samples an
/// emitting medium's light at the camera, so its photons are stored from their first
/// interaction on (the lights' first interactions are left to shadow rays).
enum class PhotonSource : uint8_t { SunOrSky, LocalLight, Bounce, Emission };

/// How a photon path ended.
enum class PathEnd {
    Escaped,    ///< left the scene: no surface ahead and no collision in the media
    Absorbed,   ///< Russian roulette (medium or surface), or it hit a light's black geometry
    BounceCap,  ///< still alive after photons.max_bounces interactions: dropped
};

struct TracedPath {
    PathEnd end = PathEnd::Absorbed;
    Ray ray;                 ///< the last ray: an escaped photon leaves along it
    Color power{0.0f};       ///< power at the end (relative, as passed in)
    int interactions = 0;    ///< medium scatterings and surface bounces
    bool met_media = false;  ///< some segment entered a medium's bounds
};

/// The photon pass's per-photon tracer (trace_photons runs it for every emitted photon; `fogmap
/// validate` runs it on its own beams): free paths by ray marching or delta tracking as `march`
/// says, Russian roulette on albedo, at most max_bounces interactions.
/// Immutable and shared const by all threads; samplers are per thread.
class PhotonTracer {
public:
    PhotonTracer(const Scene& scene, const MarchSettings& march, int max_bounces);

    /// Which maps take photons (global, caustic, volume); none by default. Not during trace().
    void set_store(const std::array<bool, 3>& store) { store_ = store; }
    /// Volume photons come with the beams of the segments before them (photons.volume_beams).
    void set_beams(bool on) { beams_ = on; }
    /// The streams whose bounce stream (if any) owns some of the light paths' volume photons
    /// (photon/streams.h); none by default. Not during trace(); `set` must outlive the tracer.
    void set_bounce_owner(const StreamSet* set) { bounce_owner_ = set; }

    /// Follows a photon leaving along `ray` (unit direction) with relative `power`, drawing only
    /// from `rng`. Photons the maps take are appended to *out, tagged with `index`; out may be
    /// null when no map takes photons. `samplers`: one per medium of the scene, this thread's.
    /// A Bounce photon leaves a diffuse surface and stores volume photons only. With set_beams,
    /// every segment that could end in a stored volume photon leaves its beam in *beams.
    TracedPath trace(Ray ray, Color power, Rng& rng, std::vector<Medium::Sampler>& samplers,
                     uint32_t index, std::vector<TaggedPhoton>* out,
                     PhotonSource source = PhotonSource::LocalLight,
                     std::vector<TaggedBeam>* beams = nullptr) const;

    const RayMarcher& marcher() const { return marcher_; }

private:
    const Scene& scene_;
    RayMarcher marcher_;
    Box3 media_bounds_;
    FreePathMethod method_;
    int max_bounces_;
    std::array<bool, 3> store_{false, false, false};
    bool beams_ = false;
    const StreamSet* bounce_owner_ = nullptr;
};

/// A built map: its kd-tree and the world power of a photon whose relative power is 1.
struct PhotonMap {
    KdTree<Photon> tree;
    float photon_power = 0.0f;  ///< W per photon (total power / emitted)
    uint64_t emitted = 0;
    double build_s = 0.0;
    std::string stopped;            ///< StoredPhotons::stopped
    std::vector<PhotonBeam> beams;  ///< StoredPhotons::beams
};

struct PhotonMaps {
    std::optional<PhotonMap> global, caustic, volume;
};

/// Builds one balanced kd-tree per map (the maps in parallel); consumes the pass result.
PhotonMaps build_trees(PhotonPassResult&& pass);

}  // namespace fogmap
