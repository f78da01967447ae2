#include "render/pipeline.h"

#include "core/parallel.h"
#include "core/rng.h"
#include "core/timer.h"

#include <nlohmann/json.hpp>
#include "photon/photon_pass.h"
#include "render/gather_params.h"
#include "render/metrics.h"
#include "render/path_tracer.h"
#include "render/photon_integrator.h"
#include "scene/plan.h"
#include "scene/scene.h"
#include "scene/scene_desc_json.h"

#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <utility>

namespace fogmap {

namespace {

/// One report entry per map built (global, caustic, volume order).
std::vector<MapReport> map_reports(const PhotonMaps& maps) {
    std::vector<MapReport> out;
    const std::pair<const char*, const std::optional<PhotonMap>*> named[] = {
        {"global", &maps.global}, {"caustic", &maps.caustic}, {"volume", &maps.volume}};
    for (const auto& [name, map] : named)
        if (*map)
            out.push_back({name, (*map)->tree.size(), (*map)->emitted, (*map)->tree.bytes(),
                           (*map)->build_s, (*map)->stopped});
    return out;
}

void warn(Report* report, const std::string& text) {
    std::fprintf(stderr, "fogmap: warning: %s\n", text.c_str());
    report->warnings.push_back(text);
}

/// The guide's settings: its radius is the volume gather's.
GuideSettings guide_settings(const GatherParams& gather) {
    GuideSettings g;
    g.radius = gather.volume.radius;
    return g;
}

}  // namespace

uint64_t iteration_seed(uint64_t seed, int i, bool progressive) {
    return progressive ? mix64(seed * 0x9E3779B97F4A7C15ull + static_cast<uint64_t>(i)) : seed;
}

PipelineResult run_pipeline(const SceneDesc& scene_desc, bool quiet, const Image* reference) {
    const SceneDesc desc = choose_integrator(scene_desc);
    PipelineResult out;
    Report& report = out.report;
    const Timer timer;
    Plan plan = make_plan(desc);
    const std::unique_ptr<const Scene> scene = load_scene(desc);
    add_phase(&report, "load", timer.seconds());
    describe_volume_light(*scene, &plan.volume_light);
    report.plan_text = plan_text(plan);
    report.plan = plan_json(plan);
    if (!quiet) std::fprintf(stderr, "%s", report.plan_text.c_str());

    const ThreadLimit threads(desc.render.threads);
    const bool photon = desc.render.integrator == Integrator::Photon;
    const bool guided = desc.render.integrator == Integrator::Guided;
    const bool progressive = photon && desc.progressive.enabled();
    const bool quiet_pass = quiet || progressive;  // progressive runs print one line per iteration
    std::optional<GatherParams> first_gather;
    for (int i = 1;; ++i) {
        RenderSettings settings = desc.render;
        settings.seed = iteration_seed(desc.render.seed, i, progressive);
        IterationReport it;
        it.index = i;
        RenderStats stats;
        if (photon || guided) {
            PhotonPassResult pass =
                trace_photons(*scene, plan, desc.photons, desc.march, settings.seed, quiet_pass);
            if (i == 1) {
                for (const std::string& w : pass.warnings) warn(&report, w);
                for (const StreamReport& s : pass.streams)
                    report.streams.push_back(
                        {{"name", s.name},
                         {"attempts", s.attempts},
                         {"photons", s.photons},
                         {"media_share", s.photons > 0 ? double(s.met_media) / s.photons : 0.0},
                         {"longest_path", s.longest},
                         {"stored",
                          {{"global", s.stored[0]},
                           {"caustic", s.stored[1]},
                           {"volume", s.stored[2]}}}});
            }
            add_phase(&report, "photon pass", pass.time_s);
            report.photons_emitted += pass.emitted;
            report.photons_capped += pass.capped;
            report.photons_capped_power += pass.capped_power;
            const PhotonMaps maps = build_trees(std::move(pass));
            const std::vector<MapReport> built = map_reports(maps);
            for (const MapReport& m : built) {
                add_phase(&report, "build " + m.name, m.build_s);
                it.photon_bytes += m.bytes;
            }
            if (i == 1) {
                report.maps = built;  // one iteration's maps: the memory held at any time
                first_gather = gather_params(desc, *scene, maps, progressive);
            }
            const GatherParams gather =
                gather_at_iteration(*first_gather, i, desc.progressive.alpha);
            it.radii = {gather.global.radius, gather.caustic.radius, gather.volume.radius};
            if (guided) {
                std::optional<VolumeGuide> guide;
                if (maps.volume) guide.emplace(*maps.volume, guide_settings(gather));
                out.film.add(
                    render_path(*scene, settings, quiet_pass, &stats, guide ? &*guide : nullptr));
            } else {
                double precompute_s = 0.0;
                out.film.add(render_photon(*scene, maps, gather, desc.march, settings, quiet_pass,
                                           &stats, &precompute_s));
                if (precompute_s > 0.0) add_phase(&report, "precompute", precompute_s);
            }
        } else {
            out.film.add(render_path(*scene, settings, quiet_pass, &stats));
        }
        add_phase(&report, "render", stats.render_s);
        report.samples += stats.samples;
        report.rays += stats.rays;
        report.nonfinite += stats.nonfinite;
        report.depth_capped += stats.capped;
        report.render_s += stats.render_s;
        report.threads = stats.threads;
        it.elapsed_s = timer.seconds();
        if (reference) {
            Image mean = out.film.beauty;
            for (Color& c : mean.pixels) c *= 1.0f / static_cast<float>(i);
            it.rel_mse = image_error(mean, *reference).rel_mse;
        }
        report.iterations.push_back(it);
        if (progressive && !quiet)
            std::fprintf(stderr, "progressive: iteration %d, %.1f s, radii %.4g %.4g %.4g%s\n", i,
                         it.elapsed_s, it.radii.global, it.radii.caustic, it.radii.volume,
                         reference ? (", relMSE " + std::to_string(it.rel_mse)).c_str() : "");
        const ProgressiveDesc& p = desc.progressive;
        if (!progressive || (p.iterations > 0 && i >= p.iterations) ||
            (p.time_budget > 0.0f && timer.seconds() >= p.time_budget))
            break;
    }
    if (report.samples > 0 && report.depth_capped > report.samples / 1000) {
        char text[200];
        std::snprintf(text, sizeof text,
                      "render.max_depth = %d cut %.2g%% of the camera samples while they still "
                      "carried light; raise it (the image misses that light)",
                      desc.render.max_depth, 100.0 * double(report.depth_capped) / report.samples);
        warn(&report, text);
    }
    const int n = static_cast<int>(report.iterations.size());
    if (n > 1) out.film.scale(1.0f / static_cast<float>(n));
    if (report.nonfinite > 0)
        warn(&report, std::to_string(report.nonfinite) + " of " + std::to_string(report.samples) +
                          " camera samples were not finite (NaN or infinite) and were dropped; "
                          "the pixels they fell in are darker");
    report.scene = desc.path;
    report.settings = settings_json(desc);
    report.width = out.film.beauty.width;
    report.height = out.film.beauty.height;
    report.spp = desc.render.spp * n;
    report.photons_capped_power /= n;  // the mean share over iterations
    report.mean = out.film.beauty.mean();
    return out;
}

}  // namespace fogmap
