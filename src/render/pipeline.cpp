#include "render/pipeline.h"

#include "core/parallel.h"
#include "core/ranks.h"
#include "core/rng.h"
#include "core/timer.h"

#include "photon/photon_pass.h"
#include "render/camera.h"
#include "render/error_estimate.h"
#include "render/gather_params.h"
#include "render/metrics.h"
#include "render/path_tracer.h"
#include "render/photon_integrator.h"
#include "render/run_setup.h"
#include "render/sun_shadows.h"
#include "scene/scene.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
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

/// The bits of every value of `film` (beauty, each layer, each batch, the map variance and bias
/// halves, adaptive sampling's samples per pixel), one integer each.
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
    for (const Image& batch : film.batches) put(batch);
    put(film.map_variance);
    for (const Image& half : film.bias_halves) put(half);
    bits.insert(bits.end(), film.pixel_spp.begin(), film.pixel_spp.end());
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
    for (Image& batch : film->batches) get(batch);
    get(film->map_variance);
    for (Image& half : film->bias_halves) get(half);
    for (int& n : film->pixel_spp) n = int(bits[at++]);
}

/// How run_loaded runs: run_pipeline's arguments, and its clock (null: its own) and load time.
struct RunOptions {
    bool quiet = false;
    const Image* reference = nullptr;
    Ranks* ranks = nullptr;
    std::optional<TileShare> part;  ///< this process's part of a run split by --part
    const Checkpoints* checkpoints = nullptr;
    const Timer* timer = nullptr;
    double load_s = 0.0;
};

/// The counts a run sums over iterations and ranks, in the order a checkpoint stores them.
struct Counts {
    int64_t iterations = 0;  ///< in this rank's sum
    int64_t samples = 0, rays = 0, nonfinite = 0, depth_capped = 0, photons_emitted = 0,
            photons_capped = 0, clamped = 0, steps = 0, lookups = 0, gathered = 0;

    std::vector<int64_t> pack() const {
        return {iterations,     samples, rays,  nonfinite, depth_capped, photons_emitted,
                photons_capped, clamped, steps, lookups,   gathered};
    }
    /// A checkpoint's or a reduced list (the length pack gives).
    static Counts unpack(const std::vector<int64_t>& c) {
        Counts n;
        int64_t* const fields[] = {&n.iterations,     &n.samples,      &n.rays,
                                   &n.nonfinite,      &n.depth_capped, &n.photons_emitted,
                                   &n.photons_capped, &n.clamped,      &n.steps,
                                   &n.lookups,        &n.gathered};
        for (size_t i = 0; i < std::size(fields) && i < c.size(); ++i) *fields[i] = c[i];
        return n;
    }
    void add(const RenderStats& s) {
        samples += int64_t(s.samples);
        rays += int64_t(s.rays);
        nonfinite += int64_t(s.nonfinite);
        depth_capped += int64_t(s.capped);
        steps += int64_t(s.steps);
        lookups += int64_t(s.lookups);
        gathered += int64_t(s.gathered);
    }
};

static_assert(sizeof(Counts) == kRunCounts * sizeof(int64_t), "a checkpoint stores every count");

/// A target's first look, after as many iterations as batches (every batch then holds one);
/// later looks at twice the count before, so that repeated looks do not inflate the chance of
/// stopping early.
constexpr int kFirstLook = kBatches;

/// More lights than this make next-event estimation, not the samples, the bulk of the work.
constexpr size_t kManyLights = 1000;

/// The guide's settings: its radius is the volume gather's.
GuideSettings guide_settings(const GatherParams& gather, int vertices) {
    GuideSettings g;
    g.radius = gather.volume.radius;
    g.vertices = vertices;
    return g;
}

/// A warning on stderr, as every warning is said.
void say_warning(const std::string& text) {
    std::fprintf(stderr, "fogmap: warning: %s\n", text.c_str());
}

/// Adds a warning to the report, said on stderr when `speak`.
void warn_in(Report* report, bool speak, const std::string& text) {
    if (speak) say_warning(text);
    report->warnings.push_back(text);
}

/// Whose bias the estimate of a photon method's run measures, and what lowers it (the report's
/// words; where samples read photon batches).
void bias_words(const RunSetup& setup, ErrorReport* r) {
    // A progressive run's radii shrink with its iterations: more of them lower the bias too.
    const std::string iterations = setup.progressive ? "more iterations" : "progressive iterations";
    if (setup.method == Method::MapEnd) {
        r->bias_of = "the volume map's";
        r->bias_remedy = "a smaller volume.radius (or more photons), " + iterations +
                         " or the path tracer lower it";
    } else {
        r->bias_of = "the photon maps'";
        r->bias_remedy = "more photons (or smaller volume.k, global.k, caustic.k), " + iterations +
                         " or the path tracer lower it";
    }
}

/// What the estimate of a photon method's run cannot see (the report's "not in it").
std::string excluded(const RunSetup& setup) {
    if (setup.photon_batches())
        return setup.method == Method::MapEnd
                   ? "the map's bias beyond its radius's blur (the bias² above holds that part "
                     "only)"
                   : "the maps' bias beyond their radii's blur (the bias² above holds that part "
                     "only)";
    if (setup.progressive) return "the photon maps' bias (their gather radii blur the light)";
    return "the photon maps' own noise and their bias (one set of maps serves every sample; their "
           "gather radii blur the light; photon beams and final gathering are not read in "
           "batches)";
}

/// The end of a run whose sums are together, on rank 0 after the reduction or in PartMerge:
/// the film of a progressive sum, and the report from the summed counts and the film.
struct RunEnd {
    const RunSetup& setup;
    const Counts& counts;
    int own = 1;  ///< iterations rank 0 (or part 1) ran itself
    bool speak = false;
    /// Iteration 1's own estimate, stated by a run that ends after it (or null).
    const ErrorEstimate* first = nullptr;

