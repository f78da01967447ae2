#pragma once
// One run, resolved once (docs/design.md, Pipeline): the scene file (SceneDesc, its keys and
// nothing else) becomes the method that runs and why, its iteration schedule, the photon budgets,
// the keys set by rule, and the share of tiles this process renders. Every stage takes its slice;
// the Plan, the report's `settings` (what ran) and the checkpoint fingerprint print from it.
// Pure functions of the description: deterministic.

#include "photon/photon_settings.h"
#include "render/batches.h"
#include "render/tiles.h"
#include "scene/plan.h"
#include "scene/scene_desc.h"

#include <nlohmann/json_fwd.hpp>

#include <cstdint>
#include <string>
#include <vector>

namespace fogmap {

/// How camera samples are estimated (docs/design.md, Choosing an integrator).
enum class Method {
    Path,    ///< the unbiased volumetric path tracer
    Guided,  ///< the path tracer, split and guided in media by the volume map (unbiased)
    MapEnd,  ///< photon: camera paths traced as the path tracer does, ended in the volume map
    Gather,  ///< photon: camera rays march and gather every map (layered film)
};

/// "path", "guided", "photon" (both photon methods: the scene key's name).
const char* integrator_name(Method m);
/// What the method does, for messages: "the path tracer", "photon mapping with camera paths
/// ending in the volume map", ...
const char* describe(Method m);

struct RunSetup {
    /// The scene's keys as they run: render.integrator named (never auto), and the keys set by
    /// rule filled in — volume.gather_depth (auto's), volume.k, photons.volume, render.spp and
    /// advanced.iteration_spp (an iteration's), progressive.iterations (the schedule's),
    /// render.adaptive (adaptive_sampling's).
    SceneDesc run;
    Method method = Method::Path;
    std::string reason = "scene";  ///< why this method: "scene", or auto's rule
    /// Iterations summed into one film: of shrinking radii (photon methods), of fresh samples
    /// (path, guided).
    bool progressive = false;
    std::string schedule;  ///< why the iterations are as they are; "" for one plain iteration
    /// Adaptive sampling across iterations (measured_iterations): iterations 1 .. measured take
    /// render.spp in every pixel, every later one their measure's counts (IterationMeasure); 0
    /// for a plain render (render.adaptive: adaptive_sampling) or without it.
    int measured = 0;
    /// Settings keys the scene sets (away from their defaults) that this method does not read.
    std::vector<std::string> ignored;
    PhotonSettings photons;  ///< the photon pass's budgets and closing rules
    TileShare tiles;         ///< the tiles this process renders (MPI ranks, --part)
    Plan plan;               ///< the maps and passes this run needs, and why

