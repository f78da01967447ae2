#include "render/pilot.h"

#include "core/image.h"
#include "core/rng.h"
#include "render/metrics.h"
#include "render/path_tracer.h"
#include "render/pipeline.h"
#include "render/tiles.h"
#include "scene/scene.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <vector>

namespace fogmap {

namespace {

// The cost of each counted event in medium steps beside a render's (render/film.h, kRayWork),
// from the same least-squares fits: photon passes with their kd-tree: steps 0.91, interactions
// 6.7, within 11%; tables 0.8-2.2 per node.
constexpr double kInteractionWork = 7.0;  // a photon path's interaction (Embree, deposit)
constexpr double kNodeWork = 1.5;         // a node of a table built once per render

// Each pilot image takes about 1/kPilotShare of the render's samples, from at least
// kPilotMinTiles tiles, at kPilotSpp samples a pixel at least: at 1 spp (no N-rooks pixel
// positions) every candidate's relMSE came out 1.5-1.7x high on smoke.json, and the pick on
// smoke1 at three tenths of its σ went to the path tracer, 1.47x behind the photon integrator.
constexpr int kPilotShare = 512;
constexpr int kPilotMinTiles = 8;
constexpr int kPilotSpp = 4;
constexpr double kPilotMinPhotons = 1.0 / 16.0;
static_assert(kPilotSpp % kStrataGroup == 0, "the pilot's samples stratify as the render's");

// What the Plan adds to a photon pick: where its camera paths end in the volume map, if they do.
std::string map_end_words(const SceneDesc& desc) {
    if (desc.volume.gather_depth <= 0) return "";
    return " (camera paths ending in the volume map at vertex " +
           std::to_string(desc.volume.gather_depth) + ")";
}

}  // namespace

ShareLayout::ShareLayout(int width, int height, int count)
    : width_(width), height_(height), tiles_x_((width + kTile - 1) / kTile), count_(count) {
    const int tiles = tile_count(width, height);
    for (int t = 0; t < tiles; t += count) {
        offset_.push_back(size_);
        const TileRect r = tile_rect(width, height, t);
        size_ += size_t(r.x1 - r.x0) * size_t(r.y1 - r.y0);
    }
}

bool ShareLayout::contains(int x, int y) const {
    return ((y / kTile) * tiles_x_ + x / kTile) % count_ == 0;
}

size_t ShareLayout::index(int x, int y) const {
    const int t = (y / kTile) * tiles_x_ + x / kTile, x0 = (x / kTile) * kTile;
    return offset_[t / count_] + size_t(y % kTile) * size_t(std::min(kTile, width_ - x0)) +
           size_t(x - x0);
}

std::vector<Color> ShareLayout::gather(const Image& image) const {
    std::vector<Color> out(size_);
    for (int y = 0; y < height_; ++y)
        for (int x = 0; x < width_; ++x)
            if (contains(x, y)) out[index(x, y)] = image.at(x, y);
    return out;
}

Work work_units(const Report& r) {
    Work w;
    w.render = double(r.steps) + kRayWork * double(r.rays) + kLookupWork * double(r.lookups) +
               kGatheredWork * double(r.gathered);
    w.photons = double(r.photon_steps) + kInteractionWork * double(r.photon_interactions);
    w.fixed = kNodeWork * double(r.precompute_nodes);
    w.per_pixel = double(r.estimate_events);
    return w;
}

Pilot pilot_share(const SceneDesc& desc) {
    const int width = desc.camera.width, height = desc.camera.height;
    const int tiles_x = (width + kTile - 1) / kTile, tiles = tile_count(width, height);
    Pilot pilot;
    // As many tiles as the share allows at 4 spp (1 in 2048 / spp; all of them, at spp / 512,
    // from 2048 spp), for the variance of many pixels. A count prime to the tiles of a row
    // spreads the share diagonally, not in columns.
    const int least_spp = std::min(kPilotSpp, desc.render.spp);
    pilot.tile_count = std::clamp(kPilotShare * least_spp / desc.render.spp, 1,
                                  std::max(1, tiles / kPilotMinTiles));
    while (pilot.tile_count > 1 && std::gcd(pilot.tile_count, tiles_x) != 1) --pilot.tile_count;
    pilot.spp = std::max(least_spp, desc.render.spp * pilot.tile_count / kPilotShare);
    return pilot;
}

double pilot_samples_share(const SceneDesc& desc, const Pilot& pilot) {
    const double pixels = double(desc.camera.width) * desc.camera.height;
    const ShareLayout layout(desc.camera.width, desc.camera.height, pilot.tile_count);
    return 6.0 * double(layout.size()) * pilot.spp / (pixels * desc.render.spp);
}

namespace {

// What a pilot run scales by: f, the pilot's share of the render's samples, and f_photons, its
// share of the photons. Photon budgets and attempts scale with the samples, so that the map's
// variance stands to the camera paths' as in the render, but not below 1/16 (pilot.h).
struct PilotScale {
    explicit PilotScale(double share) : f(share), f_photons(std::max(f, kPilotMinPhotons)) {}
    /// A budget of n scaled, at least 1 unless n is 0.
    uint64_t scaled(uint64_t n) const {
        return n == 0 ? 0
                      : std::max<uint64_t>(1, static_cast<uint64_t>(std::llround(n * f_photons)));
    }
    double f, f_photons;
};

// The run of candidate `kind` with seed k: the share's tiles at the pilot's samples, photons
// scaled.
RunSetup candidate_run(const SceneDesc& desc, const Pilot& pilot, const PilotScale& scale,
                       Integrator kind, int k) {
    SceneDesc d = desc;
    d.render.integrator = kind;
    d.render.spp = pilot.spp;
    d.render.seed = pilot_seed(desc.render.seed, k);
    d.progressive.spp = pilot.spp;  // one iteration (iteration_size): the share's samples
    d.render.adaptive = false;      // the variance per sample of a uniform render, extrapolated
    RunSetup run_setup = resolve_run(d);
    run_setup.share_tiles(TileShare{0, pilot.tile_count});
    PhotonSettings& p = run_setup.photons;
    p.global = scale.scaled(desc.photons.global);
    p.caustic = scale.scaled(desc.photons.caustic);
    p.volume = scale.scaled(kind == Integrator::Photon ? volume_budget(desc)
                                                       : desc.photons.volume_or_default());
    p.max_emitted = scale.scaled(desc.photons.max_emitted);
    // The photon integrator's attempts rule, scaled; the guided tracer's volume map closes by it
    // too (else it would fill, in thin media after many times the work).
    p.volume_attempts = kind != Integrator::Path ? scale.scaled(volume_attempts(desc)) : 0;
    return run_setup;
}

// Candidate `kind`'s two runs: their share's pixels appended to *images, and the work they
// predict for the full render.
PilotCandidate run_candidate(const SceneDesc& desc, const Scene& scene, SharedTables* shared,
                             const Pilot& pilot, const PilotScale& scale, const ShareLayout& share,
                             Integrator kind, std::vector<std::vector<Color>>* images) {
    PilotCandidate c;
    c.integrator = kind;
    Work work;
    double pixels = 0.0;
    for (int k = 0; k < 2; ++k) {
        PipelineResult run =
            run_on_scene(candidate_run(desc, pilot, scale, kind, k), scene, shared);
        const Work w = work_units(run.report);
        work.render += 0.5 * w.render;
        work.photons += 0.5 * w.photons;
        work.per_pixel += 0.5 * w.per_pixel;
        work.fixed = std::max(work.fixed, w.fixed);  // shared tables: built once
        pixels = double(run.report.samples) / pilot.spp;
        images->push_back(share.gather(run.film.beauty));
    }
    // The full render: every pixel (the pilot has `pixels`) at 1/f the samples, 1/f_photons the
    // photons, and the tables once.
    const double all_pixels =
        double(desc.camera.width) * desc.camera.height / std::max(pixels, 1.0);
    c.work = work.fixed + work.photons / scale.f_photons + work.render * all_pixels / scale.f +
             work.per_pixel * all_pixels;
    return c;
}

// Per pixel of the share and channel, the median of the pilot's images.
std::vector<Color> share_median(const std::vector<std::vector<Color>>& images, size_t size) {
    std::vector<Color> median(size);
    std::vector<float> values(images.size());
    for (size_t i = 0; i < median.size(); ++i)
        for (int ch = 0; ch < 3; ++ch) {
            for (size_t k = 0; k < images.size(); ++k) values[k] = images[k][i][ch];
            std::sort(values.begin(), values.end());
            const size_t h = values.size() / 2;
            median[i][ch] = 0.5f * (values[h - 1] + values[h]);
        }
    return median;
}

// relMSE as bench measures it, Σ d² / (y² + kRelMseFloor) over pixels and channels, per candidate
// (*count: the values summed); d² estimated from two independent images a, b as (a − b)² / 2, y
// by the median of the pilot's images averaged over the pixel's 5 × 5 neighbourhood in the share.
// (Their mean at the pixel alone is so noisy, a firefly weighing its own pixel down, that the
// noisiest candidate's error came out 3x low at 1 spp on the Disney cloud.)
std::vector<double> rel_mse_sums(const SceneDesc& desc, const ShareLayout& share,
                                 const std::vector<std::vector<Color>>& images, double* count) {
    const int width = desc.camera.width, height = desc.camera.height;
    const std::vector<Color> median = share_median(images, share.size());
    std::vector<double> sums(images.size() / 2, 0.0);
    for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x) {
            if (!share.contains(x, y)) continue;
            DVec3 value(0.0);
            double n = 0.0;
            for (int v = std::max(0, y - 2); v <= std::min(height - 1, y + 2); ++v)
                for (int u = std::max(0, x - 2); u <= std::min(width - 1, x + 2); ++u)
                    if (share.contains(u, v)) {
                        value += DVec3(median[share.index(u, v)]);
                        n += 1.0;
                    }
            value /= n;
            const size_t i = share.index(x, y);
            for (int ch = 0; ch < 3; ++ch) {
                for (size_t c = 0; c < sums.size(); ++c) {
                    const double d = double(images[2 * c][i][ch]) - images[2 * c + 1][i][ch];
                    sums[c] += relative_squared_error(0.5 * d * d, value[ch]);
                }
                *count += 1.0;
            }
        }
    return sums;
}

}  // namespace