    /// The mean of a progressive sum over the counted iterations, its clamps warned of.
    Film mean(const FixedFilm& sum, Report* report) const {
        if (sum.clamped > 0)
            warn_in(report, speak,
                    std::to_string(sum.clamped) +
                        " pixel values or sums beyond the fixed-point range (radiance 1.7e7) were "
                        "clamped");
        return sum.mean(int(counts.iterations), setup.run.render.spp);
    }
    void finish(Film* film, Report* report) const;

private:
    void estimate(Film* film, Report* report) const;
};

/// The samples every pixel of a run's film holds after `iterations`: render.spp each where
/// iterations are summed into one film (progressive), else render.spp (the ranks of a plain run
/// count one iteration each).
int run_spp(const SceneDesc& run, bool progressive, int iterations) {
    return run.render.spp * (progressive ? iterations : 1);
}

/// The report's counts, its warnings of cut and dropped samples, its figures, the estimate.
void RunEnd::finish(Film* film, Report* report) const {
    const SceneDesc& desc = setup.run;
    Report& r = *report;
    r.samples = uint64_t(counts.samples);
    r.rays = uint64_t(counts.rays);
    r.nonfinite = uint64_t(counts.nonfinite);
    r.depth_capped = uint64_t(counts.depth_capped);
    r.photons_emitted = uint64_t(counts.photons_emitted);
    r.photons_capped = uint64_t(counts.photons_capped);
    r.steps = uint64_t(counts.steps);
    r.lookups = uint64_t(counts.lookups);
    r.gathered = uint64_t(counts.gathered);
    if (r.samples > 0 && double(r.depth_capped) > kCapWarnShare * double(r.samples)) {
        char text[200];
        std::snprintf(text, sizeof text,
                      "render.max_depth = %d cut %.2g%% of the camera samples while they still "
                      "carried light; raise it (the image misses that light)",
                      desc.render.max_depth, 100.0 * double(r.depth_capped) / r.samples);
        warn_in(report, speak, text);
    }
    if (r.nonfinite > 0)
        warn_in(report, speak,
                std::to_string(r.nonfinite) + " of " + std::to_string(r.samples) +
                    " camera samples were not finite (NaN or infinite) and were dropped; the "
                    "pixels they fell in are darker");
    r.scene = desc.path;
    r.settings = settings_json(setup);
    r.width = film->beauty.width;
    r.height = film->beauty.height;
    r.spp = run_spp(desc, setup.progressive, int(counts.iterations));
    r.photons_capped_power /= std::max(own, 1);  // the mean share over rank 0's iterations
    r.mean = film->beauty.mean();
    estimate(film, report);
}

/// The error estimate from the film's batches (and its map variance and bias halves), its
/// variance and samples layers, and what it cannot see: a photon method's bias beyond what the
/// bias halves measure, and the photon gather's maps' noise when one set serves every sample.
void RunEnd::estimate(Film* film, Report* report) const {
    const Timer timer;
    const bool progressive = setup.progressive, first_alone = counts.iterations == 1 && first;
    ErrorEstimate e = first_alone ? *first : estimate_error(*film, report->spp);
    ErrorReport& r = report->error;
    r.valid = e.valid;
    r.why = progressive ? "needs at least 2 iterations" : "needs at least 2 samples per pixel";
    r.rel_mse = e.rel_mse.value;
    r.lo = e.rel_mse.lo;
    r.hi = e.rel_mse.hi;
    r.dof = e.dof;
    r.bias_valid = e.bias_valid;
    r.bias2 = e.bias2.value;
    r.bias_lo = e.bias2.lo;
    r.bias_hi = e.bias2.hi;
    r.batches = e.batches;
    r.batched_by = progressive && !first_alone ? "iterations" : "samples";
    r.tail_share = e.tail_share;
    r.tail = e.tail;
    r.top_x = e.top_x;
    r.top_y = e.top_y;
    r.target = setup.run.progressive.target_relmse;
    r.reached = r.target > 0.0 && meets_target(e, r.target);
    r.iterations = progressive ? int(counts.iterations) : 1;  // ranks of a plain run add 1 each
    if (setup.photon()) r.excludes = excluded(setup);
    if (setup.photon_batches()) bias_words(setup, &r);
    film->variance = std::move(e.variance);
    if (film->samples.pixels.empty()) {  // a progressive sum's mean has its own
        film->samples = Image(report->width, report->height);
        if (film->pixel_spp.empty())
            std::fill(film->samples.pixels.begin(), film->samples.pixels.end(),
                      Color(float(report->spp)));
        for (size_t p = 0; p < film->pixel_spp.size(); ++p)  // adaptive sampling's own
            film->samples.pixels[p] = Color(float(film->pixel_spp[p]));
    }
    add_phase(report, "estimate", timer.seconds());
}

/// A plain render's counts summed over ranks or parts, with the photons of `first`: every rank
/// traced a share of the same photon rounds, and every part all of them, and counted them all.
Counts plain_sum(Counts sum, const Counts& first) {
    sum.photons_emitted = first.photons_emitted;
    sum.photons_capped = first.photons_capped;
    return sum;
}

