#pragma once
// The volume photon map at the end of a camera path (volume.gather_depth; README, "Ending camera
// paths in the volume map"). The photon integrator with gather_depth = D traces camera paths as
// the path tracer does, with next-event estimation at every vertex, and at a medium vertex x that
// is its D-th scattering vertex (in media and on diffuse surfaces) adds the light that reached x
// after at least one interaction — what the volume map holds (first interactions are left to
// shadow rays) — and ends the path. Seen through D − 1 sampled bounces, the map's low-frequency
// noise is averaged by every pixel's samples, as a surface final gather averages the global map
// (Jensen 1996); the walk's long tail costs one lookup instead of a random walk. A diffuse bounce
// averages the map as a medium's scattering does (a ground point sees it over its hemisphere), so
// it counts: paths from the ground end one medium vertex sooner. Counting medium vertices alone
// (64 spp, 8 seeds; 4 for smoke.json) cost relMSE +9% on smoke1 over a 10 km ground, +18% on the
// Disney cloud over it and +10% on smoke.json, at the same time; the ground's pixels gave most.
//
// At a vertex found by delta tracking the path needs ∫ f(ω, ω') L_i(x, ω') dω' (σ_s/σ_t is in
// the path weight). The map estimates the collision density σ_s L_i = Σ f ΔΦ_p / V over the
// photons within r; dividing by σ_s at x, or at each photon, has unbounded variance where the
// density varies inside the kernel (fireflies at smoke1's edges over a 10 km ground, 64 spp: relMSE
// 0.0027 and 0.0081 at D = 2, against 0.0014 for the path tracer), so it is divided by σ_s
// averaged over the same ball, σ̄_s(x) (0.00091): the estimate is then the σ_s-weighted average
// of L_i over the ball, a consistent blur, and no small denominator can occur where photons are.
// Immutable after construction; queries are thread-safe.

#include "media/medium.h"
#include "media/phase.h"
#include "photon/photon_pass.h"
#include "scene/scene_desc.h"

#include <array>
#include <vector>

namespace fogmap {

/// σ_s averaged over a ball of radius r about any point, for every medium together: a dense grid
/// over the media's bounds (grown by r) of the box average, over the equal-volume cube, of σ_s at
/// the grid's points, interpolated trilinearly. Cells are a third of the cube's edge (so the
/// average takes 3 × 3 × 3 points), or larger where the grid would exceed kMaxCells.
class KernelDensity {
public:
    static constexpr size_t kMaxCells = size_t(1) << 22;  ///< 12 bytes each: at most 50 MB
    /// Memory a grid leaves to the next one (VolumeMapEnd::Buffers).
    struct Buffers {
        std::vector<Color> points, values;
    };
    /// The grid for a ball of `radius` (world units, > 0; otherwise empty: at() is 0);
    /// `recycle` (may be null): build in its vectors' memory.
    KernelDensity(const std::vector<Medium>& media, float radius, Buffers* recycle = nullptr);
    /// The grid's memory into `to` (this grid is empty afterwards); a grid that returned before
    /// building took nothing and leaves `to` as it is.
    void give_back(Buffers* to) {
        if (!values_.empty()) to->values = std::move(values_);
    }
    /// σ̄_s at world point x, per channel (1/world unit); 0 beyond the grid.
    Color at(const Vec3& x) const;