    /// The photon integrator's methods (the others trace no photon maps).
    bool photon() const { return method == Method::MapEnd || method == Method::Gather; }
    /// Samples read the photon maps in photon batches, so that the film measures their radii's
    /// bias (render/volume_map_end.h, PhotonBatches, RadiusBias) and, in a plain run, whose maps
    /// serve every sample, their noise (a progressive run's batches are iterations with maps of
    /// their own, and its sum keeps the bias alone: FixedFilm::bias); every lookup of the photon
    /// gather must be able to (PhotonIntegrator::batches_supported).
    bool photon_batches() const;
    /// What iteration i's film keeps of them: none, or the maps' noise and bias, or in a run of
    /// iterations their bias alone (the sum keeps no noise of one iteration's maps) but in its
    /// first iteration where first_iteration_estimate holds.
    PhotonParts photon_parts(int i) const;
    /// Whether a run of iterations that ends after its first states that iteration's own error
    /// estimate, as a plain render does (the sum of one iteration has one batch): where it may
    /// end there (a time budget, or one iteration) and the film holds all its noise (the path
    /// tracers', or the photon methods' that read their maps in batches).
    bool first_iteration_estimate() const;
    /// Sets the reason, and the Plan's integrator line with it (and the schedule's, and whether
    /// adaptive sampling runs).
    void set_reason(std::string why);
    /// This process renders `share` of the tiles: without ranks to share adaptive sampling's
    /// image-wide sums with (--part), every pixel takes render.spp.
    void share_tiles(TileShare share);
};

/// Resolves `desc` (validated): auto's rules, then the schedule, the budgets and the keys set by
/// rule, in that order (the budgets follow an iteration's samples). Never throws.
RunSetup resolve_run(const SceneDesc& desc);

/// `file` resolved with `integrator` named (auto's path tracer for a target its photon run's bias
/// put out of reach) at the volume gather depth
/// `chosen` (auto's resolution of it) took, with `reason`.
RunSetup resolve_picked(const SceneDesc& file, const RunSetup& chosen, Integrator integrator,
                        std::string reason);

/// What render.integrator = "auto" picks, with the measured reason, in this order:
/// - photon when a glass or mirror surface and a diffuse one meet a point, spot or small sun
///   (angular radius below 1°): the caustics these cast are paths the path tracers cannot sample;
/// - photon when a point or spot light shines in a medium;
/// - photon when a medium emits;
/// - for any other scene with media (smoke and clouds under sun, sky or area lights), photon with
///   camera paths ending in the volume map (volume.gather_depth kAutoGatherDepth, unless the
///   scene sets a depth or asks for photon beams);
/// - path when there is no medium.
/// Sets setup->run.render.integrator (and gather_depth) and reason. A named integrator is
/// kept with the reason "scene".
void choose_integrator(RunSetup* setup);

/// The vertex at which auto's camera paths end in the volume map (docs/measurements.md).
inline constexpr int kAutoGatherDepth = 3;

/// The method that runs `desc`, whose integrator is named: photon with volume.gather_depth >= 1
/// is MapEnd, photon otherwise Gather.
Method method_of(const SceneDesc& desc);

/// The rules below take a description whose integrator is named (not auto).

/// Camera paths ending in the volume map with photons.max_emitted 0: the attempts at which the
/// volume map closes, kVolumeAttemptsPerSample per camera sample and at least its budget
/// (photon/photon_pass.h); otherwise 0 (no such rule).
uint64_t volume_attempts(const SceneDesc& desc);

/// The most photons volume_budget asks for (168 MB of photons).
inline constexpr uint64_t kVolumeRuleMaxPhotons = uint64_t(1) << 23;

/// The volume map's budget: with the attempts rule on and photons.volume not given, as many
/// photons as attempts, at most kVolumeRuleMaxPhotons (the rule alone then closes the map);
/// otherwise photons.volume (kDefaultVolumePhotons when not given).
uint64_t volume_budget(const SceneDesc& desc);

/// How a photon render takes its camera samples: iterations of `spp` samples per pixel.
struct IterationSize {
    int spp = 1;
    int iterations = 1;  ///< a progressive run's: progressive.iterations (0: by time budget)
    std::string reason;  ///< for the Plan; "" for a plain render of one iteration
};

/// The most iterations a run with progressive.target_relmse and no other budget takes.
inline constexpr int kTargetIterations = 4096;

/// Camera samples an iteration takes at least where the volume map's photons follow the samples
/// (the attempts rule's budget): smaller iterations repeat the per-iteration work too often,
/// larger maps cost more than their photons (docs/measurements.md, Progressive photon mapping).
inline constexpr uint64_t kIterationSamples = uint64_t(1) << 20;

/// Samples a pixel a progressive photon gather's iteration takes at least where no medium emits:
/// its photon pass and its map lookups (advanced.map_spp a pixel, however many samples) are the
/// iteration's own and the rest of its samples cheap, and adaptive sampling allocates from here
/// (four map steps). Where a medium emits, the maps' photons carry the light and more of them a
/// sample pay instead (docs/measurements.md, An iteration's size).
inline constexpr int kGatherIterationSpp = 16;

/// For the photon methods. A progressive run: iterations of advanced.iteration_spp when the scene
/// sets it; else, under the attempts rule with photons.volume not given, of the least multiple of
/// render.spp that gives kIterationSamples camera samples; else, for the photon gather where no
/// medium emits, of the least multiple of render.spp that gives kGatherIterationSpp; else of
/// render.spp. A plain render of N = render.spp: advanced.iteration_spp given,
/// ceil(N / advanced.iteration_spp) iterations of it; else, under the attempts rule with
/// N x pixels >= 2 kIterationSamples, I = floor(N x pixels / kIterationSamples) iterations of
/// ceil(N / I) spp; else one iteration of N.
IterationSize iteration_size(const SceneDesc& desc);

/// The volume map's k: with camera paths ending in it, volume.k not given and a medium whose phase
/// function is peaked (media/phase.h, peaked_phase: it weighs few of the photons gathered), twice
/// the default; otherwise volume.k (its default when not given).
int volume_k(const SceneDesc& desc);

/// The consecutive samples of a pixel that make one unit of its estimate when `method` renders
/// `desc` (render_film's `unit`): the photon gather's map step (one sample of each unit reads the
/// maps: photon_integrator.h, map_step), the path tracer's strata groups otherwise (strata_unit).
int sample_unit(const SceneDesc& desc, Method method);

/// Whether render.adaptive applies to a plain render of `desc` by `method`, or to a measured
/// iteration of a run of them (render.spp an iteration's): render.spp enough to leave a first pass
/// of whole units (sample_unit) something to allocate (first_pass_spp).
bool adaptive_sampling(const SceneDesc& desc, Method method);

/// Adaptive sampling across a run of iterations (render.adaptive; render.spp an iteration's):
/// the first ceil(kAdaptiveMinSpp / render.spp) iterations measure every pixel alike and each
/// later one takes the work of a uniform iteration where they show the error (one measure of at
/// least kAdaptiveMinSpp samples a pixel, and no first pass in every iteration: docs/design.md,
/// Adaptive sampling). Their count; 0 for a plain render or without render.adaptive. Not of the
/// run's iteration count, so that a run resumed with more iterations measured the same ones.
int measured_iterations(const SceneDesc& desc, bool progressive);

/// resolve_run(desc).plan.
Plan make_plan(const SceneDesc& desc);

/// The settings that ran, every key but the camera, lights, materials, shapes and media, with
/// the method's name in render.integrator.
nlohmann::json settings_json(const RunSetup& setup);

/// FNV-1a of what a resumed progressive run must share with its checkpoint: the resolved run
/// without progressive.iterations, progressive.time_budget, progressive.target_relmse,
/// render.threads and render.adaptive.
uint64_t resumable_fingerprint(const RunSetup& setup);

}  // namespace fogmap