/// The report of a run's parts put together (PartMerge): part 1's plan, settings, maps and
/// streams; every part's phases and work added up (the processes' seconds, not the wall clock),
/// their iterations in order and their warnings, each once.
Report merged_report(std::vector<Report> parts) {
    Report r = std::move(parts[0]);
    r.parts = int(parts.size());
    for (size_t i = 1; i < parts.size(); ++i) {
        const Report& p = parts[i];
        for (const auto& [name, s] : p.phases_s) add_phase(&r, name, s);
        r.render_s += p.render_s;
        r.photon_steps += p.photon_steps;
        r.photon_interactions += p.photon_interactions;
        r.precompute_nodes += p.precompute_nodes;
        r.estimate_events += p.estimate_events;
        r.iterations.insert(r.iterations.end(), p.iterations.begin(), p.iterations.end());
        for (const std::string& w : p.warnings)
            if (std::find(r.warnings.begin(), r.warnings.end(), w) == r.warnings.end())
                r.warnings.push_back(w);
    }
    // An iteration in several parts is one iteration shared (a plain render's tiles): once.
    const auto by_index = [](const IterationReport& a, const IterationReport& b) {
        return a.index < b.index;
    };
    std::stable_sort(r.iterations.begin(), r.iterations.end(), by_index);
    r.iterations.erase(std::unique(r.iterations.begin(), r.iterations.end(),
                                   [](const IterationReport& a, const IterationReport& b) {
                                       return a.index == b.index;
                                   }),
                       r.iterations.end());
    return r;
}

/// One run on a loaded scene, as named stages: begin (the Plan), then per round run one
/// iteration and accumulate it, then reduce over ranks and finish the report.
class RunLoop {
public:
    RunLoop(const RunSetup& setup, const Scene& scene, const RunOptions& o);
    PipelineResult run();

private:
    void warn(const std::string& text);
    void warn_many_lights();
    void begin();
    PhotonMaps trace_maps(uint64_t seed, int i, IterationReport* it);
    Film run_iteration(int i, IterationReport* it, RenderStats* stats, GivenSamples given);
    Film render_guided(const PhotonMaps& maps, const GatherParams& gather,
                       const RenderSettings& settings, RenderStats* stats, GivenSamples given);
    Film render_map_end(const PhotonMaps& maps, const GatherParams& gather,
                        const RenderSettings& settings, PhotonParts parts, RenderStats* stats,
                        IterationReport* it, GivenSamples given);
    GivenSamples given_samples(int i, PassMeasure* measure) const;
    void finish_measure();
    void measure_again(int i);
    void add_measure(int i, const PassMeasure& measure);
    void accumulate(Film film, const RenderStats& stats, IterationReport it);
    bool last_round(int ran, int round, double loop_start_s);
    bool target_reached();
    std::string bias_above_target(const ErrorEstimate& e, int n) const;
    int iteration_cap() const;
    void gather_to_root();
    /// Rank 0's checkpoint of iterations 1 .. `iterations`, with iteration 1's estimate while
    /// the sum holds that iteration alone.
    Checkpoint checkpoint(int iterations) const {
        return {0, iterations, counts_.pack(), sum_,
                iterations == 1 ? first_estimate_ : std::nullopt};
    }
    bool reduce();
    void finish_report();
    RenderSettings iteration_settings(int i) const;

    const RunSetup& setup_;
    const SceneDesc& desc_;
    const Scene& scene_;
    const RunOptions& o_;
    Ranks* const ranks_;
    const int n_ranks_, my_rank_;
    const bool root_, speak_, quiet_, progressive_, quiet_pass_;
    const Timer own_timer_;
    const Timer& timer_;
    const int base_;  ///< iterations of the checkpoint resumed from
    PipelineResult out_;
    Report& report_ = out_.report;
    Counts counts_;
    FixedFilm sum_;  ///< progressive iterations, summed in fixed point (film.h)
    int own_ = 0;    ///< iterations this rank ran itself
    int next_look_ = 0;  ///< the iteration count at which a target is looked at next (0: none)
    double checkpointed_s_ = 0.0;
    std::optional<GatherParams> first_gather_;
    std::optional<SigmaTable> sigma_table_;  ///< MapEnd: σ_s over boxes, for every iteration
    VolumeMapEnd::Buffers end_buffers_;  ///< MapEnd: each iteration's grids in the last's memory
    std::optional<SunShadows> sun_shadows_;  ///< MapEnd: every iteration's
    /// Adaptive sampling across iterations (RunSetup::measured): this process's measure of the
    /// measured iterations, which of them it holds (by index, 1 .. measured), and once every
    /// process holds the whole measure, every later iteration's samples per pixel.
    IterationMeasure measure_;
    std::vector<char> measured_here_;
    std::vector<int> later_counts_;
    bool first_pass_reported_ = false;  ///< iteration 1's photon streams and warnings
    /// Iteration 1's own error estimate, where the run may end after it and this process ran it
    /// (RunSetup::first_iteration_estimate).
    std::optional<ErrorEstimate> first_estimate_;
};

RunLoop::RunLoop(const RunSetup& setup, const Scene& scene, const RunOptions& o)
    : setup_(setup),
      desc_(setup.run),
      scene_(scene),
      o_(o),
      ranks_(o.ranks),
      n_ranks_(o.part    ? o.part->count
               : o.ranks ? o.ranks->size()
                         : 1),
      my_rank_(o.part    ? o.part->index
               : o.ranks ? o.ranks->rank()
                         : 0),
      root_(o.part || my_rank_ == 0),  // a part holds its own sums
      speak_(root_),
      quiet_(o.quiet || !speak_),
      progressive_(setup.progressive),
      quiet_pass_(quiet_ || progressive_),  // progressive runs print a line per iteration
      timer_(o.timer ? *o.timer : own_timer_),
      base_(o.checkpoints && o.checkpoints->resume ? o.checkpoints->resume->iterations : 0),
      measured_here_(size_t(setup.measured) + 1, 0) {}

void RunLoop::warn(const std::string& text) { warn_in(&report_, speak_, text); }