    /// Trilinear interpolation at x: the 8 surrounding grid points and their weights.
    struct Corners {
        std::array<size_t, 8> node;
        std::array<float, 8> weight;
        std::array<Vec3, 8> gradient;  ///< of each weight (1/world unit)
    };
    /// False beyond the grid (or when it is empty).
    bool corners(const Vec3& x, Corners* c) const;
    size_t nodes() const { return values_.size(); }
    Vec3 node_position(size_t n) const;
    const Color& node_value(size_t n) const { return values_[n]; }
    float cell() const { return cell_; }
    const std::array<int, 3>& dims() const { return dims_; }

private:
    Vec3 origin_{0.0f};
    float cell_ = 1.0f;
    std::array<int, 3> dims_{0, 0, 0};
    std::vector<Color> values_;  ///< x fastest
};

/// σ_s integrated over axis-aligned boxes, for every medium together: a summed-volume table of
/// σ_s sampled at the centres of cubic cells (the media's finest voxel, or larger where the
/// table would exceed kMaxCells) over the media's bounds grown by `margin`. Built once per render
/// (σ_s does not change between progressive iterations). The cap: on smoke1 2¹⁹ cells (1.9 voxels,
/// 0.04 s) gave the same error as 2²¹ (1.2 voxels); 2¹⁷ (3 voxels) overshot its dense foot by 1.1%.
class SigmaTable {
public:
    static constexpr size_t kMaxCells = size_t(1) << 19;  ///< 24 bytes each: at most 12 MB
    SigmaTable(const std::vector<Medium>& media, float margin);
    /// σ_s averaged over the cube of edge `edge` about x (the cells' piecewise-constant σ_s,
    /// integrated exactly), per channel; 0 beyond the table.
    Color cube_average(const Vec3& x, float edge) const;
    /// Lattice points (each one density evaluation to build).
    size_t nodes() const { return sums_.size(); }

private:
    DVec3 integral_to(const Vec3& u) const;  ///< ∫ σ_s from the origin to lattice point u
    Vec3 origin_{0.0f};
    float cell_ = 1.0f;
    std::array<int, 3> dims_{0, 0, 0};  ///< lattice points per axis (cells + 1)
    std::vector<DVec3> sums_;           ///< x fastest
};

class VolumeMapEnd {
public:
    /// `map`: the volume map (photons after their first interaction), gathered within `radius`;
    /// paths end at a medium vertex that is their `depth`-th vertex (>= 1; diffuse surfaces
    /// count), or later where the ball spans more than `max_tau` > 0 scattering mean free paths
    /// (see FineEnough below).
    /// With k > 0 and a table (set_table), lookups where the grid's ball holds more than 2k
    /// photons gather within a smaller radius instead (see AdaptiveRadius below).
    /// `recycle` (may be null): memory the previous map's grids left (see Buffers), taken and
    /// given back when this one is destroyed.
    struct Buffers;
    VolumeMapEnd(const PhotonMap& map, const std::vector<Medium>& media, float radius, int depth,
                 float k = 0.0f, float max_tau = 0.0f, Buffers* recycle = nullptr);
    ~VolumeMapEnd();
    VolumeMapEnd(const VolumeMapEnd&) = delete;
    VolumeMapEnd& operator=(const VolumeMapEnd&) = delete;
    /// Some grid point's ball holds more than 2k photons: lookups there want a SigmaTable.
    bool wants_table() const { return crowded_anywhere_; }
    /// σ_s over boxes for AdaptiveRadius (may be null: one radius everywhere); must outlive this.
    void set_table(const SigmaTable* table) { table_ = table; }
    int depth() const { return depth_; }  ///< the first vertex paths may end at
    /// A medium vertex at x, the path's `vertex`-th (1-based; diffuse surface vertices count),
    /// ends it in the map (FineEnough).
    bool ends_at(const Vec3& x, int vertex) const {
        return vertex >= depth_ && (max_tau_ <= 0.0f || vertex >= kLatestEndFactor * depth_ ||
                                    optical_radius(x) <= max_tau_);
    }
    /// σ̄_s r at x: the scattering mean free paths the lookup's ball spans (the most scattering
    /// channel's), as FineEnough judges it: where the map's radius r spans more than max_tau,
    /// r is AdaptiveRadius's smaller one for the photon count about x (see FineEnough).
    float optical_radius(const Vec3& x) const;
    /// ∫ f(ω, ω') L_i(x, ω') dω' towards −dir (dir: the path's travel direction into x) for the
    /// light that arrived after at least one interaction, blurred over the ball of radius r.
    /// `scratch`: the calling thread's.
    Color inscattered(const Vec3& x, const Vec3& dir, const PhaseMix& phase,
                      NeighborList& scratch) const;

    /// Lookups interpolate the photons' directional moments (see Moments below); else they
    /// search the kd-tree, and the grid (when built) gives only the photon counts.
    bool interpolates() const { return phase_fits_ && !slot_.empty(); }
    /// Grid points built: the kernel density's and the moments'.
    size_t nodes() const { return density_.nodes() + slot_.size(); }

    /// Where the moments are kept: every medium fits_moment_grid (|g| <= kMomentGridMaxG,
    /// media/phase.h: the phase's Legendre series cut after l = 2 then misses at most
    /// Σ_{l≥3} (2l+1) (g g_p)^l / 4π of a photon field with Legendre moments g_p^l, such as
    /// once-scattered light (g_p = g): at g 0.4 that is 3.6% of the l = 0 term, forwards or
    /// backwards, and 0.5% at g 0.3; measured over the lookups of a render, the interpolated
    /// estimate's mean is 0.2% (smoke.json, g 0.3) and 1.4% (smoke1, g 0.4) below the exact
    /// one's), the density grid at its full resolution (cells ≈ r / 2) and at most
    /// kMaxMomentNodes grid points with medium about them (124 bytes each).
    static constexpr size_t kMaxMomentNodes = size_t(1) << 21;