uint64_t pilot_seed(uint64_t seed, int k) {
    return derive_seed(seed, stream::kPilot, static_cast<uint64_t>(k));
}

Pilot run_pilot(const SceneDesc& desc, const Scene& scene, SharedTables* shared) {
    Pilot pilot = pilot_share(desc);
    const PilotScale scale(double(pilot.spp) / desc.render.spp);
    const ShareLayout share(desc.camera.width, desc.camera.height, pilot.tile_count);
    std::vector<std::vector<Color>> images;  // candidate c, seed k at 2c + k: the share's pixels
    for (const Integrator kind : {Integrator::Photon, Integrator::Path, Integrator::Guided})
        pilot.candidates.push_back(
            run_candidate(desc, scene, shared, pilot, scale, share, kind, &images));
    double count = 0.0;
    const std::vector<double> sums = rel_mse_sums(desc, share, images, &count);
    for (size_t c = 0; c < sums.size(); ++c) {
        pilot.candidates[c].rel_mse = count > 0.0 ? scale.f * sums[c] / count : 0.0;
        if (pilot.candidates[c].score() < pilot.candidates[pilot.best].score()) pilot.best = c;
    }
    return pilot;
}

SceneDesc piloted_desc(const SceneDesc& file, const RunSetup& setup) {
    SceneDesc desc = file;
    desc.render.integrator = Integrator::Photon;
    desc.volume.gather_depth = setup.run.volume.gather_depth;
    return desc;
}