/// The report's first entries and the Plan, printed unless quiet.
void RunLoop::begin() {
    report_.ranks = n_ranks_;
    add_phase(&report_, "load", o_.load_s);
    for (const std::string& w : scene_.warnings) warn(w);
    warn_many_lights();
    if (!setup_.ignored.empty()) {
        std::string keys;
        for (const std::string& k : setup_.ignored) keys += (keys.empty() ? "" : ", ") + k;
        warn(std::string(describe(setup_.method)) + " does not read " + keys +
             ", set in the scene: other integrators' settings");
    }
    Plan plan = setup_.plan;
    describe_volume_light(scene_, &plan.volume_light);
    report_.plan_text = plan_text(plan);
    report_.plan = plan_json(plan);
    if (!quiet_) std::fprintf(stderr, "%s", report_.plan_text.c_str());
    if (desc_.progressive.target_relmse > 0.0f)
        for (next_look_ = kFirstLook; next_look_ <= base_;) next_look_ *= 2;
    if (base_ > 0 && root_) {
        sum_ = o_.checkpoints->resume->sum;
        counts_ = Counts::unpack(o_.checkpoints->resume->counts);
        sum_.clamped = uint64_t(counts_.clamped);
        first_estimate_ = o_.checkpoints->resume->first;
    }
    // Iteration 1's maps set every later iteration's radii (render/gather_params.h): a rank that
    // does not run it traces its photons for that alone.
    if (progressive_ && setup_.method != Method::Path && (my_rank_ != 0 || base_ > 0)) {
        PhotonPassResult pass = trace_photons(scene_, setup_.plan, setup_.photons, desc_.march,
                                              iteration_seed(desc_.render.seed, 1, true), true);
        first_gather_ = gather_params(desc_, scene_, build_trees(std::move(pass)), true);
    }
}

/// Next-event estimation takes a shadow ray to every light at every camera vertex: with many
/// lights that, not the samples, sets the work, so the run says so up front with its estimate.
void RunLoop::warn_many_lights() {
    const size_t lights = scene_.lights.size();
    if (lights <= kManyLights) return;
    const double samples = double(desc_.camera.width) * desc_.camera.height * desc_.render.spp;
    char text[300];
    std::snprintf(text, sizeof text,
                  "%zu lights: every camera vertex takes a shadow ray to each, so this run traces "
                  "at least %.0f shadow rays (%.0f samples x %zu lights); merge lights or lower "
                  "render.spp if that is too many",
                  lights, samples * double(lights), samples, lights);
    warn(text);
}

/// Iteration i's settings: the run's, with the iteration's seed.
RenderSettings RunLoop::iteration_settings(int i) const {
    RenderSettings settings = desc_.render;
    settings.seed = iteration_seed(desc_.render.seed, i, progressive_);
    return settings;
}

/// The photon pass of iteration i and its kd-trees, reported (streams and warnings once).
PhotonMaps RunLoop::trace_maps(uint64_t seed, int i, IterationReport* it) {
    // A plain render is shared: every rank traces a share of each photon round and builds the
    // same maps (photon/photon_pass.h), then renders a share of the tiles.
    PhotonPassResult pass = trace_photons(scene_, setup_.plan, setup_.photons, desc_.march, seed,
                                          quiet_pass_, progressive_ ? nullptr : ranks_);
    if (i == 1 && !first_pass_reported_) {  // once: iteration 1 may be measured again
        first_pass_reported_ = true;
        for (const std::string& w : pass.warnings) warn(w);
        for (const StreamReport& s : pass.streams)
            report_.streams.push_back(
                {{"name", s.name},
                 {"attempts", s.attempts},
                 {"photons", s.photons},
                 {"media_share", s.photons > 0 ? double(s.met_media) / s.photons : 0.0},
                 {"longest_path", s.longest},
                 {"stored",
                  {{"global", s.stored[0]}, {"caustic", s.stored[1]}, {"volume", s.stored[2]}}}});
    }
    add_phase(&report_, "photon pass", pass.time_s);
    if (pass.exchange_s > 0.0) add_phase(&report_, "photon exchange", pass.exchange_s);
    counts_.photons_emitted += int64_t(pass.emitted);
    report_.photon_steps += pass.steps;
    report_.photon_interactions += pass.interactions;
    counts_.photons_capped += int64_t(pass.capped);
    report_.photons_capped_power += pass.capped_power;
    PhotonMaps maps = build_trees(std::move(pass));
    const std::vector<MapReport> built = map_reports(maps);
    for (const MapReport& m : built) {
        add_phase(&report_, "build " + m.name, m.build_s);
        it->photon_bytes += m.bytes;
    }
    if (report_.maps.empty()) report_.maps = built;  // one iteration's maps
    return maps;
}

/// The guided tracer: camera paths split by the map's light to come (AdjointSplit), directions
/// guided at the first advanced.guide_vertices medium vertices.
Film RunLoop::render_guided(const PhotonMaps& maps, const GatherParams& gather,
                            const RenderSettings& settings, RenderStats* stats,
                            GivenSamples given) {
    std::optional<VolumeGuide> guide;
    std::optional<AdjointGrid> grid;
    Image pixels;
    AdjointSplit split;
    if (maps.volume) {
        if (desc_.render.guide_vertices > 0)
            guide.emplace(*maps.volume, guide_settings(gather, desc_.render.guide_vertices));
        const Timer precompute;
        grid.emplace(*maps.volume, scene_.media, gather.volume.radius);
        RenderStats estimate;
        pixels = render_pixel_estimate(scene_, settings, *grid, &estimate, setup_.tiles);
        report_.estimate_events += estimate.steps + estimate.rays + estimate.lookups;
        report_.precompute_nodes += grid->evaluations();
        split = AdjointSplit{&*grid, &pixels};
        add_phase(&report_, "precompute", precompute.seconds());
    }
    return render_path(
        scene_, settings, quiet_pass_, stats,
        grid ? PathPolicy::guided(guide ? &*guide : nullptr, split) : PathPolicy::plain(),
        setup_.tiles, /*layered=*/true, given);
}

