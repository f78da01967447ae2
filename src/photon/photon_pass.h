#pragma once
// The photon pass (docs/design.md, Photon emission and streams): fills the photon maps the Plan
// turns on to their budgets. Photons leave the lights in streams (photon/streams.h), and every
// photon of one stream in one map carries the same power; Russian roulette on albedo decides
// survival at every interaction; free paths in media by ray marching (default) or delta tracking.
// Storage: global map at diffuse hits after at least one interaction, caustic map for L S+ D,
// volume map at scattering events after at least one interaction (the first interaction from a
// light is left to shadow rays; emitting media's photons are stored from their first).
// Allocation (PhotonPass): pilot rounds of every stream, then rounds whose stream proportions
// (stream_proportions) are recomputed each round from what the streams have deposited so far.
// Closing: a map closes when full; the pass stops at photons.max_emitted attempts; a global map
// still open when the volume map fills closes with it if its photons carry under a quarter of
// the volume map's power; where camera paths end in the volume map, the only map, it closes
// after settings.volume_attempts (kVolumeAttemptsPerSample per camera sample, at least its
// budget; scene/plan.h).
// Why: the streams and their proportions minimise the maps' summed relative variance per unit
// of work, and the closing rules keep a map nobody needs more of from driving the pass.
// Deterministic: attempt i of a stream draws from Rng(seed, i, the stream's key) and chunks merge
// in a fixed order, whatever the thread or rank count.
// PhotonTracer, the per-photon part, is public so that `fogmap validate` traces its beams with
// exactly this code.

#include "media/ray_march.h"
#include "photon/kd_tree.h"
#include "photon/photon.h"
#include "photon/photon_settings.h"
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
    /// Work traced (deterministic, for the report: Report::photon_steps): medium density
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

/// Runs the photon pass (PhotonPass, below) for the maps the plan turns on, with `settings`'
/// budgets, free paths as `march` says (delta-tracked whatever it says with settings.volume_beams:
/// a short beam takes its photon's presence for the transmittance, so free paths must be exact;
/// photon_beams.h), and attempt i of a stream drawing from Rng(seed, i, the stream's key).
/// Progress on stderr unless quiet. With `ranks` (core/ranks.h) every rank calls it with the same
/// arguments, each traces a share of the photons, and every rank returns the maps one process would
/// build.
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
    struct Walk;  ///< one path's state (photon_pass.cpp)
    enum class Collision { None, Scattered, Absorbed };
    /// The segment ahead (up to t_max) through the media: no collision, a scattering (the
    /// photon stored if the volume map takes it, and a new direction), or Russian roulette's end.
    Collision cross_media(Walk& w, float t_max, int depth) const;
    /// A surface interaction: stores the surface photons and reflects; false if absorbed.
    bool leave_surface(Walk& w, const SurfaceHit& hit, int depth) const;
    /// The part of the segment ahead on [0, end) within the media's bounds, as a beam.
    void leave_beam(Walk& w, float end) const;

    const Scene& scene_;
    RayMarcher marcher_;
    Box3 media_bounds_;
    FreePathMethod method_;
    int max_bounces_;
    std::array<bool, 3> store_{false, false, false};
    bool beams_ = false;
    const StreamSet* bounce_owner_ = nullptr;
};

/// The allocation rule: each stream's attempts in the next round relative to the largest (1),
/// N_s ∝ √(Φ_s Σ_m P_ms / P_m² / c_s) over the open maps m with P_m = Σ_s P_ms > 0, and at least
/// 5% of its share under plain emission (0.05 Φ_s / max_s Φ_s). power: Φ_s, the power of the
/// region stream s samples; deposit: P_ms, the power it has put into map m per attempt; cost:
/// c_s, its work per attempt. Why: a map's variance is about Σ_s (Φ_s / N_s) P_ms, and this
/// minimises Σ_m Var_m / P_m² for the work Σ_s N_s c_s; the floor keeps sampling light the pilot
/// saw little of.
std::vector<double> stream_proportions(const std::vector<double>& power,
                                       const std::vector<std::array<double, 3>>& deposit,
                                       const std::array<bool, 3>& open,
                                       const std::vector<double>& cost);

/// A round's attempts per stream: ⌈batch × rate_s⌉, or, when those pass `left` (the last round
/// under the cap), each scaled by left / their sum, rounded down (all `left` to stream 0 if that
/// leaves none).
std::vector<uint64_t> round_counts(const std::vector<double>& rate, uint64_t batch, uint64_t left);

class Progress;

/// One photon pass, as trace_photons runs it (docs/design.md, Photon emission and streams):
/// construct with trace_photons' arguments, then run() once. Rounds of attempts of every stream
/// are traced in parallel chunks and merged in a fixed order; a pilot of every stream comes
/// first, then rounds in the allocation's proportions, until every map has closed or the cap is
/// reached; then every photon is weighed Φ_s / (its stream's attempts behind its map).
/// Why a class: the allocation and closing rules share the pass's counts, and each is a method.
class PhotonPass {
public:
    PhotonPass(const Scene& scene, const Plan& plan, const PhotonSettings& settings,
               const MarchSettings& march, uint64_t seed, bool quiet, Ranks* ranks);
    PhotonPass(const PhotonPass&) = delete;
    PhotonPass& operator=(const PhotonPass&) = delete;