    // FineEnough. A ball that spans several mean free paths blurs light that varies over one:
    // under the lit face of a dense medium L_i falls as exp(−σ_t d), and the ball's σ_s-weighted
    // average is darker than L_i at its centre. On smoke1 over the ground with σ 5× the bundled
    // value (σ_s 4; 64 spp, 4 seeds) ending every path at vertex 3 left its dense foot 12–22% dark
    // (10×10-pixel blocks) against the path tracer. So a path ends at its D-th vertex
    // only where σ̄_s r <= max_tau, else it scatters on as in the path tracer and asks again at
    // the next vertex, ending at vertex kLatestEndFactor · D (scene/scene_desc.h) in any case.
    // max_tau 1.5: that foot −5% at worst, relMSE × time 0.68× the unmodified render's and 0.56×
    // the path tracer's (max_tau 1 / 1.5 / 2: foot −4 / −5 / −6%, 0.76 / 0.68 / 0.70×); the
    // bundled smoke1 unchanged in error and time (at 1: +11% relMSE × time); smoke.json and the
    // Disney cloud never exceed it (bit-identical images).
    // Where σ̄_s r exceeds max_tau the smaller radius of AdaptiveRadius decides, and it follows
    // the photon count n in the ball: read at x, a count high by chance ended the path there
    // with a lookup high by the same chance (its estimate grows with n), and a low one sent it
    // on — the lookups that made the image were a biased sample of the map's noise. The bundled
    // cloud (σ_s 39.6, g 0.85) at 64×36, 256 spp, 147 000 photons, its lit medium against a
    // 65 536-spp path reference (16 seeds): +3.9 ± 0.5% at k 50, +2.5 ± 0.3% (32 seeds) at k 100;
    // with every path ending at vertex 3 (max_tau 0) +1.5% and +1.4%. So the decision reads the
    // count of the grid's balls about the 8 points kDecisionOffset r along each axis away (√3 r)
    // on average, which hold few of the smaller ball's photons (0.6 r: the ended lookups of
    // VolumeMapEnd.WhetherAPathEndsDoesNotFollowTheNoiseOfTheLookupsPhotons still +2–4% high).
    // Then +1.4 ± 0.5% at k 50, +2.1 ± 0.5% at k 100; the rest is the balls' blur at this
    // photon count (k 100: +4.9 ± 0.8% at 37 000 photons, +0.3 ± 0.2% at 590 000). On smoke1
    // over the ground (64 spp, 8 seeds) the high-by-chance lookups had lightened its dense foot's
    // blur: its worst 8 × 8 blocks −1.7% → −2.2%, relMSE 0.000549 → 0.000567.
    static constexpr float kDecisionOffset = 1.0f;

    // AdaptiveRadius. The map's one radius r, a median of k-th-neighbour distances, is set by a
    // plume's thin, wide parts; where photons crowd (dense parts, where the light also varies
    // over shorter distances) the ball's σ_s-weighted average blurs what r = 0.6 would show:
    // smoke1's dense foot over the ground (64 spp, 4 seeds) came out 5.0% darker than the path
    // tracer at r = 1.76 and 0.1% brighter at r = 0.6 (whose thin parts then double the
    // variance). So where the grid's ball holds n > 2k photons, the lookup gathers every photon
    // within r_a = r (k / n)^⅓ from the kd-tree (about k of them) and divides by σ_s averaged
    // over r_a's equal-volume cube (SigmaTable, built only when some grid point is crowded).
    // The caller scales k by (r / r₁)³ in progressive iterations, so r_a shrinks with r. Lookups
    // in the kd-tree (|g| > kMomentGridMaxG) take it too, the grid then holding only the counts
    // (k > 0): smoke1 over the ground with g 0.8 and 5× its σ (64 spp, 8 seeds) had its dense
    // foot's worst 10×10 block 5% dark with one radius, 1% with the rule (the path tracer's
    // −1%: noise), at the same relMSE × CPU time; the Disney cloud's relMSE moved 0.00543 →
    // 0.00544 (6 seeds) for 0.04 s more precompute per map.