/// Camera paths traced as the path tracer does, ended in the volume map.
Film RunLoop::render_map_end(const PhotonMaps& maps, const GatherParams& gather,
                             const RenderSettings& settings, PhotonParts parts, RenderStats* stats,
                             IterationReport* it, GivenSamples given) {
    const Timer precompute;
    std::optional<VolumeMapEnd> end;
    if (maps.volume) {
        // Where the ball holds many photons, gather about k of them (VolumeMapEnd's
        // AdaptiveRadius), k shrinking with the radius's cube; a radius the scene sets is kept.
        const float r1 = first_gather_->volume.radius;
        const float k = desc_.volume.radius > 0.0f ? 0.0f
                                                   : float(first_gather_->volume.k) *
                                                         std::pow(gather.volume.radius / r1, 3.0f);
        it->volume_k = k;
        end.emplace(*maps.volume, scene_.media, gather.volume.radius, gather.gather_depth, k,
                    desc_.volume.gather_tau, &end_buffers_, parts);
        report_.precompute_nodes += end->nodes();
        if (end->wants_table() || end->batched()) {  // batched: RadiusBias's σ̄ too
            if (!sigma_table_) {
                sigma_table_.emplace(scene_.media, 2.0f * r1);
                report_.precompute_nodes += sigma_table_->nodes();
            }
            end->set_table(&*sigma_table_);
        }
    }
    // Moving media's shadows change within the shutter: shadow rays then, at the sample's time.
    const SunShadows* sun = nullptr;
    if (!media_move(scene_)) {
        if (!sun_shadows_) {
            sun_shadows_.emplace(scene_.lights, scene_.media, desc_.volume.sun_grid);
            report_.precompute_nodes += sun_shadows_->nodes();
        }
        sun = &*sun_shadows_;
    }
    add_phase(&report_, "precompute", precompute.seconds());
    return render_path(scene_, settings, quiet_pass_, stats,
                       end ? PathPolicy::end_in_map(*end, sun) : PathPolicy::plain(sun),
                       setup_.tiles, /*layered=*/true, given);
}

/// Iteration i: the photon pass where the method has maps, then the method's render.
Film RunLoop::run_iteration(int i, IterationReport* it, RenderStats* stats, GivenSamples given) {
    const RenderSettings settings = iteration_settings(i);
    if (setup_.method == Method::Path)
        return render_path(scene_, settings, quiet_pass_, stats, PathPolicy::plain(), setup_.tiles,
                           /*layered=*/true, given);
    const PhotonMaps maps = trace_maps(settings.seed, i, it);
    if (i == 1) first_gather_ = gather_params(desc_, scene_, maps, progressive_);
    const GatherParams gather = gather_at_iteration(*first_gather_, i, desc_.progressive.alpha);
    it->radii = {gather.global.radius, gather.caustic.radius, gather.volume.radius};
    switch (setup_.method) {
        case Method::Guided:
            return render_guided(maps, gather, settings, stats, given);
        case Method::MapEnd:
            return render_map_end(maps, gather, settings, setup_.photon_parts(i), stats, it, given);
        default: {
            double precompute_s = 0.0;
            Film film =
                render_photon(scene_, maps, gather, desc_.march, settings, quiet_pass_, stats,
                              &precompute_s, setup_.tiles, setup_.photon_parts(i), given);
            if (precompute_s > 0.0) add_phase(&report_, "precompute", precompute_s);
            return film;
        }
    }
}

/// What iteration i's film takes under adaptive sampling across iterations: a measured one its
/// own passes, its first pass's PassMeasure into `measure`; a later one the measure's counts.
GivenSamples RunLoop::given_samples(int i, PassMeasure* measure) const {
    if (setup_.measured == 0) return {};
    if (i <= setup_.measured) return {nullptr, measure};
    FOGMAP_ASSERT(!later_counts_.empty(),
                  "iterations after the measured ones wait for the measure");
    return {&later_counts_, nullptr};
}

/// Every process's measure made whole, and every later iteration's counts from it, the same on
/// every rank: a process measures again the measured iterations no process of this run measured
/// (a resumed run's: of its share, (i − 1) mod ranks), or, without ranks to share the measure
/// with (a part, or alone), every one it did not measure itself; ranks then sum their measures
/// on every rank (integers: exact).
void RunLoop::finish_measure() {
    const int measured = setup_.measured;
    for (int i = 1; i <= measured; ++i) {
        const bool mine = !ranks_ || (i <= base_ && (i - 1) % n_ranks_ == my_rank_);
        if (!measured_here_[size_t(i)] && mine) measure_again(i);
    }
    if (measure_.values.empty()) measure_.zero(desc_.camera.width, desc_.camera.height);
    if (ranks_ && n_ranks_ > 1) {
        const Timer reduce;
        ranks_->sum_to_all(&measure_.values);
        add_phase(&report_, "reduce", reduce.seconds());
    }
    const int spp = desc_.render.spp, unit = sample_unit(desc_, setup_.method);
    later_counts_ = measure_.allocate(measured, measured_spp(spp, unit, desc_.render.adaptive), spp,
                                      unit, desc_.render.seed);
}

/// Iteration i's first pass rendered again for its measure alone (the iteration is in some
/// process's sum): the counts and the report are as they were but for the phases' times (what it
/// counts, photons, samples, streams and warnings, is counted where it was summed).
void RunLoop::measure_again(int i) {
    const Counts counts = counts_;
    const Report report = report_;
    const bool reported = first_pass_reported_;
    IterationReport it;
    RenderStats stats;
    PassMeasure measure;
    run_iteration(i, &it, &stats, {nullptr, &measure, /*first_pass_only=*/true});
    add_measure(i, measure);
    counts_ = counts;
    auto phases = std::move(report_.phases_s);
    report_ = report;
    report_.phases_s = std::move(phases);
    first_pass_reported_ = reported;
}

