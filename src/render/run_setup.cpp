#include "render/run_setup.h"

#include "core/hash.h"
#include "core/world_range.h"
#include "media/phase.h"
#include "render/film.h"
#include "render/path_tracer.h"
#include "render/photon_integrator.h"
#include "render/sun_shadows.h"
#include "render/volume_map_end.h"
#include "scene/scene_desc_json.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <string>
#include <utility>
#include <vector>

namespace fogmap {

namespace {

/// "1 shape", "3 shapes", "2 media".
std::string count(size_t n, const char* one, const char* many) {
    return std::to_string(n) + " " + (n == 1 ? one : many);
}

PlanItem on(std::string reason) { return PlanItem{true, std::move(reason)}; }
PlanItem off(std::string reason) { return PlanItem{false, std::move(reason)}; }

/// The power-carrying quantity of each light type (a light with zero power emits nothing).
bool emits(const LightDesc& l) {
    switch (l.type) {
        case LightType::Point:
        case LightType::Spot:
            return max_component(l.intensity) > 0.0f;
        case LightType::Quad:
        case LightType::Environment:
            return max_component(l.radiance) > 0.0f;
        case LightType::Sun:
            return max_component(l.irradiance) > 0.0f;
    }
    return false;
}

bool scatters(const MediumDesc& m) {
    return max_component(m.sigma_s) > 0.0f && m.density_scale > 0.0f;
}

bool is_diffuse(const MaterialDesc& m) {
    return m.type == MaterialType::Diffuse && max_component(m.albedo) > 0.0f;
}

/// Glass always passes light on; a mirror only if it reflects some of it.
bool is_specular(const MaterialDesc& m) {
    switch (m.type) {
        case MaterialType::Diffuse:
            return false;
        case MaterialType::Mirror:
            return max_component(m.albedo) > 0.0f;
        case MaterialType::Glass:
            return true;
    }
    return false;
}

/// Shapes whose material satisfies `pred`; unknown materials count as nothing.
template <class Pred>
size_t count_shapes(const SceneDesc& desc, Pred pred) {
    size_t n = 0;
    for (const ShapeDesc& s : desc.shapes) {
        const auto it = desc.materials.find(s.material);
        if (it != desc.materials.end() && pred(it->second)) ++n;
    }
    return n;
}

std::string budget(uint64_t photons) { return "budget " + std::to_string(photons) + " photons"; }

PlanItem plan_embree(const SceneDesc& desc) {
    size_t quad_lights = 0;
    for (const LightDesc& l : desc.lights) quad_lights += l.type == LightType::Quad ? 1 : 0;
    if (desc.shapes.empty() && quad_lights == 0) return off("no surfaces");
    std::string reason;
    if (!desc.shapes.empty()) reason = count(desc.shapes.size(), "shape", "shapes");
    if (quad_lights > 0) {
        reason += (reason.empty() ? "" : ", ") + count(quad_lights, "quad light", "quad lights");
    }
    return on(reason);
}

PlanItem plan_marching(const SceneDesc& desc) {
    if (desc.media.empty()) return off("no medium");
    if (desc.render.integrator == Integrator::Path) {
        return off("integrator is path: media use delta tracking");
    }
    if (desc.render.integrator == Integrator::Guided) {
        return on(count(desc.media.size(), "medium", "media") +
                  "; photon free paths march, camera paths use delta tracking");
    }
    // march.method picks how photons find free paths (photon beams need exact ones: delta
    // tracking); camera rays of this integrator march unless they end in the volume map.
    const char* how = "";
    if (desc.volume.gather_depth > 0) {
        // render/sun_shadows.h: suns up to 1° wide, when every medium is a grid.
        bool sun = false, grids = desc.volume.sun_grid > 0.0f;
        for (const LightDesc& l : desc.lights)
            sun = sun || (l.type == LightType::Sun && l.angular_radius_deg <= kSunGridMaxRadiusDeg);
        for (const MediumDesc& m : desc.media) grids = grids && m.type == MediumType::Vdb;
        const std::string sun_shadows =
            sun && grids ? ", take the sun's transmittance from a grid of optical depth along it "
                           "(nodes advanced.sun_grid = " +
                               g_text(desc.volume.sun_grid) +
                               (desc.volume.sun_grid == 1.0f ? " voxel" : " voxels") + " apart)"
                         : "";
        return on(count(desc.media.size(), "medium", "media") + "; photon free paths " +
                  (desc.march.method == FreePathMethod::March ? "march" : "use delta tracking") +
                  ", camera paths use ratio tracking (first segment) and delta tracking" +
                  sun_shadows + " and end in the volume map");
    }
    if (desc.volume.estimator == VolumeEstimator::PhotonBeams)
        return on(count(desc.media.size(), "medium", "media") +
                  "; camera rays march, photon free paths use delta tracking (photon beams)");
    switch (desc.march.method) {
        case FreePathMethod::March:
            how = "camera rays and photon free paths march";
            break;
        case FreePathMethod::Delta:
            how = "camera rays march, photon free paths use delta tracking";
            break;
    }
    return on(count(desc.media.size(), "medium", "media") + "; " + how);
}

PlanItem plan_volume_light(const SceneDesc& desc) {
    size_t n = 0;
    for (const MediumDesc& m : desc.media) {
        if (!m.emission || !(m.density_scale > 0.0f) || !(m.emission->scale > 0.0f)) continue;
        // A blackbody's colour comes from its temperatures, known once the grid is read.
        if (m.emission->kind != EmissionSource::Blackbody &&
            !(max_component(m.emission->color) > 0.0f))
            continue;
        ++n;
    }
    if (n == 0) return off("no medium emits");
    return on(count(n, "emissive medium", "emissive media"));
}

PlanItem plan_volume(const SceneDesc& desc) {
    if (desc.media.empty()) return off("no participating medium");
    size_t scattering = 0;
    for (const MediumDesc& m : desc.media) scattering += scatters(m) ? 1 : 0;
    if (scattering == 0) return off("media do not scatter");
    if (desc.photons.volume_or_default() == 0) return off("photons.volume = 0");
    const uint64_t n = volume_budget(desc);
    return on(count(scattering, "scattering medium", "scattering media") + ", " + budget(n) +
              (n == desc.photons.volume_or_default()
                   ? ""
                   : " (a photon per attempt: photons.volume not set)"));
}

PlanItem plan_global(const SceneDesc& desc, size_t diffuse) {
    if (diffuse == 0) return off("no diffuse surface");
    if (desc.photons.global == 0) return off("photons.global = 0");
    return on(count(diffuse, "diffuse shape", "diffuse shapes") + ", " +
              budget(desc.photons.global));
}

PlanItem plan_caustic(const SceneDesc& desc, size_t diffuse) {
    const size_t specular = count_shapes(desc, is_specular);
    if (specular == 0) return off("no specular surface");
    if (diffuse == 0) return off("no diffuse surface to receive caustics");
    if (desc.photons.caustic == 0) return off("photons.caustic = 0");
    return on(count(specular, "specular shape", "specular shapes") + ", " +
              count(diffuse, "diffuse receiver", "diffuse receivers") + ", " +
              budget(desc.photons.caustic));
}

/// Every medium's |g| lets the volume map's lookups read its grid of moments (media/phase.h).
bool moments_fit(const SceneDesc& desc) {
    return std::all_of(desc.media.begin(), desc.media.end(),
                       [](const MediumDesc& m) { return fits_moment_grid(m.g); });
}

/// The plan of `desc`, its integrator named (the integrator item's reason is the caller's).
Plan plan_for(const SceneDesc& desc) {
    Plan plan;
    plan.integrator.on = true;
    plan.integrator_name = to_string(desc.render.integrator);
    plan.embree_scene = plan_embree(desc);
    plan.ray_marching = plan_marching(desc);
    plan.volume_light = plan_volume_light(desc);

    // Conditions shared by all maps come first, so their reason is the same for the three.
    bool any_emits = plan.volume_light.on;
    for (const LightDesc& l : desc.lights) any_emits = any_emits || emits(l);
    if (desc.render.integrator == Integrator::Path) {
        plan.volume_map = plan.global_map = plan.caustic_map = off("integrator is path");
    } else if (!any_emits) {
        plan.volume_map = plan.global_map = plan.caustic_map = off("no light emits power");
    } else if (desc.render.integrator == Integrator::Guided) {
        plan.volume_map = plan_volume(desc);
        if (plan.volume_map)
            plan.volume_map.reason += "; camera paths split in media by its light to come";
        plan.global_map = plan.caustic_map = off("integrator is guided: only media are guided");
    } else if (desc.volume.gather_depth > 0) {
        const int d = desc.volume.gather_depth;
        plan.volume_map = plan_volume(desc);
        char kd_tree[64];
        std::snprintf(kd_tree, sizeof kd_tree,
                      ", looked up in its kd-tree (a medium's |g| above %g)",
                      double(kMomentGridMaxG));
        std::string lookup =
            moments_fit(desc) ? ", looked up from a grid of its photons' moments" : kd_tree;
        const int k = volume_k(desc);
        if (desc.volume.radius <= 0.0f)  // render/volume_map_end.h, AdaptiveRadius
            lookup += " (where more than " + std::to_string(2 * k) +
                      " fall within its radius, within a smaller one holding about " +
                      (k == desc.volume.k_or_default()
                           ? "volume.k = " + std::to_string(k)
                           : std::to_string(k) + " (twice volume.k for a peaked phase function)") +
                      ")";
        std::string at = "at the medium vertex that is their vertex " + std::to_string(d) +
                         " (diffuse bounces count)";
        if (desc.volume.gather_tau > 0.0f) {  // render/volume_map_end.h, FineEnough
            char tau[160];
            std::snprintf(tau, sizeof tau,
                          " or the first after it where its ball spans at most advanced.gather_tau "
                          "= %g scattering mean free paths (by vertex %d)",
                          double(desc.volume.gather_tau), kLatestEndFactor * d);
            at += tau;
        }
        if (const uint64_t n = volume_attempts(desc))
            lookup += "; it closes after " + std::to_string(n) + " photon attempts (" +
                      g_text(kVolumeAttemptsPerSample) +
                      " per camera sample, at least its budget) if not full before";
        if (plan.volume_map) plan.volume_map.reason += "; camera paths end in it " + at + lookup;
        plan.global_map = plan.caustic_map =
            off("volume.gather_depth " + std::to_string(d) + ": camera paths trace surfaces");
    } else {
        const size_t diffuse = count_shapes(desc, is_diffuse);
        plan.volume_map = plan_volume(desc);
        plan.global_map = plan_global(desc, diffuse);
        plan.caustic_map = plan_caustic(desc, diffuse);
    }
    return plan;
}

}  // namespace

void choose_integrator(RunSetup* setup) {
    SceneDesc& desc = setup->run;
    if (desc.render.integrator != Integrator::Auto) return;
    auto small = [](const LightDesc& l) {
        return (l.type == LightType::Point || l.type == LightType::Spot ||
                (l.type == LightType::Sun && l.angular_radius_deg < 1.0f)) &&
               emits(l);
    };
    bool small_light = false, point_light = false;
    for (const LightDesc& l : desc.lights) {
        small_light = small_light || small(l);
        point_light =
            point_light || ((l.type == LightType::Point || l.type == LightType::Spot) && emits(l));
    }
    const bool caustics =
        count_shapes(desc, is_specular) > 0 && count_shapes(desc, is_diffuse) > 0 && small_light;
    if (caustics) {
        desc.render.integrator = Integrator::Photon;
        setup->reason =
            "auto: glass or mirrors lit by a point, spot or small sun cast caustics only the "
            "caustic map renders";
    } else if (point_light && !desc.media.empty()) {
        desc.render.integrator = Integrator::Photon;
        setup->reason =
            "auto: a point or spot light in a medium, where the volume map measured 4x lower "
            "error than the path tracer at equal time (fog.json)";
    } else if (plan_volume_light(desc).on) {
        desc.render.integrator = Integrator::Photon;
        setup->reason =
            "auto: an emitting medium lights the scene, where the photon maps measured 3-8x lower "
            "error than the path tracer at equal time (fire.json)";
    } else if (!desc.media.empty()) {
        // Unless the scene asks for photon beams, which gather along marched camera rays.
        desc.render.integrator = Integrator::Photon;
        if (desc.volume.gather_depth == 0 && desc.volume.estimator != VolumeEstimator::PhotonBeams)
            desc.volume.gather_depth = kAutoGatherDepth;
        setup->reason =
            "auto: media under sun, sky or area lights: photon, " +
            std::string(desc.volume.gather_depth == 0
                            ? "with the photon beams the scene asks for"
                            : "camera paths ending in the volume map at vertex " +
                                  std::to_string(desc.volume.gather_depth)) +
            " (at least as good as a pilot's pick of photon, path or guided on every scene "
            "measured: docs/measurements.md, Choosing an integrator)";
    } else {
        desc.render.integrator = Integrator::Path;
        setup->reason = "auto: no medium and no caustics from small lights";
    }
}

uint64_t volume_attempts(const SceneDesc& desc) {
    if (method_of(desc) != Method::MapEnd || desc.photons.max_emitted > 0) return 0;
    const double samples = double(desc.camera.width) * desc.camera.height * desc.render.spp;
    return std::max(static_cast<uint64_t>(std::ceil(kVolumeAttemptsPerSample * samples)),
                    desc.photons.volume_or_default());
}

uint64_t volume_budget(const SceneDesc& desc) {
    const uint64_t attempts = volume_attempts(desc);
    if (attempts == 0 || desc.photons.volume) return desc.photons.volume_or_default();
    return std::min(attempts, kVolumeRuleMaxPhotons);
}

IterationSize iteration_size(const SceneDesc& desc) {
    const int spp = desc.render.spp, given = desc.progressive.spp;
    const bool rule = volume_attempts(desc) > 0 && !desc.photons.volume;
    const uint64_t pixels = uint64_t(desc.camera.width) * desc.camera.height;
    const auto text = [](int n, const std::string& why) {
        return "iterations of " + std::to_string(n) + " spp (" + why + ")";
    };
    const std::string samples = "at least " + std::to_string(kIterationSamples) +
                                " camera samples, the volume map's photons following them";
    if (desc.progressive.enabled()) {
        const int iterations = desc.progressive.iterations;
        if (given > 0)
            return {given, iterations, "progressive: " + text(given, "advanced.iteration_spp")};
        const auto times_spp = [&](uint64_t times, const std::string& why) {
            const int n = static_cast<int>(std::min<uint64_t>(times * spp, uint64_t(1) << 30));
            return IterationSize{
                n, iterations,
                "progressive: " + text(n, (n == spp ? std::string("render.spp")
                                                    : "render.spp " + std::to_string(spp) +
                                                          " times " + std::to_string(times)) +
                                              ": " + why)};
        };
        if (rule) {
            const uint64_t per_spp = pixels * uint64_t(spp);
            return times_spp(std::max<uint64_t>(1, (kIterationSamples + per_spp - 1) / per_spp),
                             samples);
        }
        if (method_of(desc) == Method::Gather && spp < kGatherIterationSpp &&
            !plan_volume_light(desc).on)
            return times_spp((kGatherIterationSpp + spp - 1) / spp,
                             "at least " + std::to_string(kGatherIterationSpp) +
                                 " spp: the photon pass and the map lookups are an iteration's "
                                 "own, its other samples cheap");
        return {spp, iterations,
                "progressive: " + text(spp, "render.spp: the photon budgets are the scene's")};
    }
    const std::string split = "render.spp " + std::to_string(spp) + " as ";
    if (given > 0 && given < spp) {
        const int iterations = (spp + given - 1) / given;
        return {given, iterations,
                split + std::to_string(iterations) + " progressive " +
                    text(given, "advanced.iteration_spp")};
    }
    const uint64_t iterations = rule
                                    ? std::min<uint64_t>(pixels * uint64_t(spp) / kIterationSamples,
                                                         kMaxProgressiveIterations)
                                    : 1;
    if (given > 0 || iterations < 2) return {spp, 1, ""};
    const int n = static_cast<int>((uint64_t(spp) + iterations - 1) / iterations);
    return {n, static_cast<int>(iterations),
            split + std::to_string(iterations) + " progressive " +
                text(n, samples + "; smaller maps than one of all the samples' photons, looked up "
                                  "faster")};
}

int volume_k(const SceneDesc& desc) {
    if (method_of(desc) != Method::MapEnd || desc.volume.k) return desc.volume.k_or_default();
    const bool peaked = std::any_of(desc.media.begin(), desc.media.end(),
                                    [](const MediumDesc& m) { return peaked_phase(m.g); });
    return peaked ? 2 * kDefaultVolumeK : kDefaultVolumeK;
}

Method method_of(const SceneDesc& desc) {
    switch (desc.render.integrator) {
        case Integrator::Path:
        case Integrator::Auto:
            return Method::Path;
        case Integrator::Guided:
            return Method::Guided;
        case Integrator::Photon:
            return desc.volume.gather_depth > 0 ? Method::MapEnd : Method::Gather;
    }
    return Method::Path;
}

const char* integrator_name(Method m) {
    switch (m) {
        case Method::Path:
            return "path";
        case Method::Guided:
            return "guided";
        case Method::MapEnd:
        case Method::Gather:
            return "photon";
    }
    return "path";
}

const char* describe(Method m) {
    switch (m) {
        case Method::Path:
            return "the path tracer";
        case Method::Guided:
            return "the guided path tracer";
        case Method::MapEnd:
            return "photon mapping with camera paths ending in the volume map";
        case Method::Gather:
            return "photon mapping";
    }
    return "the path tracer";
}

bool RunSetup::photon_batches() const {
    return method == Method::MapEnd ||
           (method == Method::Gather &&
            PhotonIntegrator::batches_supported(run.volume.estimator, run.global.final_gather));
}

PhotonParts RunSetup::photon_parts(int i) const {
    if (!photon_batches()) return PhotonParts::None;
    const bool noise = !progressive || (i == 1 && first_iteration_estimate());
    return noise ? PhotonParts::NoiseAndBias : PhotonParts::Bias;
}

bool RunSetup::first_iteration_estimate() const {
    const ProgressiveDesc& p = run.progressive;
    return progressive && (p.time_budget > 0.0f || p.iterations == 1) &&
           (method == Method::Path || method == Method::Guided || photon_batches());
}

int sample_unit(const SceneDesc& desc, Method method) {
    const int spp = desc.render.spp;
    return method == Method::Gather ? map_step(spp, desc.render.map_spp) : strata_unit(spp);
}

bool adaptive_sampling(const SceneDesc& desc, Method method) {
    const int spp = desc.render.spp;
    return desc.render.adaptive && first_pass_spp(spp, sample_unit(desc, method)) < spp;
}

int measured_iterations(const SceneDesc& desc, bool progressive) {
    if (!desc.render.adaptive || !progressive) return 0;
    return (kAdaptiveMinSpp + desc.render.spp - 1) / desc.render.spp;
}

void RunSetup::share_tiles(TileShare share) {
    tiles = share;
    if (share.count > 1 && !share.ranks && run.render.adaptive) {
        run.render.adaptive = false;
        set_reason(reason);
    }
}

void RunSetup::set_reason(std::string why) {
    reason = std::move(why);
    std::string& said = plan.integrator.reason;
    said = reason + (schedule.empty() ? "" : "; " + schedule);
    const int spp = run.render.spp, iterations = run.progressive.iterations;
    // render_film's own passes (measured_spp): a plain render's, and a measured iteration's.
    const bool passes = adaptive_sampling(run, method);
    const std::string two_passes =
        "a first pass of " + std::to_string(first_pass_spp(spp, sample_unit(run, method))) +
        " spp, then the rest of " +
        (measured > 0 ? "its " + std::to_string(spp) + " spp's" : std::string("render.spp's")) +
        " work where it shows the error";
    if (measured > 0 && iterations > 0 && iterations <= measured)
        said += passes ? "; adaptive sampling: " +
                             std::string(iterations > 1 ? "in each iteration " : "") + two_passes
                       : "; adaptive sampling: none (" + std::to_string(iterations) +
                             " iterations, no more than the " + std::to_string(measured) +
                             " that would measure for the later ones)";
    else if (measured > 0)  // a first pass leaves nothing below 8 spp, where more measure
        said += "; adaptive sampling across iterations: " +
                (passes ? "iteration 1 takes " + two_passes
                        : (measured == 1
                               ? std::string("iteration 1 takes its ")
                               : "iterations 1-" + std::to_string(measured) + " take their ") +
                              std::to_string(spp) + " spp in every pixel") +
                ", every later one a uniform iteration's work where " +
                (passes ? "that first pass shows" : "they show") +
                " the error, and each pixel is the mean of all its samples";
    else if (run.render.adaptive)
        said += "; adaptive sampling: " + two_passes;
}

namespace {

/// Whether `method` reads the settings key section.key (a key of render, photons, global,
/// caustic, volume, march or progressive); keys not named here are read by every method.
bool reads(Method method, const std::string& section, const std::string& key) {
    const bool gather = method == Method::Gather, photon = gather || method == Method::MapEnd;
    if (section == "global" || section == "caustic") return gather;
    if (section == "progressive") return photon || key != "alpha";  // the others: iterations
    if (section == "march") return method != Method::Path;
    if (section == "photons")
        return (key == "global" || key == "caustic") ? gather : method != Method::Path;
    if (section == "volume") {
        if (key == "k" || key == "radius") return method != Method::Path;
        if (key == "gather_depth") return photon;
        return gather;  // estimator
    }
    if (section == "advanced") {
        if (key == "guide_vertices") return method == Method::Guided;
        if (key == "gather_tau" || key == "sun_grid") return method == Method::MapEnd;
        if (key == "iteration_spp") return photon;
        return gather;  // map_spp, lookups_per_ray, light_samples
    }
    return true;
}

/// The settings keys `desc` sets away from their defaults that `method` does not read.
std::vector<std::string> ignored_keys(const SceneDesc& desc, Method method) {
    const nlohmann::json given = settings_json(desc), defaults = settings_json(SceneDesc{});
    std::vector<std::string> out;
    for (const auto& [section, keys] : given.items())
        for (const auto& [key, value] : keys.items())
            if ((!defaults[section].contains(key) || defaults[section][key] != value) &&
                !reads(method, section, key))
                out.push_back(section + "." + key);
    return out;
}

/// The rest of resolve_run once the integrator is named: the schedule (a photon render's
/// iterations), then the budgets and the keys set by rule, which follow an iteration's samples.
/// `file`: the scene's own keys, of which those the method ignores are named.
RunSetup resolve_named(RunSetup s, const SceneDesc& file) {
    SceneDesc& d = s.run;
    s.method = method_of(d);
    s.ignored = ignored_keys(file, s.method);
    if (s.photon()) {
        const IterationSize size = iteration_size(d);
        if (d.progressive.enabled() || size.iterations > 1) {
            d.render.spp = d.progressive.spp = size.spp;
            d.progressive.iterations = size.iterations;
            s.schedule = size.reason;
        }
    } else if (d.progressive.enabled()) {
        s.schedule =
            "iterations of render.spp = " + std::to_string(d.render.spp) + " fresh samples a pixel";
    }
    // A target alone stops by its rule or at kTargetIterations: never a run without an end.
    ProgressiveDesc& p = d.progressive;
    if (p.target_relmse > 0.0f && p.iterations == 0 && p.time_budget == 0.0f) {
        p.iterations = kTargetIterations;
        s.schedule += std::string(s.schedule.empty() ? "" : "; ") + "at most " +
                      std::to_string(kTargetIterations) + " iterations to reach the target";
    }
    s.progressive = p.enabled();
    s.measured = measured_iterations(d, s.progressive);
    d.render.adaptive = s.progressive ? s.measured > 0 : adaptive_sampling(d, s.method);
    s.photons = d.photons;
    s.photons.volume_beams = s.photon() && d.volume.estimator == VolumeEstimator::PhotonBeams;
    s.photons.volume_attempts = volume_attempts(d);
    s.photons.volume = volume_budget(d);
    s.plan = plan_for(d);
    s.set_reason(s.reason);
    d.volume.k = volume_k(d);
    d.photons.volume = s.photons.volume;
    return s;
}

}  // namespace

RunSetup resolve_run(const SceneDesc& desc) {
    RunSetup s;
    s.run = desc;
    choose_integrator(&s);
    return resolve_named(std::move(s), desc);
}

RunSetup resolve_picked(const SceneDesc& file, const RunSetup& chosen, Integrator integrator,
                        std::string reason) {
    RunSetup s;
    s.run = file;
    s.run.render.integrator = integrator;
    s.run.volume.gather_depth = chosen.run.volume.gather_depth;
    s.reason = std::move(reason);
    return resolve_named(std::move(s), file);
}

Plan make_plan(const SceneDesc& desc) { return resolve_run(desc).plan; }

nlohmann::json settings_json(const RunSetup& setup) { return settings_json(setup.run); }

uint64_t resumable_fingerprint(const RunSetup& setup) {
    nlohmann::json j = to_json(setup.run);
    j["progressive"].erase("iterations");
    j["progressive"].erase("time_budget");
    j["progressive"].erase("target_relmse");
    j["render"].erase("threads");
    return fnv1a(j.dump());
}

}  // namespace fogmap
