#include "photon/slab.h"

#include "core/error.h"
#include "core/rng.h"
#include "core/timer.h"
#include "media/volume_gen.h"
#include "photon/photon_pass.h"
#include "scene/scene.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <unistd.h>

#include <atomic>
#include <cmath>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

namespace fogmap {

namespace {

constexpr uint64_t kSlabStream = stream::kSlab;
constexpr uint64_t kChunk = 1024;

// Geometry (world units = slab thicknesses). The grid's voxel (i, j, k) sits at index point
// (i, j, k) and the density ramps to 0 over one voxel beyond the outer voxel centres
// (docs/design.md, Density between voxels), so ny voxels of height 1/ny, centred at
// y = −1 + (j + ½)/ny, give density 1 on [−1 + ½/ny, −½/ny] and ramps of one voxel above and
// below: the optical depth across is exactly σ_t · ny/ny = σ_t. Plane-parallel transport depends
// on depth only through the optical depth τ(y) (substitute dτ = σ_t(y) dy in the RTE), so the
// ramps leave Rd and Tt unchanged.
// Across x and z, 2 voxels of kWidth thicknesses: density 1 for |x|, |z| <= kWidth / 2, then a
// ramp to 0 at 3 kWidth / 2. The beam enters within ½ of the axis, so a photon reaches the sides
// only by travelling 100 thicknesses sideways: a single flight at |cos θ| < 0.01 that survives
// σ_t · 100 (probability < 0.01 e^{−100τ} per scattering), or a random walk of > 10⁴ steps in
// thick slabs. Escapes are classified by the sign of the direction's y, which in an infinite
// slab tells the face a photon leaves through; photons whose last interaction lies outside the
// uniform part are counted ("edge") and expected to be 0. Beyond τ = 100 the width (and the
// beam's) shrink as 100/τ: the same safety in optical depths, and coordinates small enough that
// float positions resolve the free paths of a τ = 1e6 slab (scene.cpp refuses media where they
// cannot).
constexpr float kWidth = 200.0f;

// Per photon: the power leaving up, down unscattered and down scattered.
struct Tally {
    double sum[3] = {0.0, 0.0, 0.0};
    double sum2[4] = {0.0, 0.0, 0.0, 0.0};  // squares of the three, and of down = [1] + [2]
    double capped_power = 0.0;              // power of the paths the bounce cap cut
    uint64_t absorbed = 0, bounce_cap = 0, edge = 0;
    uint64_t interactions = 0, steps = 0;  // the work traced (SlabResult)

    void add(const Tally& o) {
        for (int i = 0; i < 3; ++i) sum[i] += o.sum[i];
        for (int i = 0; i < 4; ++i) sum2[i] += o.sum2[i];
        capped_power += o.capped_power;
        absorbed += o.absorbed;
        bounce_cap += o.bounce_cap;
        edge += o.edge;
        interactions += o.interactions;
        steps += o.steps;
    }