/// Adds measured iteration i's PassMeasure to this process's measure.
void RunLoop::add_measure(int i, const PassMeasure& measure) {
    measure_.add(measure);
    measured_here_[size_t(i)] = 1;
}

/// Adds an iteration's film and counts to the run's, and its line to the report.
void RunLoop::accumulate(Film film, const RenderStats& stats, IterationReport it) {
    if (progressive_ && it.index == 1 && setup_.first_iteration_estimate()) {
        const Timer timer;
        ErrorEstimate e = estimate_error(film, desc_.render.spp);
        if (e.valid) first_estimate_ = std::move(e);
        add_phase(&report_, "estimate", timer.seconds());
    }
    if (progressive_)
        sum_.add(film, it.index, desc_.render.spp);
    else
        out_.film = std::move(film);
    add_phase(&report_, "render", stats.render_s);
    counts_.add(stats);
    report_.render_s += stats.render_s;
    report_.threads = stats.threads;
    it.elapsed_s = timer_.seconds();
    // The running error: of the mean so far, known to a lone rank that started at 1.
    const bool running_error = o_.reference && n_ranks_ == 1 && base_ == 0;
    if (running_error && progressive_)
        it.rel_mse =
            image_error(sum_.mean(int(counts_.iterations), desc_.render.spp).beauty, *o_.reference)
                .rel_mse;
    report_.iterations.push_back(it);
    if (!progressive_ || quiet_) return;
    char radii[100] = "";
    if (setup_.photon())
        std::snprintf(radii, sizeof radii, ", radii %.4g %.4g %.4g", it.radii.global,
                      it.radii.caustic, it.radii.volume);
    std::fprintf(stderr, "progressive: iteration %d, %.1f s%s%s\n", it.index, it.elapsed_s, radii,
                 running_error ? (", relMSE " + std::to_string(it.rel_mse)).c_str() : "");
}

/// After round `round`, with iterations 1 .. `ran` run: whether the run stops, the same answer on
/// every rank (the count is known to all, the time budget agreed on); writes a checkpoint when
/// one is due.
bool RunLoop::last_round(int ran, int round, double loop_start_s) {
    if (!progressive_) return true;
    const ProgressiveDesc& p = desc_.progressive;
    if (p.iterations > 0 && ran >= p.iterations) return true;
    if (next_look_ > 0 && ran >= next_look_) {
        if (target_reached()) return true;
        next_look_ *= 2;
    }
    // Out of time when another round would end further past the budget than this one ends
    // before it (a round taking the mean time so far): the run ends within half a round of it.
    const double now_s = timer_.seconds(), round_s = (now_s - loop_start_s) / (round + 1);
    const bool out_of_time = p.time_budget > 0.0f && now_s + 0.5 * round_s >= p.time_budget;
    if (ranks_ ? ranks_->any(out_of_time) : out_of_time) return true;
    // A checkpoint after a whole round: every iteration up to `ran` is in some rank's sum.
    const Checkpoints* const c = o_.checkpoints;
    if (c && c->every_s > 0.0) {
        const bool due = timer_.seconds() - checkpointed_s_ >= c->every_s;
        if (ranks_ ? ranks_->any(due) : due) {
            gather_to_root();
            if (root_) c->write(checkpoint(ran));
            checkpointed_s_ = timer_.seconds();
        }
    }
    return false;
}

/// At a look: whether the run stops, the same answer on every rank and for any rank count: the
/// error estimate of iterations 1 .. next_look_ (all of them in rank 0's sum, no later one
/// anywhere: iteration_cap) has its upper bound at the target, or its maps' bias² alone is
/// further above it than the run's iterations can bring it (bias_above_target; the report says
/// why the target was not reached).
bool RunLoop::target_reached() {
    gather_to_root();
    bool stop = false, bias = false;
    if (root_) {
        const int n = int(counts_.iterations);
        const ErrorEstimate e =
            estimate_error(sum_.mean(n, desc_.render.spp), run_spp(desc_, true, n));
        const bool reached = meets_target(e, desc_.progressive.target_relmse);
        const std::string why = reached ? "" : bias_above_target(e, n);
        if (!why.empty()) report_.error.unreached = why;
        bias = !why.empty();
        stop = reached || bias;
        if (!quiet_)
            std::fprintf(stderr, "target: %d iterations, relMSE %.3g [%.3g, %.3g]%s\n", n,
                         e.rel_mse.value, e.rel_mse.lo, e.rel_mse.hi,
                         reached       ? ", reached"
                         : why.empty() ? ""
                                       : ", stopped: the bias");
    }
    out_.bias_stopped = ranks_ ? ranks_->any(bias) : bias;
    return ranks_ ? ranks_->any(stop) : stop;
}

/// Why the target cannot be reached, or "": the maps' bias² alone (its 95% lower bound) is above
/// it, and more iterations would not bring it under within the run's iterations (its count, or
/// as many as its time budget allows at the pace so far). The radii shrink as r^d ∝ i^(α − 1)
/// (render/gather_params.h), the bias with r² and its square with r⁴: the discs' (d = 2), the
/// fastest, reach X after n (lo / X)^(1 / (2 (1 − α))) iterations.
std::string RunLoop::bias_above_target(const ErrorEstimate& e, int n) const {
    const ProgressiveDesc& p = desc_.progressive;
    if (!e.bias_valid || !(e.bias2.lo > p.target_relmse)) return "";
    const double shrink = 2.0 * (1.0 - std::min(double(p.alpha), 0.99));
    const double needed = n * std::pow(e.bias2.lo / p.target_relmse, 1.0 / shrink);
    double most = p.iterations > 0 ? p.iterations : std::numeric_limits<double>::infinity();
    if (p.time_budget > 0.0f) most = std::min(most, n * p.time_budget / timer_.seconds());
    if (needed <= most) return "";
    char text[320];
    std::snprintf(text, sizeof text,
                  "the maps' bias² alone, at least %.3g (95%%), is above the target, and the "
                  "radii shrink too slowly with iterations to bring it under in this run (about "
                  "%.3g iterations; stopped after %d): smaller radii (or more photons) or the "
                  "path tracer lower it",
                  e.bias2.lo, needed, n);
    return text;
}

