#include "render/progressive.h"

#include "core/rng.h"
#include "core/timer.h"
#include "photon/photon_pass.h"
#include "render/metrics.h"
#include "render/tiles.h"
#include "scene/plan.h"
#include "scene/scene.h"
#include "scene/scene_desc_json.h"

#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <string>

namespace fogmap {

namespace {

void accumulate(AovImages& sum, const AovImages& add) {
    Image* to[] = {&sum.beauty,          &sum.direct,  &sum.volume_single,
                   &sum.volume_multiple, &sum.caustic, &sum.indirect};
    const Image* from[] = {&add.beauty,          &add.direct,  &add.volume_single,
                           &add.volume_multiple, &add.caustic, &add.indirect};
    for (int l = 0; l < 6; ++l) {
        if (to[l]->pixels.empty()) *to[l] = Image(from[l]->width, from[l]->height);
        for (size_t i = 0; i < from[l]->pixels.size(); ++i) to[l]->pixels[i] += from[l]->pixels[i];
    }
}

AovImages scaled(const AovImages& sum, float s) {
    AovImages out = sum;
    for (Image* img : {&out.beauty, &out.direct, &out.volume_single, &out.volume_multiple,
                       &out.caustic, &out.indirect})
        for (Color& c : img->pixels) c *= s;
    return out;
}

// Median distance to the k-th nearest photon over up to 256 photons spread through the map: a
// starting radius that holds about k photons where photons are (Hachisuka et al. start from a
// k-NN radius too).
float initial_radius(const PhotonMap& map, int k, float fallback) {
    const std::vector<Photon>& photons = map.tree.records();
    if (photons.size() <= static_cast<size_t>(k)) return fallback;
    const size_t samples = std::min<size_t>(256, photons.size());
    std::vector<float> r;
    NeighborList scratch;
    for (size_t i = 0; i < samples; ++i) {
        map.tree.knn(photons[i * photons.size() / samples].position(), k, fallback, &scratch);
        r.push_back(static_cast<int>(scratch.size()) >= k ? std::sqrt(scratch.max_dist2())
                                                          : fallback);
    }
    std::nth_element(r.begin(), r.begin() + r.size() / 2, r.end());
    return r[r.size() / 2];
}

}  // namespace

float next_radius(float radius, int i, float alpha, int dimensions) {
    const double ratio = (i + static_cast<double>(alpha)) / (i + 1.0);
    return static_cast<float>(radius * std::pow(ratio, 1.0 / dimensions));
}

ProgressiveResult run_progressive(const SceneDesc& desc, const Image* reference, bool quiet) {
    const ProgressiveDesc& settings = desc.progressive;
    ProgressiveResult result;
    Report& report = result.report;
    const Timer timer;
    // The scene is loaded once; each iteration changes only its seed (photons and camera).
    const auto [plan, scene] = plan_and_load(desc, quiet, &report);
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                              thread_count(desc.render));

    GatherOverride gather{gather_radii(*scene), true};
    AovImages sum;
    double photon_s = 0.0, render_s = 0.0;
    std::map<std::string, double> build_s{{"global", 0.0}, {"caustic", 0.0}, {"volume", 0.0}};
    for (int i = 1;; ++i) {
        scene->desc.render.seed = mix64(desc.render.seed * 0x9E3779B97F4A7C15ull + i);
        PhotonPassResult pass = trace_photons(*scene, plan, true);
        if (i == 1 && !quiet)
            for (const std::string& w : pass.warnings)
                std::fprintf(stderr, "fogmap: warning: %s\n", w.c_str());
        photon_s += pass.time_s;
        report.photons_emitted += pass.emitted;
        report.photons_capped += pass.capped;
        report.photons_capped_power += pass.capped_power;
        const PhotonMaps maps = build_trees(std::move(pass));
        const std::vector<MapReport> built = map_reports(maps);
        for (const MapReport& m : built) build_s[m.name] += m.build_s;
        if (i == 1) {
            report.maps = built;  // one iteration's maps: the memory held at any time
            // Radii the scene leaves at 0 start from the first maps' photon density.
            if (maps.global && desc.global.radius == 0.0f)
                gather.radii.global =
                    initial_radius(*maps.global, desc.global.k, gather.radii.global);
            if (maps.caustic && desc.caustic.radius == 0.0f)
                gather.radii.caustic =
                    initial_radius(*maps.caustic, desc.caustic.k, gather.radii.caustic);
            if (maps.volume && desc.volume.radius == 0.0f)
                gather.radii.volume =
                    initial_radius(*maps.volume, desc.volume.k, gather.radii.volume);
        }
        RenderStats stats;
        const AovImages aov =
            render_photon(*scene, maps, scene->desc.render, true, &stats, nullptr, &gather);
        render_s += stats.render_s;
        report.samples += stats.samples;
        report.rays += stats.rays;
        report.nonfinite += stats.nonfinite;
        report.depth_capped += stats.capped;
        report.threads = stats.threads;
        accumulate(sum, aov);

        ProgressiveIteration it;
        it.index = i;
        it.elapsed_s = timer.seconds();
        it.radii = gather.radii;
        for (const MapReport& m : built) it.photon_bytes += m.bytes;
        if (reference) it.rel_mse = image_error(scaled(sum, 1.0f / i).beauty, *reference).rel_mse;
        result.iterations.push_back(it);
        if (!quiet)
            std::fprintf(stderr, "progressive: iteration %d, %.1f s, radii %.4g %.4g %.4g%s\n", i,
                         it.elapsed_s, it.radii.global, it.radii.caustic, it.radii.volume,
                         reference ? (", relMSE " + std::to_string(it.rel_mse)).c_str() : "");

        gather.radii.global = next_radius(gather.radii.global, i, settings.alpha, 2);
        gather.radii.caustic = next_radius(gather.radii.caustic, i, settings.alpha, 2);
        gather.radii.volume = next_radius(gather.radii.volume, i, settings.alpha, 3);
        if (settings.iterations > 0 && i >= settings.iterations) break;
        if (settings.time_budget > 0.0f && timer.seconds() >= settings.time_budget) break;
        if (!settings.enabled()) break;
    }
    const int n = static_cast<int>(result.iterations.size());
    result.aov = scaled(sum, 1.0f / n);
    report.phases_s.emplace_back("photon pass", photon_s);
    for (const char* name : {"global", "caustic", "volume"})
        report.phases_s.emplace_back(std::string("build ") + name, build_s[name]);
    report.phases_s.emplace_back("render", render_s);
    report.scene = desc.path;
    report.settings = settings_json(desc);
    report.width = result.aov.beauty.width;
    report.height = result.aov.beauty.height;
    report.spp = desc.render.spp * n;
    report.render_s = render_s;
    report.photons_capped_power /= n;  // the mean share over iterations
    report.mean = result.aov.beauty.mean();
    for (const ProgressiveIteration& it : result.iterations)
        report.iterations.push_back(
            {{"index", it.index},
             {"elapsed_s", it.elapsed_s},
             {"radii", {it.radii.global, it.radii.caustic, it.radii.volume}},
             {"rel_mse", it.rel_mse},
             {"photon_bytes", it.photon_bytes}});
    return result;
}

}  // namespace fogmap