    // LeanCorrection. The estimate is the σ_s-weighted average of the light over the ball, and
    // where σ_s varies across it that average is the light's at the σ_s-weighted centroid, not at
    // x: (ρ²/5) ∇σ_s / σ_s away (ρ the ball's radius; exact for linear σ_s and light). At the edge
    // of smoke1's dense foot it leans into the denser, darker inside: 2–4% dark 8 × 8-pixel
    // blocks over the ground that did not move with the phase's cut, the photons' tracking, the
    // sun's grid or the ground (README, "Choosing gather settings"), growing as ρ² (fixed radius
    // 0.7: ±1.6%, 1.0: −3.8%). So the estimate E is corrected to first order, E − (∂E/∂u) ·
    // offset along u = ∇σ̄_s / |∇σ̄_s|, ∂E/∂u by central differences of the grid's estimate half a
    // radius either side, the offset at most a half ball's (3/8 ρ), the correction at most half
    // of E (else, at 1 radius either side, a difference across a thin edge made one firefly that
    // doubled an 8-seed mean's block); left out where the offset is below kLeanMinOffset ρ, and
    // where lookups search the kd-tree alone (|g| > kMomentGridMaxG). smoke1 over the ground, 64
    // spp, 16 seeds: the mean image's 8 × 8-block bias² 1.6·10⁻⁵ → 4.7·10⁻⁶ (the foot's blocks
    // −3.5 / −3.3 / −2.8% → −2.4 / −1.3 / −1.3%), one image's relMSE 0.000556 → 0.000546, for
    // 1.03× the CPU time (9 paired runs); smoke.json unchanged (0.000379 → 0.000378, 6 seeds).
    // ∂E/∂u from the derivatives of the trilinear weights instead (no extra lookups) followed the
    // grid's cell-to-cell noise: relMSE +23%.
    static constexpr float kLeanMinOffset = 0.02f;

private:
    /// n photons within r call for AdaptiveRadius.
    bool crowded(float n) const { return table_ && k_ > 0.0f && n > 2.0f * k_; }
    Color smaller_ball(const Vec3& x, const Vec3& dir, const PhaseMix& phase, float n,
                       NeighborList& scratch) const;
    // The estimate at a grid point p is Σ_p ΔΦ f(ω_p · ω_o) over the photons within r, and f's
    // Legendre series up to l = 2 makes it linear in the photons' moments Σ ΔΦ, Σ ΔΦ ω and
    // Σ ΔΦ ω ωᵀ: computed once per grid point, interpolated trilinearly at a lookup (one more
    // blur of a cell, ≈ r / 2, on the ball's r), and evaluated with the phase at x. This replaces
    // a kd-tree search of every photon within r per lookup (22% of a gather_depth 3 render of
    // smoke.json) by 8 grid points' reads.
    struct Moments {
        Color m0{0.0f};                                                  ///< Σ ΔΦ
        float count = 0.0f;                                              ///< photons
        std::array<Color, 3> m1{Color(0.0f), Color(0.0f), Color(0.0f)};  ///< Σ ΔΦ ω_a
        std::array<Color, 6> m2{
            Color(0.0f), Color(0.0f), Color(0.0f),
            Color(0.0f), Color(0.0f), Color(0.0f)};  ///< Σ ΔΦ ω_a ω_b: xx, yy, zz, xy, xz, yz
    };

public:
    /// The grids' memory, kept between progressive iterations: a new map's vectors reuse the
    /// capacity of the last one's instead of faulting in fresh pages, which on smoke1 over the
    /// ground took 0.06–0.08 s of each iteration's 0.12 s of grids (20–27 MB of moments).
    struct Buffers {
        KernelDensity::Buffers density;
        std::vector<size_t> nodes;
        std::vector<int32_t> slot;
        std::vector<Moments> moments;
        std::vector<float> counts;
    };

private:
    /// σ̄_s at x and, where the grid holds moments, the interpolated moments (else m stays 0);
    /// the corners used. False beyond the grid.
    bool interpolate(const Vec3& x, Color* density, Moments* m,
                     KernelDensity::Corners* c = nullptr) const;
    /// The photon count interpolated at x as interpolate does, from counts_ (0 beyond the grid
    /// or without counts_).
    float count_at(const Vec3& x) const;
    /// Σ ΔΦ f(ω·ω_o) from moments (the l ≤ 2 series), per channel, towards o.
    static Color phase_sum(const Moments& m, const Vec3& o, const PhaseMix& phase);
    /// LeanCorrection: what to subtract from an estimate at x over a ball of radius `rho`,
    /// towards o (c: x's grid corners; density: σ̄_s at x).
    Color lean(const KernelDensity::Corners& c, const Vec3& x, const Color& density, const Vec3& o,
               const PhaseMix& phase, float rho) const;
    Buffers* recycle_;
    const PhotonMap& map_;
    float radius_;
    int depth_;
    KernelDensity density_;
    bool phase_fits_;               ///< every medium fits_moment_grid
    std::vector<int32_t> slot_;     ///< per grid point: its moments' index, or −1 (no medium)
    std::vector<Moments> moments_;  ///< grid points with medium about them
    std::vector<float> counts_;     ///< their photon counts, packed for FineEnough's decision
    const SigmaTable* table_ = nullptr;
    float k_;
    float max_tau_;
    bool crowded_anywhere_ = false;
};

}  // namespace fogmap