/// The last iteration the next round may run: progressive.iterations, and with a target the
/// next look's count (no iteration past it may enter the sum it looks at); 0 = none.
int RunLoop::iteration_cap() const {
    int cap = desc_.progressive.iterations;
    // The measured iterations end a round of their own: later ones take their counts.
    if (setup_.measured > 0 && later_counts_.empty())
        cap = cap > 0 ? std::min(cap, setup_.measured) : setup_.measured;
    if (next_look_ == 0) return cap;
    return cap > 0 ? std::min(cap, next_look_) : next_look_;
}

/// Every rank's progressive sum and counts into rank 0's; the other ranks start again from zero.
void RunLoop::gather_to_root() {
    counts_.clamped = int64_t(sum_.clamped);
    std::vector<int64_t> c = counts_.pack();
    if (sum_.values.empty()) sum_ = empty_sum(setup_);
    if (ranks_) {
        const Timer reduce;
        ranks_->sum_to_root(&c);
        ranks_->sum_to_root(&sum_.values);
        add_phase(&report_, "reduce", reduce.seconds());
    }
    if (!root_) {
        c.assign(c.size(), 0);
        std::fill(sum_.values.begin(), sum_.values.end(), 0);
    }
    counts_ = Counts::unpack(c);
    sum_.clamped = uint64_t(counts_.clamped);
}

/// The ranks' films and counts onto rank 0; false on the other ranks (they hold no result) and
/// on a part, which leaves its sums as they are for PartMerge.
bool RunLoop::reduce() {
    if (o_.part) {
        PartSums& p = out_.part.emplace();
        counts_.clamped = int64_t(sum_.clamped);
        p.counts = counts_.pack();
        if (progressive_) {
            if (sum_.values.empty()) sum_ = empty_sum(setup_);
            p.values = std::move(sum_.values);
        } else {
            p.values = film_bits(out_.film);
            p.shape.map_variance = !out_.film.map_variance.pixels.empty();
            p.shape.bias_halves = int(out_.film.bias_halves.size());
            p.shape.batch_share = out_.film.batch_share;
        }
        p.report = std::move(report_);
        p.first = std::move(first_estimate_);
        return false;
    }
    if (progressive_) {
        gather_to_root();
        if (!root_) return false;
        // The last checkpoint holds every iteration: a later --resume with a larger budget
        // continues from here.
        const Checkpoints* const c = o_.checkpoints;
        if (c && c->every_s > 0.0) c->write(checkpoint(int(counts_.iterations)));
        out_.film = RunEnd{setup_, counts_, own_, speak_}.mean(sum_, &report_);
        return true;
    }
    if (n_ranks_ > 1) {
        // Each pixel is one rank's and 0 (bits 0) on the others: summing the values' bits as
        // integers gives rank 0 the very floats one process renders.
        std::vector<int64_t> c = counts_.pack();
        std::vector<int64_t> bits = film_bits(out_.film);
        const Timer reduce;
        ranks_->sum_to_root(&c);
        ranks_->sum_to_root(&bits);
        add_phase(&report_, "reduce", reduce.seconds());
        if (!root_) return false;
        set_film_bits(bits, &out_.film);
        counts_ = plain_sum(Counts::unpack(c), counts_);
    }
    if (o_.reference)
        report_.iterations.back().rel_mse = image_error(out_.film.beauty, *o_.reference).rel_mse;
    return true;
}

/// Rank 0's report from its counts and film.
void RunLoop::finish_report() {
    const ErrorEstimate* first = first_estimate_ ? &*first_estimate_ : nullptr;
    RunEnd{setup_, counts_, own_, speak_, first}.finish(&out_.film, &report_);
}

PipelineResult RunLoop::run() {
    const ThreadLimit threads(desc_.render.threads);
    begin();
    out_.setup = setup_;
    const double loop_start_s = timer_.seconds();
    int ran = base_;  // iterations 1 .. ran are in some rank's sum
    for (int round = 0;; ++round) {
        if (setup_.measured > 0 && later_counts_.empty() && ran >= setup_.measured)
            finish_measure();
        // Rank r runs iteration ran + r + 1 of each round, after the checkpoint's, up to the cap.
        const int i = progressive_ ? ran + my_rank_ + 1 : 1;
        const int cap = iteration_cap();
        if (!progressive_ || !(cap > 0 && i > cap)) {
            ++counts_.iterations;
            ++own_;
            IterationReport it;
            it.index = i;
            RenderStats stats;
            PassMeasure measure;
            Film film = run_iteration(i, &it, &stats, given_samples(i, &measure));
            if (i <= setup_.measured) add_measure(i, measure);
            accumulate(std::move(film), stats, it);
        }
        ran = cap > 0 ? std::min(ran + n_ranks_, cap) : ran + n_ranks_;
        if (last_round(ran, round, loop_start_s)) break;
    }
    // The grids kept for a next iteration are not needed by the mean and the estimate.
    end_buffers_ = VolumeMapEnd::Buffers{};
    sigma_table_.reset();
    if (reduce()) finish_report();
    return std::move(out_);
}

PipelineResult run_loaded(const RunSetup& setup, const Scene& scene, const RunOptions& o) {
    return RunLoop(setup, scene, o).run();
}

