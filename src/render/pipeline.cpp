#include "render/pipeline.h"

#include "core/timer.h"
#include "photon/photon_pass.h"
#include "render/path_tracer.h"
#include "render/progressive.h"
#include "render/tiles.h"
#include "scene/plan.h"
#include "scene/scene.h"
#include "scene/scene_desc_json.h"

#include <tbb/global_control.h>

#include <cstdio>

namespace fogmap {

LoadedScene plan_and_load(const SceneDesc& desc, bool quiet, Report* report) {
    const Timer timer;
    LoadedScene loaded{make_plan(desc), nullptr};
    report->plan_text = plan_text(loaded.plan);
    report->plan = plan_json(loaded.plan);
    if (!quiet) std::fprintf(stderr, "%s", report->plan_text.c_str());
    loaded.scene = load_scene(desc);
    report->phases_s.emplace_back("load", timer.seconds());
    return loaded;
}

std::vector<MapReport> map_reports(const PhotonMaps& maps) {
    std::vector<MapReport> out;
    const std::pair<const char*, const std::optional<PhotonMap>*> named[] = {
        {"global", &maps.global}, {"caustic", &maps.caustic}, {"volume", &maps.volume}};
    for (const auto& [name, map] : named)
        if (*map)
            out.push_back({name, (*map)->tree.size(), (*map)->emitted, (*map)->tree.bytes(),
                           (*map)->build_s});
    return out;
}

PipelineResult run_pipeline(const SceneDesc& desc, bool quiet, const Image* reference) {
    PipelineResult out;
    if (desc.progressive.enabled() && desc.render.integrator == Integrator::Photon) {
        ProgressiveResult p = run_progressive(desc, reference, quiet);
        return {std::move(p.aov), true, std::move(p.report)};
    }
    Report& report = out.report;
    const auto [plan, scene] = plan_and_load(desc, quiet, &report);
    // One thread limit for every parallel phase of this run.
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                              thread_count(desc.render));
    RenderStats stats;
    if (desc.render.integrator == Integrator::Photon) {
        PhotonPassResult pass = trace_photons(*scene, plan, quiet);
        for (const std::string& w : pass.warnings)
            if (!quiet) std::fprintf(stderr, "fogmap: warning: %s\n", w.c_str());
        report.phases_s.emplace_back("photon pass", pass.time_s);
        report.photons_emitted = pass.emitted;
        report.photons_capped = pass.capped;
        report.photons_capped_power = pass.capped_power;
        const PhotonMaps maps = build_trees(std::move(pass));
        report.maps = map_reports(maps);
        for (const MapReport& m : report.maps)
            report.phases_s.emplace_back("build " + m.name, m.build_s);
        double precompute_s = 0.0;
        out.aov = render_photon(*scene, maps, desc.render, quiet, &stats, &precompute_s);
        if (precompute_s > 0.0) report.phases_s.emplace_back("precompute", precompute_s);
        out.layered = true;
    } else {
        out.aov.beauty = render_path(*scene, desc.render, quiet, &stats);
    }
    report.phases_s.emplace_back("render", stats.render_s);

    report.scene = desc.path;
    report.settings = settings_json(desc);
    report.width = out.aov.beauty.width;
    report.height = out.aov.beauty.height;
    report.spp = desc.render.spp;
    report.threads = stats.threads;
    report.samples = stats.samples;
    report.rays = stats.rays;
    report.nonfinite = stats.nonfinite;
    report.depth_capped = stats.capped;
    report.render_s = stats.render_s;
    report.mean = out.aov.beauty.mean();
    return out;
}

}  // namespace fogmap
