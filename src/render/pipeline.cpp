#include "render/pipeline.h"

#include "core/parallel.h"
#include "core/ranks.h"
#include "core/rng.h"
#include "core/timer.h"
#include "core/world_range.h"

#include <nlohmann/json.hpp>
#include "photon/photon_pass.h"
#include "render/camera.h"
#include "render/gather_params.h"
#include "render/metrics.h"
#include "render/path_tracer.h"
#include "render/photon_integrator.h"
#include "render/pilot.h"
#include "scene/plan.h"
#include "scene/scene.h"
#include "scene/scene_desc_json.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
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
                           (*map)->build_s, (*map)->stopped, (*map)->beams.size()});
    return out;
}

/// The bits of every value of `film` (beauty, then each layer), one integer each.
std::vector<int64_t> film_bits(const Film& film) {
    std::vector<int64_t> bits;
    auto put = [&](const Image& image) {
        for (const Color& c : image.pixels)
            for (int k = 0; k < 3; ++k) {
                uint32_t b;
                std::memcpy(&b, &c[k], sizeof b);
                bits.push_back(b);
            }
    };
    put(film.beauty);
    for (const Image& layer : film.layers) put(layer);
    return bits;
}

/// The inverse of film_bits on a film of the same shape.
void set_film_bits(const std::vector<int64_t>& bits, Film* film) {
    size_t at = 0;
    auto get = [&](Image& image) {
        for (Color& c : image.pixels)
            for (int k = 0; k < 3; ++k) {
                const uint32_t b = static_cast<uint32_t>(bits[at++]);
                std::memcpy(&c[k], &b, sizeof b);
            }
    };
    get(film->beauty);
    for (Image& layer : film->layers) get(layer);
}

/// How run_loaded runs: run_pipeline's arguments, and its clock (null: its own) and load and
/// pilot times; `silent` prints nothing, not even warnings (auto's pilot runs).
struct RunOptions {
    bool quiet = false, silent = false;
    const Image* reference = nullptr;
    Ranks* ranks = nullptr;
    const Checkpoints* checkpoints = nullptr;
    const Timer* timer = nullptr;
    double load_s = 0.0, pilot_s = 0.0;
    SharedTables* shared = nullptr;
};

PipelineResult run_loaded(const SceneDesc& desc, const Scene& scene, const RunOptions& o);

/// The guide's settings: its radius is the volume gather's.
GuideSettings guide_settings(const GatherParams& gather, int vertices) {
    GuideSettings g;
    g.radius = gather.volume.radius;
    g.vertices = vertices;
    return g;
}

}  // namespace

uint64_t iteration_seed(uint64_t seed, int i, bool progressive) {
    return progressive ? mix64(seed * 0x9E3779B97F4A7C15ull + static_cast<uint64_t>(i)) : seed;
}

PipelineResult run_pipeline(const SceneDesc& scene_desc, bool quiet, const Image* reference,
                            Ranks* ranks, const Checkpoints* checkpoints) {
    SceneDesc desc = choose_integrator(scene_desc);
    const Timer timer;
    std::unique_ptr<const Scene> scene;
    agree_on_input(ranks, [&] { scene = load_scene(desc); });
    const double load_s = timer.seconds();
    double pilot_s = 0.0;
    SharedTables shared;           // the pilot's sun grids serve the render
    if (desc.render.auto_media) {  // the same choice on every rank: the pilot is deterministic
        const Timer pilot;
        bool piloted = false;  // a phase of its own only when it ran
        desc = pilot_auto(std::move(desc), *scene, &shared, &piloted);
        if (piloted) pilot_s = pilot.seconds();
    }
    RunOptions o;
    o.quiet = quiet;
    o.reference = reference;
    o.ranks = ranks;
    o.checkpoints = checkpoints;
    o.timer = &timer;
    o.load_s = load_s;
    o.pilot_s = pilot_s;
    o.shared = &shared;
    return run_loaded(desc, *scene, o);
}

PipelineResult run_on_scene(const SceneDesc& desc, const Scene& scene, SharedTables* shared) {
    RunOptions o;
    o.quiet = o.silent = true;
    o.shared = shared;
    return run_loaded(desc, scene, o);
}