/// auto's answer to a target its photon run's bias alone put out of reach
/// (RunLoop::bias_above_target): the path tracer, unbiased, from the first iteration, within the
/// same time budget (the run's timer goes on); the report says so, with the photon run's time.
/// Every rank takes it (bias_stopped is every rank's).
PipelineResult unbiased_instead(const SceneDesc& file, const PipelineResult& photon,
                                const Scene& scene, const RunOptions& o) {
    const ErrorReport& e = photon.report.error;
    char text[300];
    std::snprintf(text, sizeof text,
                  "auto: photon mapping's bias² alone (at least %.3g after %d iterations) is above "
                  "the target relMSE %.3g: the path tracer, unbiased, renders it instead",
                  e.bias_lo, e.iterations, e.target);
    const bool speak = !o.ranks || o.ranks->rank() == 0;
    if (speak) say_warning(text);  // now, before the path run: the report takes it after
    const RunSetup path = resolve_picked(file, photon.setup, Integrator::Path, text);
    PipelineResult out = run_loaded(path, scene, o);
    double photon_s = 0.0;  // the photon run's phases but those the path run has again
    for (const auto& [name, s] : photon.report.phases_s)
        if (name != "load") photon_s += s;
    add_phase(&out.report, "photon run", photon_s);
    warn_in(&out.report, false, text);
    return out;
}

}  // namespace

uint64_t iteration_seed(uint64_t seed, int i, bool progressive) {
    return progressive ? mix64(seed * 0x9E3779B97F4A7C15ull + static_cast<uint64_t>(i)) : seed;
}

PipelineResult run_pipeline(const SceneDesc& desc, bool quiet, const Image* reference, Ranks* ranks,
                            const Checkpoints* checkpoints, const RunSetup* decided,
                            std::optional<TileShare> part) {
    RunSetup setup = decided ? *decided : resolve_run(desc);
    const ThreadLimit threads(desc.render.threads);  // loading (bricks) too
    const Timer timer;
    std::unique_ptr<const Scene> scene;
    agree_on_input(ranks, [&] { scene = load_scene(setup.run); });
    RunOptions o;
    o.load_s = timer.seconds();
    if (ranks && !setup.progressive)
        setup.share_tiles(TileShare{ranks->rank(), ranks->size(), ranks});
    if (part && !setup.progressive) setup.share_tiles(*part);
    o.quiet = quiet;
    o.reference = reference;
    o.ranks = ranks;
    o.part = part;
    o.checkpoints = checkpoints;
    o.timer = &timer;
    PipelineResult result = run_loaded(setup, *scene, o);
    // Checkpoints and parts fix the run's settings: there the bias stop ends the run.
    const bool fixed = part || (checkpoints && (checkpoints->resume || checkpoints->every_s > 0.0));
    if (!result.bias_stopped || desc.render.integrator != Integrator::Auto || fixed) return result;
    return unbiased_instead(desc, result, *scene, o);
}

FixedFilm empty_sum(const RunSetup& setup) {
    FixedFilm sum;
    sum.zero(setup.run.camera.width, setup.run.camera.height, /*layered=*/true,
             setup.photon_batches());
    return sum;
}

size_t part_value_count(const RunSetup& setup, const PartSums::FilmShape& shape) {
    const int w = setup.run.camera.width, h = setup.run.camera.height;
    if (setup.progressive)
        return FixedFilm::value_count(w, h, /*layered=*/true, setup.photon_batches());
    const size_t images = 1 + kLayerCount + kBatches + (shape.map_variance ? 1 : 0) +
                          size_t(std::max(shape.bias_halves, 0));
    return size_t(3) * w * h * images;
}

void PartMerge::add(PartSums part) {
    if (reports_.empty()) {
        first_counts_ = part.counts;
        reports_.push_back(std::move(part.report));
        sum_ = std::move(part);
        return;
    }
    FOGMAP_ASSERT(
        part.counts.size() == sum_.counts.size() && part.values.size() == sum_.values.size(),
        "the parts of one run have films and counts of one shape");
    // As MPI_SUM adds them: two's complement, wrapping (a corrupt part cannot make it undefined).
    const auto add = [](std::vector<int64_t>* sum, const std::vector<int64_t>& values) {
        for (size_t k = 0; k < sum->size(); ++k)
            (*sum)[k] = int64_t(uint64_t((*sum)[k]) + uint64_t(values[k]));
    };
    add(&sum_.counts, part.counts);
    add(&sum_.values, part.values);
    if (part.first) sum_.first = std::move(part.first);  // the part that ran iteration 1
    reports_.push_back(std::move(part.report));
}

PipelineResult PartMerge::finish(const RunSetup& setup, bool speak) {
    FOGMAP_ASSERT(!reports_.empty(), "a run has at least one part");
    const Counts own = Counts::unpack(first_counts_);
    const SceneDesc& d = setup.run;
    PipelineResult out;
    out.report = merged_report(std::move(reports_));
    if (setup.progressive) {
        const Counts sum = Counts::unpack(sum_.counts);
        FixedFilm film = empty_sum(setup);
        film.values = std::move(sum_.values);
        film.clamped = uint64_t(sum.clamped);
        const RunEnd end{setup, sum, int(own.iterations), speak,
                         sum_.first ? &*sum_.first : nullptr};
        out.film = end.mean(film, &out.report);
        end.finish(&out.film, &out.report);
        return out;
    }
    const Counts sum = plain_sum(Counts::unpack(sum_.counts), own);
    out.film = Film(d.camera.width, d.camera.height, /*layered=*/true);
    const PartSums::FilmShape& shape = sum_.shape;  // part 1's, every part's
    if (shape.map_variance) out.film.map_variance = Image(d.camera.width, d.camera.height);
    out.film.bias_halves.assign(size_t(shape.bias_halves), Image(d.camera.width, d.camera.height));
    out.film.batch_share = shape.batch_share;
    set_film_bits(sum_.values, &out.film);
    RunEnd{setup, sum, 1, speak}.finish(&out.film, &out.report);
    return out;
}

}  // namespace fogmap