    // Tallies a photon's path; `uniform_half`: the half width of the slab's uniform part.
    void record(const TracedPath& path, float uniform_half) {
        interactions += static_cast<uint64_t>(path.interactions);
        if (path.interactions > 0 &&
            (std::abs(path.ray.o.x) > uniform_half || std::abs(path.ray.o.z) > uniform_half))
            ++edge;
        if (path.end == PathEnd::Absorbed) {
            ++absorbed;
            return;
        }
        if (path.end == PathEnd::BounceCap) {
            ++bounce_cap;
            capped_power += average(path.power);
            return;
        }
        const double power = average(path.power);
        const int bin = path.ray.d.y > 0.0f ? 0 : path.interactions == 0 ? 1 : 2;
        sum[bin] += power;
        sum2[bin] += power * power;
        if (bin > 0) sum2[3] += power * power;  // up and down exclude each other
    }
};

SlabEstimate estimate(double sum, double sum2, uint64_t n) {
    SlabEstimate e;
    const double nd = static_cast<double>(n);
    e.mean = sum / nd;
    e.standard_error =
        n < 2 ? std::numeric_limits<double>::quiet_NaN()
              : std::sqrt(std::max(0.0, (sum2 - nd * e.mean * e.mean) / (nd - 1.0)) / nd);
    return e;
}

/// A temp VDB path unique to this process and call; the file is removed when this goes.
struct TempFile {
    std::string path;
    TempFile() {
        static std::atomic<uint64_t> counter{0};
        path =
            (std::filesystem::temp_directory_path() / ("fogmap-slab-" + std::to_string(::getpid()) +
                                                       "-" + std::to_string(counter++) + ".vdb"))
                .string();
    }
    ~TempFile() {
        std::error_code ec;
        std::filesystem::remove(path, ec);
    }
};

// The slab of optical thickness `tau` and `width` (Geometry above) as a scene: its grid written
// to a temp VDB file, loaded, and the file removed.
std::unique_ptr<Scene> slab_scene(const SlabSettings& s, double tau, float width) {
    TempFile vdb;
    const float hy = 1.0f / static_cast<float>(s.voxels);
    write_float_grid(
        vdb.path, "density", 2, s.voxels, 2, [](int, int, int) { return 1.0f; },
        Vec3(width, hy, width), Vec3(-0.5f * width, -1.0f + 0.5f * hy, -0.5f * width));
    SceneDesc desc;
    desc.path = "<slab>";
    MediumDesc m;
    m.type = MediumType::Vdb;
    m.file = vdb.path;
    m.sigma_s = Color(static_cast<float>(s.albedo * tau));  // tau per unit thickness
    m.sigma_a = Color(static_cast<float>((1.0 - s.albedo) * tau));
    m.g = static_cast<float>(s.g);
    desc.media.push_back(m);
    return load_scene(desc);
}

// The beam's s.photons photons through the slab of `width`, tallied in chunks of kChunk merged
// in index order.
Tally trace_beam(const SlabSettings& s, const Scene& scene, const PhotonTracer& tracer,
                 float width) {
    const float uniform_half = 0.5f * width, beam = width / kWidth;
    const uint64_t chunks = (s.photons + kChunk - 1) / kChunk;
    std::vector<Tally> tallies(chunks);
    tbb::parallel_for(tbb::blocked_range<uint64_t>(0, chunks, 1), [&](const auto& r) {
        std::vector<Medium::Sampler> samplers;
        for (const Medium& medium : scene.media) samplers.emplace_back(medium);
        for (uint64_t c = r.begin(); c != r.end(); ++c)
            for (uint64_t i = c * kChunk; i < std::min(s.photons, (c + 1) * kChunk); ++i) {
                Rng rng(s.seed, i, kSlabStream);
                // Collimated, normal incidence, entering within ½ thickness of the axis (scaled as
                // the width).
                const Vec3 o(beam * (rng.uniform() - 0.5f), 1.0f, beam * (rng.uniform() - 0.5f));
                tallies[c].record(tracer.trace(Ray{o, Vec3(0.0f, -1.0f, 0.0f)}, Color(1.0f), rng,
                                               samplers, 0, nullptr),
                                  uniform_half);
            }
        // Each sampler counts this range's steps alone; their sum does not depend on the split.
        for (const Medium::Sampler& m : samplers) tallies[r.begin()].steps += m.steps();
    });
    Tally total;
    for (const Tally& t : tallies) total.add(t);
    return total;
}

}  // namespace

double semi_infinite_tau(int max_bounces, double albedo) {
    // A photon reaches depth τ only if it survives k interactions (Russian roulette on the
    // albedo: probability albedo^k) or if its first k + 1 flights, unit-mean exponentials, sum to
    // more than τ: P(Γ(k, 1) > x k) <= exp(−k (x − 1 − ln x)) for x > 1 (Chernoff). Each term is
    // held below e^-61, so the sum stays below e^-60 (1e-26). k: max_bounces, or fewer where the
    // albedo ends every path sooner (579 at albedo 0.9), which keeps a thick slab's cost (the
    // tentative collisions in its density ramps grow as sqrt(τ)) independent of its τ.
    constexpr double kExponent = 61.0;
    double k = static_cast<double>(max_bounces);
    if (albedo < 1.0) k = std::min(k, std::ceil(kExponent / -std::log(albedo)));
    k += 1.0;
    double x = 1.0 + 1e-6;
    while (k * (x - 1.0 - std::log(x)) < kExponent) x *= 1.001;
    // At most 1e6: deeper, free paths fall below float resolution (scene.cpp refuses such media),
    // and no walk of up to 1e8 steps goes that deep (its depth spreads as sqrt(steps) free paths:
    // probability below e^-1000).
    return std::clamp(x * k, 100.0, 1e6);
}

SlabResult run_slab(const SlabSettings& s) {
    FOGMAP_ASSERT(s.tau >= 0.0 && s.albedo >= 0.0 && s.albedo <= 1.0 && std::abs(s.g) < 1.0 &&
                      s.photons > 0 && s.step_voxels > 0.0f && s.max_bounces >= 1 && s.voxels >= 1,
                  "slab settings out of range");
    const Timer timer;
    SlabResult result;
    result.photons = s.photons;
    // A slab thicker than the stand-in is the same medium for every photon that can be traced
    // (and a huge finite tau would leave float positions unable to advance a free path).
    result.tau_model = std::min(s.tau, semi_infinite_tau(s.max_bounces, s.albedo));
    result.tau_per_voxel = result.tau_model / s.voxels;
    const float width = kWidth * static_cast<float>(std::min(1.0, 100.0 / result.tau_model));
    const std::unique_ptr<Scene> scene = slab_scene(s, result.tau_model, width);

    MarchSettings march;
    march.method = s.method;
    march.step_voxels = s.step_voxels;
    const PhotonTracer tracer(*scene, march, s.max_bounces);  // no map: it stores nothing
    result.delta_in_march = s.method == FreePathMethod::March && tracer.marcher().any_stiff();
    const Tally total = trace_beam(s, *scene, tracer, width);
    result.rd = estimate(total.sum[0], total.sum2[0], s.photons);
    result.unscattered = estimate(total.sum[1], total.sum2[1], s.photons);
    result.td = estimate(total.sum[2], total.sum2[2], s.photons);
    result.tt = estimate(total.sum[1] + total.sum[2], total.sum2[3], s.photons);
    result.absorbed = total.absorbed;
    result.bounce_cap = total.bounce_cap;
    result.bounce_cap_power = total.capped_power / static_cast<double>(s.photons);
    result.edge = total.edge;
    result.interactions = total.interactions;
    result.steps = total.steps;
    result.time_s = timer.seconds();
    return result;
}

}  // namespace fogmap
