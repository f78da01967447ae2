#pragma once
// Plan: which maps and passes a run needs, and why (docs/design.md, Pipeline). Made from the
// resolved run before any resource is loaded (render/run_setup.h, make_plan); each item is a bool
// and a one-line reason that the report prints. Passes test their item first and skip (no time,
// no memory) when it is off. Plain data; thread-safe to read.

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

/// The rules make_plan (render/run_setup.h) applies, in this order for each map (the first that
/// fails is the reason):
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