namespace {

// Why `desc` (piloted_desc's) takes the photon integrator without a pilot, or "" where one runs.
std::string no_pilot_reason(const SceneDesc& desc) {
    const std::string why = "auto: media under sun, sky or area lights, and ";
    if (desc.progressive.enabled())
        return why +
               "progressive iterations (a count, a time budget or a target): photon mapping, "
               "whose radii shrink with them (no pilot)";
    const Pilot share = pilot_share(desc);
    if (share.spp > kPilotMaxShare * desc.render.spp)
        return why + std::to_string(desc.render.spp) + " spp, where a pilot (" +
               std::to_string(share.spp) +
               " spp, its photon runs tracing a quarter of the render's photons or more) would "
               "cost more than it saves: photon without one" +
               map_end_words(desc);
    if (const double f = pilot_samples_share(desc, share); f > kPilotMaxSamples) {
        char text[64];
        std::snprintf(text, sizeof text, "%.0f%%", 100.0 * f);
        return why + "a render of " + std::to_string(desc.camera.width) + " x " +
               std::to_string(desc.camera.height) + " x " + std::to_string(desc.render.spp) +
               " spp, whose pilot would take " + text +
               " of its camera samples: photon without one" + map_end_words(desc);
    }
    return "";
}

}  // namespace

RunSetup decline_pilot(const SceneDesc& file, RunSetup setup) {
    if (!setup.pilot) return setup;
    if (const std::string why = no_pilot_reason(piloted_desc(file, setup)); !why.empty()) {
        setup.pilot = false;
        setup.set_reason(why);
    }
    return setup;
}

RunSetup settle_pilot(const SceneDesc& file, RunSetup setup, const Scene& scene,
                      SharedTables* shared, bool* piloted) {
    if (piloted) *piloted = false;
    setup = decline_pilot(file, std::move(setup));
    if (!setup.pilot) return setup;
    setup.pilot = false;
    const SceneDesc desc = piloted_desc(file, setup);
    const Pilot pilot = run_pilot(desc, scene, shared);
    if (piloted) *piloted = true;
    const PilotCandidate& best = pilot.candidates[pilot.best];
    std::string scores;
    for (const PilotCandidate& c : pilot.candidates) {
        char text[64];
        std::snprintf(text, sizeof text, "%s%s %.2g", scores.empty() ? "" : ", ",
                      to_string(c.integrator), best.score() > 0.0 ? c.score() / best.score() : 1.0);
        scores += text;
    }
    char text[160];
    std::snprintf(text, sizeof text,
                  "; a pilot (1 in %d tiles, %d spp, two seeds) measured relMSE x work relative "
                  "to the best: ",
                  pilot.tile_count, pilot.spp);
    std::string reason = "auto: media under sun, sky or area lights" + std::string(text) + scores +
                         " -> " + to_string(best.integrator);
    if (best.integrator == Integrator::Photon) reason += map_end_words(desc);
    RunSetup picked = resolve_picked(file, setup, best.integrator, reason);
    // As piloted: the guided tracer's volume map closes by the photon integrator's attempts rule.
    if (best.integrator == Integrator::Guided)
        picked.photons.volume_attempts = volume_attempts(desc);
    return picked;
}

}  // namespace fogmap