namespace {

PipelineResult run_loaded(const SceneDesc& loaded, const Scene& scene_ref, const RunOptions& o) {
    const Image* const reference = o.reference;
    Ranks* const ranks = o.ranks;
    const Checkpoints* const checkpoints = o.checkpoints;
    const int n_ranks = ranks ? ranks->size() : 1, my_rank = ranks ? ranks->rank() : 0;
    const bool root = my_rank == 0;
    const bool speak = root && !o.silent;
    const bool quiet = o.quiet || !speak;  // rank 0 alone speaks
    PipelineResult out;
    Report& report = out.report;
    report.ranks = n_ranks;
    const auto warn = [&](const std::string& text) {
        if (speak) std::fprintf(stderr, "fogmap: warning: %s\n", text.c_str());
        report.warnings.push_back(text);
    };
    const Timer own_timer;
    const Timer& timer = o.timer ? *o.timer : own_timer;
    // A photon render's iterations take iteration_size's samples, its photon budgets with them;
    // a plain render it splits is a progressive run of so many iterations.
    SceneDesc desc = loaded;
    std::string iteration_text;
    if (desc.render.integrator == Integrator::Photon) {
        const IterationSize size = iteration_size(desc);
        if (desc.progressive.enabled() || size.iterations > 1) {
            desc.render.spp = desc.progressive.spp = size.spp;
            desc.progressive.iterations = size.iterations;
            iteration_text = "; " + size.reason;
        }
    }
    Plan plan = make_plan(desc);
    plan.integrator.reason += iteration_text;
    const Scene* const scene = &scene_ref;
    add_phase(&report, "load", o.load_s);
    if (o.pilot_s > 0.0) add_phase(&report, "pilot", o.pilot_s);
    for (const std::string& w : scene->warnings) warn(w);
    describe_volume_light(*scene, &plan.volume_light);
    report.plan_text = plan_text(plan);
    report.plan = plan_json(plan);
    if (!quiet) std::fprintf(stderr, "%s", report.plan_text.c_str());

    const ThreadLimit threads(desc.render.threads);
    const bool photon = desc.render.integrator == Integrator::Photon;
    const bool guided = desc.render.integrator == Integrator::Guided;
    // Camera paths traced as the path tracer does, ended in the volume map: an unlayered film.
    const bool map_end = photon && desc.volume.gather_depth > 0;
    // The photon beams estimate needs the photon paths' beams (their free paths then delta-tracked:
    // photon/photon_pass.h).
    PhotonSettings photons = desc.photons;
    photons.volume_beams = photon && desc.volume.estimator == VolumeEstimator::PhotonBeams;
    if (photons.volume_attempts == 0) {                   // unless set (auto's pilot)
        photons.volume_attempts = volume_attempts(desc);  // the volume map's share of the work
        photons.volume = volume_budget(desc);
    }
    const bool progressive = photon && desc.progressive.enabled();
    const bool quiet_pass = quiet || progressive;  // progressive runs print one line per iteration
    std::optional<GatherParams> first_gather;
    std::optional<SigmaTable> sigma_table;  // map_end: σ_s over boxes, for every iteration
    VolumeMapEnd::Buffers end_buffers;      // map_end: each iteration's grids in the last's memory
    // map_end: the suns' optical depth, every iteration (and every run sharing the tables)
    SharedTables own_tables;
    std::optional<SunShadows>& sun_shadows = (o.shared ? o.shared : &own_tables)->sun;
    // Progressive iterations are summed in fixed point (film.h): the same bits whatever rank ran
    // which iteration. Rank r runs iterations i ≡ r + 1 (mod ranks), one per round, after the
    // `base` iterations of the checkpoint resumed from.
    FixedFilm sum;
    int mine = 0;  // iterations in this rank's sum
    const ProgressiveDesc& p = desc.progressive;
    const int base = checkpoints && checkpoints->resume ? checkpoints->resume->iterations : 0;
    // Counts summed over ranks with the film; rank 0 holds the totals after gather_to_root.
    const auto counts = [&] {
        return std::vector<int64_t>{mine,
                                    int64_t(report.samples),
                                    int64_t(report.rays),
                                    int64_t(report.nonfinite),
                                    int64_t(report.depth_capped),
                                    int64_t(report.photons_emitted),
                                    int64_t(report.photons_capped),
                                    int64_t(sum.clamped),
                                    int64_t(report.steps),
                                    int64_t(report.lookups),
                                    int64_t(report.gathered)};
    };
    const auto set_counts = [&](const std::vector<int64_t>& c) {
        mine = int(c[0]);
        report.samples = uint64_t(c[1]);
        report.rays = uint64_t(c[2]);
        report.nonfinite = uint64_t(c[3]);
        report.depth_capped = uint64_t(c[4]);
        report.photons_emitted = uint64_t(c[5]);
        report.photons_capped = uint64_t(c[6]);
        sum.clamped = uint64_t(c[7]);
        report.steps = uint64_t(c[8]);
        report.lookups = uint64_t(c[9]);
        report.gathered = uint64_t(c[10]);
    };
    // Every rank's sum and counts into rank 0's; the other ranks start again from zero.
    const auto gather_to_root = [&] {
        std::vector<int64_t> c = counts();
        if (sum.values.empty())
            sum.add(Film(desc.camera.width, desc.camera.height, photon && !map_end));
        if (ranks) {
            const Timer reduce;
            ranks->sum_to_root(&c);
            ranks->sum_to_root(&sum.values);
            add_phase(&report, "reduce", reduce.seconds());
        }
        if (root) {
            set_counts(c);
        } else {
            set_counts(std::vector<int64_t>(c.size(), 0));
            std::fill(sum.values.begin(), sum.values.end(), 0);
        }
    };
    if (base > 0 && root) {
        sum = checkpoints->resume->sum;
        set_counts(checkpoints->resume->counts);
    }
    // Iteration 1's maps set every later iteration's radii (render/gather_params.h): a rank that
    // does not run it traces its photons for that alone.
    if (progressive && (my_rank != 0 || base > 0)) {
        PhotonPassResult pass = trace_photons(*scene, plan, photons, desc.march,
                                              iteration_seed(desc.render.seed, 1, true), true);
        first_gather = gather_params(desc, *scene, build_trees(std::move(pass)), true);
    }
    // A plain render is shared: every rank traces a share of each photon round and builds the
    // same maps (photon/photon_pass.h), then renders a share of the tiles.
    Ranks* const pass_ranks = progressive ? nullptr : ranks;
    double checkpointed_s = 0.0;
    int own = 0;  // iterations this rank ran itself
    const double loop_start_s = timer.seconds();
    for (int round = 0;; ++round) {
        const int i = progressive ? base + round * n_ranks + my_rank + 1 : 1;
        const bool runs = !progressive || !(p.iterations > 0 && i > p.iterations);
        if (runs) {
            ++mine;
            ++own;
            RenderSettings settings = desc.render;
            settings.seed = iteration_seed(desc.render.seed, i, progressive);
            if (!progressive && ranks) {  // else the description's share (auto's pilot)
                settings.tile_index = my_rank;
                settings.tile_count = n_ranks;
            }
            IterationReport it;
            it.index = i;
            RenderStats stats;
            Film film;
            if (photon || guided) {
                PhotonPassResult pass = trace_photons(*scene, plan, photons, desc.march,
                                                      settings.seed, quiet_pass, pass_ranks);
                if (i == 1) {
                    for (const std::string& w : pass.warnings) warn(w);
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
                if (pass.exchange_s > 0.0) add_phase(&report, "photon exchange", pass.exchange_s);
                report.photons_emitted += pass.emitted;
                report.photon_steps += pass.steps;
                report.photon_interactions += pass.interactions;
                report.photons_capped += pass.capped;
                report.photons_capped_power += pass.capped_power;
                const PhotonMaps maps = build_trees(std::move(pass));
                const std::vector<MapReport> built = map_reports(maps);
                for (const MapReport& m : built) {
                    add_phase(&report, "build " + m.name, m.build_s);
                    it.photon_bytes += m.bytes;
                }
                if (report.maps.empty()) report.maps = built;  // one iteration's maps
                if (i == 1) first_gather = gather_params(desc, *scene, maps, progressive);
                const GatherParams gather = gather_at_iteration(*first_gather, i, p.alpha);
                it.radii = {gather.global.radius, gather.caustic.radius, gather.volume.radius};
                if (guided) {
                    // Splitting by the map's light to come (AdjointSplit), directions guided at
                    // the first render.guide_vertices medium vertices.
                    std::optional<VolumeGuide> guide;
                    std::optional<AdjointGrid> grid;
                    Image pixels;
                    AdjointSplit split;
                    if (maps.volume) {
                        if (desc.render.guide_vertices > 0)
                            guide.emplace(*maps.volume,
                                          guide_settings(gather, desc.render.guide_vertices));
                        const Timer precompute;
                        grid.emplace(*maps.volume, scene->media, gather.volume.radius);
                        RenderStats estimate;
                        pixels = render_pixel_estimate(*scene, settings, *grid, &estimate);
                        report.estimate_events += estimate.steps + estimate.rays + estimate.lookups;
                        report.precompute_nodes += grid->evaluations();
                        split = AdjointSplit{&*grid, &pixels};
                        add_phase(&report, "precompute", precompute.seconds());
                    }
                    film =
                        render_path(*scene, settings, quiet_pass, &stats, guide ? &*guide : nullptr,
                                    nullptr, nullptr, grid ? &split : nullptr);
                } else if (map_end) {
                    const Timer precompute;
                    std::optional<VolumeMapEnd> end;
                    if (maps.volume) {
                        // Where the ball holds many photons, gather about k of them
                        // (VolumeMapEnd's AdaptiveRadius), k shrinking with the radius's cube;
                        // a radius the scene sets is kept everywhere.
                        const float r1 = first_gather->volume.radius;
                        const float k = desc.volume.radius > 0.0f
                                            ? 0.0f
                                            : float(first_gather->volume.k) *
                                                  std::pow(gather.volume.radius / r1, 3.0f);
                        end.emplace(*maps.volume, scene->media, gather.volume.radius,
                                    gather.gather_depth, k, desc.volume.gather_tau, &end_buffers);
                        report.precompute_nodes += end->nodes();
                        if (end->wants_table()) {
                            if (!sigma_table) {
                                sigma_table.emplace(scene->media, 2.0f * r1);
                                report.precompute_nodes += sigma_table->nodes();
                            }
                            end->set_table(&*sigma_table);
                        }
                    }
                    if (!sun_shadows) {
                        sun_shadows.emplace(scene->lights, scene->media, desc.volume.sun_grid);
                        report.precompute_nodes += sun_shadows->nodes();
                    }
                    add_phase(&report, "precompute", precompute.seconds());
                    film = render_path(*scene, settings, quiet_pass, &stats, nullptr,
                                       end ? &*end : nullptr, &*sun_shadows);
                } else {
                    double precompute_s = 0.0;
                    film = render_photon(*scene, maps, gather, desc.march, settings, quiet_pass,
                                         &stats, &precompute_s);
                    if (precompute_s > 0.0) add_phase(&report, "precompute", precompute_s);
                }
            } else {
                film = render_path(*scene, settings, quiet_pass, &stats);
            }
            if (progressive)
                sum.add(film);
            else
                out.film = std::move(film);
            add_phase(&report, "render", stats.render_s);
            report.samples += stats.samples;
            report.rays += stats.rays;
            report.steps += stats.steps;
            report.lookups += stats.lookups;
            report.gathered += stats.gathered;
            report.nonfinite += stats.nonfinite;
            report.depth_capped += stats.capped;
            report.render_s += stats.render_s;
            report.threads = stats.threads;
            it.elapsed_s = timer.seconds();
            // The running error: of the mean so far, known to a lone rank that started at 1.
            if (reference && progressive && n_ranks == 1 && base == 0)
                it.rel_mse = image_error(sum.mean(mine).beauty, *reference).rel_mse;
            report.iterations.push_back(it);
            if (progressive && !quiet)
                std::fprintf(stderr, "progressive: iteration %d, %.1f s, radii %.4g %.4g %.4g%s\n",
                             i, it.elapsed_s, it.radii.global, it.radii.caustic, it.radii.volume,
                             reference && n_ranks == 1 && base == 0
                                 ? (", relMSE " + std::to_string(it.rel_mse)).c_str()
                                 : "");
        }
        // Every rank stops after the same round: the count is known to all, the time budget is
        // agreed on (any rank out of time stops them all).
        if (!progressive) break;
        const int ran = base + (round + 1) * n_ranks;
        if (p.iterations > 0 && ran >= p.iterations) break;
        // Out of time when another round would end further past the budget than this one ends
        // before it (a round taking the mean time so far): the run ends within half a round of it.
        const double now_s = timer.seconds(), round_s = (now_s - loop_start_s) / (round + 1);
        const bool out_of_time = p.time_budget > 0.0f && now_s + 0.5 * round_s >= p.time_budget;
        if (ranks ? ranks->any(out_of_time) : out_of_time) break;
        // A checkpoint after a whole round: every iteration up to `ran` is in some rank's sum.
        if (checkpoints && checkpoints->every_s > 0.0) {
            const bool due = timer.seconds() - checkpointed_s >= checkpoints->every_s;
            if (ranks ? ranks->any(due) : due) {
                gather_to_root();
                if (root) checkpoints->write(Checkpoint{0, ran, counts(), sum});
                checkpointed_s = timer.seconds();
            }
        }
    }
    int iterations = 1;  // all ranks ran
    if (!progressive && n_ranks > 1) {
        // Each pixel is one rank's and 0 (bits 0) on the others: summing the values' bits as
        // integers gives rank 0 the very floats one process renders.
        std::vector<int64_t> c{int64_t(report.samples),   int64_t(report.rays),
                               int64_t(report.nonfinite), int64_t(report.depth_capped),
                               int64_t(report.steps),     int64_t(report.lookups),
                               int64_t(report.gathered)};
        std::vector<int64_t> bits = film_bits(out.film);
        const Timer reduce;
        ranks->sum_to_root(&c);
        ranks->sum_to_root(&bits);
        add_phase(&report, "reduce", reduce.seconds());
        if (!root) return out;
        set_film_bits(bits, &out.film);
        report.samples = uint64_t(c[0]);
        report.rays = uint64_t(c[1]);
        report.nonfinite = uint64_t(c[2]);
        report.depth_capped = uint64_t(c[3]);
        report.steps = uint64_t(c[4]);
        report.lookups = uint64_t(c[5]);
        report.gathered = uint64_t(c[6]);
    }
    if (reference && !progressive)
        report.iterations.back().rel_mse = image_error(out.film.beauty, *reference).rel_mse;
    if (progressive) {
        gather_to_root();
        if (!root) return out;
        // The last checkpoint holds every iteration: a later --resume with a larger budget
        // continues from here.
        if (checkpoints && checkpoints->every_s > 0.0) checkpoints->write({0, mine, counts(), sum});
        if (sum.clamped > 0)
            warn(std::to_string(sum.clamped) +
                 " pixel values or sums beyond the fixed-point range (radiance 1.7e7) were "
                 "clamped");
        out.film = sum.mean(mine);
        iterations = mine;
    }
    if (report.samples > 0 && report.depth_capped > report.samples / 1000) {
        char text[200];
        std::snprintf(text, sizeof text,
                      "render.max_depth = %d cut %.2g%% of the camera samples while they still "
                      "carried light; raise it (the image misses that light)",
                      desc.render.max_depth, 100.0 * double(report.depth_capped) / report.samples);
        warn(text);
    }
    if (report.nonfinite > 0)
        warn(std::to_string(report.nonfinite) + " of " + std::to_string(report.samples) +
             " camera samples were not finite (NaN or infinite) and were dropped; the pixels "
             "they fell in are darker");
    report.scene = desc.path;
    report.settings = settings_json(desc);
    report.width = out.film.beauty.width;
    report.height = out.film.beauty.height;
    report.spp = desc.render.spp * iterations;
    report.photons_capped_power /= std::max(own, 1);  // the mean share over rank 0's iterations
    report.mean = out.film.beauty.mean();
    return out;
}

}  // namespace

}  // namespace fogmap
