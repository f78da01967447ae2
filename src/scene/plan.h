#pragma once
// Plan: which maps and passes a scene needs, and why (DESIGN.md, Pipeline). A pure function of
// the validated SceneDesc, computed before any resource is loaded; each item is a bool and a
// one-line reason that the report prints. Passes test their item first and skip (no time, no
// memory) when it is off. Plain data; thread-safe to read.

#include "scene/scene_desc.h"

#include <nlohmann/json_fwd.hpp>

#include <string>

namespace fogmap {

struct Scene;

/// One decision of the plan: on or off, and a one-line reason ("no specular surface").
struct PlanItem {
    bool on = false;
    std::string reason;
    /// `if (!plan.caustic_map) return;` reads as the decision.
    explicit operator bool() const { return on; }
};

/// The rules make_plan applies, in this order for each map (the first that fails is the reason):
/// - embree_scene: at least one shape or quad light, else "no surfaces".
/// - ray_marching: at least one medium ("no medium") and render.integrator = photon ("integrator
///   is path: media use delta tracking"); the reason says how photon free paths are found
///   (march.method).
/// - every map: render.integrator = photon ("integrator is path"), then a light that emits: its
///   intensity (point, spot), radiance (quad, environment) or irradiance (sun) has a channel > 0
///   ("no light emits power").
/// - volume_map: a medium ("no participating medium") with a sigma_s channel > 0 and
///   density_scale > 0 ("media do not scatter"), then photons.volume > 0 ("photons.volume = 0").
/// - global_map: a shape with a diffuse material whose albedo has a channel > 0 ("no diffuse
///   surface"), then photons.global > 0.
/// - caustic_map: a shape made of glass or of a mirror with albedo > 0 ("no specular surface"),
///   a diffuse shape as above ("no diffuse surface to receive caustics"), photons.caustic > 0.
/// Reachability: any emitting light is taken to reach every surface and medium. Occlusion is not
/// traced (the plan comes before Embree and OpenVDB are loaded); a specular surface that no
/// light sees gets a caustic map that stays empty, which costs shooting time but is correct.
struct Plan {
    /// The integrator (on) and why: the scene's choice, or what auto picked.
    PlanItem integrator;
    const char* integrator_name = "photon";
    PlanItem embree_scene;
    PlanItem ray_marching;
    PlanItem volume_light;
    PlanItem volume_map;
    PlanItem global_map;
    PlanItem caustic_map;
};

/// What render.integrator = "auto" picks, with the measured reason (README, "Choosing an
/// integrator"), in this order:
/// - photon when a glass or mirror surface and a diffuse one meet a point, spot or small sun
///   (angular radius below 1°): the caustics these cast are paths the path tracers cannot sample;
/// - photon when a point or spot light shines in a medium (fog.json: the volume map had 4× lower
///   error than the path tracer at equal time);
/// - photon when a medium emits (fire.json: the photon maps had 3-8x lower error than the path
///   tracer at equal time; the path tracer finds the fire only by phase and BSDF sampling);
/// - for any other scene with media (smoke and clouds under sun, sky or area lights), photon with
///   camera paths ending in the volume map (volume.gather_depth kAutoGatherDepth, unless the
///   scene sets a depth or asks for photon beams) and render.auto_media: once the media are
///   loaded, a pilot of photon, path and guided decides (render/pilot.h);
/// - path when there is no medium.
/// `desc` unchanged when its integrator is not auto; else a copy with the choice and its reason
/// (render.auto_reason). Never throws.
SceneDesc choose_integrator(SceneDesc desc);

/// The vertex at which auto's camera paths end in the volume map: 3 beat 2 on smoke1 and
/// the Disney cloud (relMSE 0.70 and 0.30 of the path tracer's at 1 s against 0.78 and 0.51) and
/// tied on smoke.json (0.58 against 0.56).
inline constexpr int kAutoGatherDepth = 3;

/// The plan for `desc` (assumed validated; shapes naming unknown materials count as nothing),
/// after choose_integrator. Never throws.
Plan make_plan(const SceneDesc& desc);

/// Camera paths ending in the volume map with photons.max_emitted 0: the attempts at which the
/// volume map closes, kVolumeAttemptsPerSample per camera sample and at least photons.volume
/// (photon/photon_pass.h); otherwise 0 (no such rule).
uint64_t volume_attempts(const SceneDesc& desc);

/// The volume map's budget: with the attempts rule on (volume_attempts > 0) and photons.volume not
/// given by the scene, as many photons as attempts, at most kVolumeRuleMaxPhotons — the rule alone
/// closes the map unless the medium stores more than a photon per attempt (on the Disney cloud
/// over the ground 0.9 per attempt: the default 100 000 filled at 40% of the rule's attempts and
/// left the map's noise half the image's); otherwise photons.volume.
uint64_t volume_budget(const SceneDesc& desc);

/// How a photon render takes its camera samples: iterations of `spp` samples per pixel.
struct IterationSize {
    int spp = 1;
    int iterations = 1;  ///< a progressive run's: progressive.iterations (0: by time budget)
    std::string reason;  ///< for the Plan; "" for a plain render of one iteration
};

/// Camera samples an iteration takes at least where the volume map's photons follow the samples
/// (the attempts rule's budget). Smaller iterations spend more of the time on what each iteration
/// repeats (the photon budget's floor, the grids, the trees) and start from the wider radius of a
/// sparser first map: on smoke1 and the Disney cloud over the ground (160 x 120) progressive runs
/// of 3 and 10 s had 0.54-0.63 of the relMSE x time of 4-spp iterations; 16 to 64 spp were within
/// 4% of 2^20 samples, 256 overshot the budget by an iteration and lost 1.06-1.41x. Larger maps
/// cost more than their photons: one iteration of 384 spp of the cloud and 512 of smoke1 (1.8 and
/// 2.5 million photons) took 1.28x and 1.11-1.15x the CPU time of 7 and 9 iterations of the same
/// samples and photons, for 0.97x and 1.07x their relMSE (README, "Progressive photon mapping").
inline constexpr uint64_t kIterationSamples = uint64_t(1) << 20;

/// For the photon integrator. A progressive run: iterations of progressive.spp when the scene
/// sets it; else, where the volume map's budget is the attempts rule's (volume_attempts > 0,
/// photons.volume not given), of the least multiple of render.spp that gives kIterationSamples
/// camera samples; else of render.spp (the balance with the scene's photon budgets is the
/// scene's). A plain render of N = render.spp: progressive.spp given, ceil(N / progressive.spp)
/// iterations of it; else, under the attempts rule with N x pixels >= 2 kIterationSamples,
/// I = floor(N x pixels / kIterationSamples) iterations of ceil(N / I) spp (progressive photon
/// mapping's: the radius shrinks over them); else one iteration of N.
IterationSize iteration_size(const SceneDesc& desc);

/// The most photons volume_budget asks for (168 MB of photons).
inline constexpr uint64_t kVolumeRuleMaxPhotons = uint64_t(1) << 23;

/// The volume map's k: with camera paths ending in it, volume.k not given by the scene and a
/// medium whose |g| is above kMomentGridMaxG (its lookups search the kd-tree), twice volume.k —
/// a peaked phase function weighs few of the gathered photons (for light from every direction
/// the effective count is (1 - g^2)^2 / (1 + g^2) of them: 0.61 at g 0.4, 0.08 at 0.8, 0.045
/// at 0.85); otherwise volume.k.
int volume_k(const SceneDesc& desc);

/// After load_scene: the volume light's reason becomes each emitter's source and power
/// ("medium 0: blackbody from grid 'temperature' (found in the file), 2.1 W"); when off, a medium
/// whose file has an emission grid it does not use is named, with how to use it.
void describe_volume_light(const Scene& scene, PlanItem* item);

/// Seven lines, each ending in '\n', in pipeline order: "integrator: path (scene)",
/// "Embree scene: built (2 shapes)", "ray marching: used (...)", "volume light: skipped (...)",
/// "volume map: built (...)",
/// "global map: ...", "caustic map: skipped (no specular surface)".
std::string plan_text(const Plan& plan);

/// {"integrator": {"on": true, "reason": "..."}, "embree_scene": ..., "ray_marching": ...,
/// "volume_light": ..., "volume_map": ..., "global_map": ..., "caustic_map": ...} for the report's
/// JSON output.
nlohmann::json plan_json(const Plan& plan);

}  // namespace fogmap
