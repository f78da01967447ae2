#pragma once
// auto's pilot for media under sun, sky or area lights (docs/design.md, Choosing an integrator): each
// candidate integrator — photon with camera paths ending in the volume map, path, guided —
// renders a share of the image's tiles with about 1/512 of the render's samples (at 4 spp and
// from 8 tiles at least), twice with independent seeds; photon budgets and the volume map's
// attempts scale with the samples, but to 1/16 at least (fewer photons would widen the volume map's
// radius and end its camera paths later than the render's). The two images' difference gives each
// candidate's variance, hence the relMSE it would reach at the scene's sample count; the work it
// did, counted, gives the work of the whole render; the candidate with the least relMSE × work is
// picked; the pilot keeps only its tiles' pixels of each image. Work is counted (medium steps,
// Embree rays, lookups, gathered photons, photon interactions, table nodes, each weighed by its
// cost measured once: work_units), not timed, so the choice is the same on every run, machine,
// thread and rank count, as the image must be. The guided tracer's volume map closes by the photon
// integrator's attempts rule, in the pilot and when picked.

#include "core/image.h"
#include "render/run_setup.h"
#include "scene/scene_desc.h"

#include <cstdint>
#include <string>
#include <vector>

namespace fogmap {

struct Report;
struct Scene;
struct SharedTables;

/// A report's work in units of one medium step (a density evaluation or a tentative collision):
/// the render's, the photon pass's, and the tables' built once per render (which do not grow
/// with the samples).
struct Work {
    double render = 0.0, photons = 0.0, fixed = 0.0;
    double per_pixel = 0.0;  ///< grows with the pixels, not the samples (the pixel estimate)
};
Work work_units(const Report& report);

struct PilotCandidate {
    Integrator integrator = Integrator::Path;
    double rel_mse = 0.0;  ///< predicted for the full render (channel-averaged, as bench's)
    double work = 0.0;     ///< predicted for the full render, work_units
    double score() const { return rel_mse * work; }
};

struct Pilot {
    int tile_count = 1;  ///< the pilot renders the tiles t ≡ 0 (mod tile_count)
    int spp = 1;         ///< per pilot image
    std::vector<PilotCandidate> candidates;  ///< photon, path, guided
    size_t best = 0;                         ///< the least score (the first of equal ones)
};

/// The pilot's pixels, the tiles t ≡ 0 (mod count) of render/tiles.h's kTile × kTile tiles
/// (rows of tiles in turn, the last ones clipped to the image), kept in one compact array: each
/// of those tiles' pixels row by row, the tiles in turn, so the pilot holds 1/count of an image
/// per run instead of a whole one. Immutable after construction.
class ShareLayout {
public:
    /// The share of a width × height image (both >= 1) at one tile in `count` (>= 1).
    ShareLayout(int width, int height, int count);
    /// The number of pixels in the share.
    size_t size() const { return size_; }
    /// Whether pixel (x, y) (0 <= x < width, 0 <= y < height) lies in the share's tiles.
    bool contains(int x, int y) const;
    /// The compact index, in [0, size()), of a pixel the share contains (else undefined).
    size_t index(int x, int y) const;
    /// The share's pixels of a whole image (width × height): image.at(x, y) at index(x, y).
    std::vector<Color> gather(const Image& image) const;

private:
    int width_, height_, tiles_x_, count_;
    std::vector<size_t> offset_;  ///< per tile of the share: the index of its first pixel
    size_t size_ = 0;
};

/// The tiles and samples per pixel of the pilot's images for `desc` (candidates and seeds
/// empty).
Pilot pilot_share(const SceneDesc& desc);

/// A pilot of more than this share of the render's samples per pixel (render.spp below 64 at
/// the pilot's 4) traces, in its four photon runs, more than a quarter of the render's photons
/// (all of them at 16 spp), and at 16-32 spp it cost more than it saved on every scene measured,
/// whichever integrator it picked (docs/measurements.md, Choosing an integrator). Below it,
/// settle_pilot takes the photon integrator without a pilot.
inline constexpr double kPilotMaxShare = 1.0 / 16.0;

/// Nor does a pilot run whose six images take more than this share of the render's camera
/// samples (small images, whose pilot is its 8 tiles at least): at 160x120 and 16-32 spp the
/// photon integrator without a pilot had 0.65-0.93 of auto's relMSE x time on smoke1 over the
/// ground, the Disney cloud and a uniform slab, and 0.43-0.51 on smoke1 at a tenth of its σ, where
/// the pilot picked the path tracer (docs/measurements.md, Choosing an integrator).
inline constexpr double kPilotMaxSamples = 0.05;

/// The share of the render's camera samples the pilot's six images of `pilot` (its tiles and
/// spp) take.
double pilot_samples_share(const SceneDesc& desc, const Pilot& pilot);

/// The seed of the pilot's run k (0 or 1) of each candidate for the render seed `seed`:
/// derive_seed(seed, stream::kPilot, k) (core/rng.h), so that the pairs of any two render seeds
/// share no seed and their picks are independent.
uint64_t pilot_seed(uint64_t seed, int k);

/// Runs the pilot of `desc` (render.integrator photon as auto resolved it for media under sun,
/// sky or area lights) on `scene`, loaded from it. Deterministic for a given description.
/// `shared` (may be null): the tables the pilot's runs share, and leave to the render.
Pilot run_pilot(const SceneDesc& desc, const Scene& scene, SharedTables* shared = nullptr);

/// What the pilot runs on (run_pilot's `desc`): `file` with the photon integrator at the volume
/// gather depth auto gave it in `setup` (resolve_run of `file`), before any split into iterations.
SceneDesc piloted_desc(const SceneDesc& file, const RunSetup& setup);

/// `setup` (resolve_run of `file`) with no pilot where none would run: progressive runs keep the
/// photon integrator (the others have no iterations), and so do renders of few samples
/// (kPilotMaxShare, kPilotMaxSamples), the reason saying why and setup.pilot false; otherwise
/// unchanged. It needs no scene, so a dry run says what the run will do.
RunSetup decline_pilot(const SceneDesc& file, RunSetup setup);

/// `setup` (resolve_run of `file`) with auto's pick settled: declined as decline_pilot says, else,
/// where setup.pilot, the pilot's pick re-resolved from `file`, the measured reason appended. A
/// setup without a pilot pending is returned unchanged. `piloted` (may be null): set to whether a
/// pilot ran.
RunSetup settle_pilot(const SceneDesc& file, RunSetup setup, const Scene& scene,
                      SharedTables* shared = nullptr, bool* piloted = nullptr);

}  // namespace fogmap