    /// Traces the pass and hands over its result (what trace_photons returns). Once.
    PhotonPassResult run();

private:
    /// Per (stream, map): photons stored, their summed relative power, and, once the map has
    /// closed, the stream's attempt count at which it stopped taking the stream's photons.
    struct Pair {
        uint64_t stored = 0;
        double power = 0.0;
        bool closed = false;
        uint64_t stop_at = 0;
    };
    struct Job;       ///< a chunk of one stream's attempts
    struct ChunkOut;  ///< what a chunk produced

    // Set-up.
    /// Allocates the maps the Plan turns on, with their budgets; false if all budgets are 0.
    bool open_maps();
    /// The streams, the total power and the tracer; false (with a warning) if no light emits.
    bool make_streams_and_tracer();

    // Allocation rules.
    /// Pilot rounds of 256, 512, ... attempts of every stream, 8192 in all (less if the cap or
    /// the budgets come first): what each stream deposits and costs, before any allocation.
    void pilot();
    /// Rounds of the allocation's proportions until every map has closed or the cap is reached.
    void allocated_rounds(Progress& progress);
    /// Power (W, channel average) stream s has put into map m per attempt behind the map.
    double deposit_rate(size_t s, int m) const;
    /// stream_proportions from every photon so far (recomputed each round).
    std::vector<double> allocation() const;

    // Closing rules.
    /// The cap on attempts: photons.max_emitted (or 100 × the largest budget), or the volume
    /// attempts rule's (the volume map alone, settings.volume_attempts) when that is lower.
    void set_cap();
    uint64_t attempts_left() const;  ///< under the cap
    bool full(int m) const;          ///< map m holds its budget
    bool any_open() const;
    /// Closes map m at every stream's attempts so far (its photons weigh Φ_s over those).
    void close_now(int m);
    /// Closes map m at the attempt e of stream s whose path filled it (keeping that whole
    /// path): for the streams merged before s at the end of this round (count), for those
    /// after it at its start.
    void close_at(int m, size_t s, uint64_t e, const std::vector<uint64_t>& count);
    /// After the first round, which every map keeps whole (every stream must have attempts
    /// behind every map): closes the maps it filled.
    void close_full_after_first_round();
    /// The global map closes with the volume map, when that one fills, if its photons carry
    /// under a quarter of the volume map's power. Checked once.
    void close_global_with_volume();
    /// MPI shares: this rank traces every n_ranks-th chunk of each round (the chunks do not
    /// depend on the rank count), and all ranks exchange them before the merge.
    bool mine(size_t chunk) const;
    void exchange(size_t n_jobs, std::vector<ChunkOut>* out);

    // A round.
    /// Traces count[s] more attempts of every stream and merges them (closing maps as they fill).
    void emit(const std::vector<uint64_t>& count);
    /// An attempt of stream s: the photon's ray, power and source; false if it yields none.
    bool start_photon(int s, std::vector<Medium::Sampler>& samplers, Rng& rng, Ray* ray,
                      Color* power, PhotonSource* source) const;
    void trace_chunk(const Job& job, std::vector<Medium::Sampler>& samplers, ChunkOut* o) const;
    /// Adds a chunk's photons to the maps still taking them and its counts to the report.
    void merge(const Job& job, const ChunkOut& o, bool first, const std::vector<uint64_t>& count);

    // Weights and the report.
    uint64_t total_attempts() const;
    /// Attempts behind pair (s, m)'s photons: all of the stream's, or those before m closed.
    double behind(size_t s, int m) const;
    /// A photon of stream s in map m carries Φ_s / behind(s, m); the map's photon power is the
    /// largest and each record's relative power is rescaled to it. Notes why a map is short.
    void weigh_map(int m);
    /// Streams' attempts, and the power photons.max_bounces cut (a warning above
    /// kCapWarnShare).
    void report_streams();

    const Scene& scene_;
    const Plan& plan_;
    const PhotonSettings& settings_;
    const MarchSettings& march_;
    const uint64_t seed_;
    const bool quiet_;
    Ranks* const ranks_;
    const size_t n_ranks_, my_rank_;

    PhotonPassResult result_;
    std::array<StoredPhotons*, 3> maps_{nullptr, nullptr, nullptr};  ///< into result_
    uint64_t largest_ = 0;                                           ///< the largest budget
    StreamSet set_;
    size_t n_streams_ = 0;
    std::optional<PhotonTracer> tracer_;
    std::array<bool, 3> open_{false, false, false};  ///< maps still taking photons
    std::vector<uint64_t> attempts_, interactions_;  ///< per stream
    std::vector<std::array<Pair, 3>> pairs_;
    std::array<std::vector<uint16_t>, 3> photon_stream_;  ///< each stored photon's stream
    std::vector<uint16_t> beam_stream_;                   ///< each stored beam's stream
    uint64_t cap_ = 0;
    bool volume_rule_ = false;  ///< the volume attempts rule set the cap
    bool global_checked_ = false;
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
