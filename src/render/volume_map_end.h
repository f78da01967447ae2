#pragma once
// The volume photon map at the end of a camera path (volume.gather_depth; docs/design.md,
// Ending camera paths in the volume map). With gather_depth = D the photon integrator traces
// camera paths as the path tracer does, with next-event estimation at every vertex; at a medium
// vertex x that is the path's D-th scattering vertex (in media and on diffuse surfaces: a ground
// point sees the map over its hemisphere) it adds the light that reached x after at least one
// interaction (what the volume map holds; first interactions are left to shadow rays) and ends
// the path. The path needs ∫ f(ω, ω') L_i(x, ω') dω' there (σ_s/σ_t is in the path weight): the
// map's σ_s L_i = Σ f ΔΦ_p / V over the photons within r, divided by σ̄_s(x), σ_s averaged over
// the same ball, so the estimate is the σ_s-weighted average of L_i over the ball.
// Why: the D − 1 sampled bounces average the map's noise as a final gather does (Jensen 1996),
// and σ̄_s leaves no small denominator where photons are (docs/why.md).
// Immutable after construction; queries are thread-safe.

#include "media/medium.h"
#include "media/phase.h"
#include "photon/estimators.h"
#include "photon/photon_pass.h"
#include "render/batches.h"
#include "scene/scene_desc.h"

#include <array>
#include <cmath>
#include <vector>

namespace fogmap {

/// advanced.gather_tau > 0: a path ends by its vertex kLatestEndFactor × gather_depth.
inline constexpr int kLatestEndFactor = 4;

/// The edge of the cube of a ball's volume, (4π/3)^⅓ r: where σ_s over a ball is wanted, its
/// average over this cube stands in (a box average is a summed-volume lookup).
inline float equal_volume_edge(float radius) { return std::cbrt(4.0f * kPi / 3.0f) * radius; }

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
    /// σ̄_s's channels summed, from the corners c about x: its value at x, its trilinear
    /// gradient, and along each axis the value on the cell's upper and lower faces, each
    /// interpolated over the other two axes as x's is (times 1 / cell).
    struct Slope {
        float value = 0.0f;
        Vec3 gradient{0.0f}, upper{0.0f}, lower{0.0f};
    };
    Slope slope(const Corners& c) const;
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
/// (σ_s does not change between progressive iterations). The cap: 2¹⁹ cells gave the error of
/// finer tables on smoke1 (docs/why.md).
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
    /// given back when this one is destroyed. `parts` other than None: lookups can also say each
    /// photon batch's share and each photon half's bias (Parts: PhotonBatches, RadiusBias below),
    /// of which the film keeps `parts`.
    struct Buffers;
    VolumeMapEnd(const PhotonMap& map, const std::vector<Medium>& media, float radius, int depth,
                 float k = 0.0f, float max_tau = 0.0f, Buffers* recycle = nullptr,
                 PhotonParts parts = PhotonParts::None);
    ~VolumeMapEnd();
    VolumeMapEnd(const VolumeMapEnd&) = delete;
    VolumeMapEnd& operator=(const VolumeMapEnd&) = delete;
    /// Some grid point's ball holds more than 2k photons: lookups there want a SigmaTable.
    bool wants_table() const { return crowded_anywhere_; }
    /// σ_s over boxes for AdaptiveRadius and RadiusBias (each grid point's κ, computed here):
    /// set once, before any lookup of a batched map (without it, one radius everywhere); must
    /// outlive this.
    void set_table(const SigmaTable* table);
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
    /// What a batched map's lookup says beside its estimate E (PhotonBatches, RadiusBias).
    struct Parts {
        std::array<float, Photon::kBatches> shares;  ///< E from batch t alone: E × shares[t]
        std::array<float, 2> bias;  ///< each photon half's estimate of E's bias, over E
    };
    /// `parts` (may be null): a batched map's parts (an unbatched map's: shares 1, bias 0).
    Color inscattered(const Vec3& x, const Vec3& dir, const PhaseMix& phase, NeighborList& scratch,
                      Parts* parts = nullptr) const;
    bool batched() const { return keeps_bias(parts_); }
    /// What a film of samples that end here keeps of the lookups' parts.
    PhotonParts parts() const { return parts_; }

    // PhotonBatches. Every photon is in one of Photon::kBatches batches of whole paths, so the
    // photons of one batch make an independent map kBatches times sparser. A lookup's estimate
    // from batch b alone is taken as the whole estimate times share_b = kBatches × (b's part of
    // what it gathered): a kd-tree lookup's part of the sum of phase × power, exactly; a grid
    // lookup's part of the power, the photons' directions taken as the whole's. From the batches'
    // estimates a film tells the variance one map read by every sample adds, which its batches of
    // samples cannot see (render/film.h, map_variance).

    // RadiusBias. The ball's blur errs by about c ρ² where the light is smooth, so an estimate
    // over the ball of radius ρ/√2 errs by half that, and 2 (E(ρ) − E(ρ/√2)) estimates E's bias
    // (Richardson). Each photon half (batches 0-3, 4-7) makes its own from its photons alone,
    // E_h(ρ) = E × 2 P_h / P and E_h(ρ/√2) = E_h(ρ) × (2^{3/2} P_h' / P_h) (σ̄(ρ) / σ̄(ρ/√2)),
    // P the lookup's sum (as the shares weigh it), P_h its half's, P_h' its half's within ρ/√2,
    // σ̄ from the SigmaTable's cubes (1 without a table; κ = 2^{3/2} σ̄(ρ) / σ̄(ρ/√2) kept per
    // grid point for the grid's lookups, whose ρ is r): two independent estimates of one bias,
    // whose product a film averages into bias² (render/film.h, BiasHalves). σ̄(ρ) / σ̄(ρ/√2) is
    // taken at most kMaxSigmaRatio: where the inner cube holds little of the medium the outer one
    // holds (a point just outside dense smoke), its few photons over its small σ̄ are no estimate,
    // and one such point made a whole image's bias² 0.23 (docs/error-estimate.md). What it leaves
    // out: blur on other scales than ρ (the grid's cells, ≈ r / 2), and the moments' cut series.
    static constexpr float kMaxSigmaRatio = 8.0f;

    /// Lookups interpolate the photons' directional moments (see Moments below); else they
    /// search the kd-tree, and the grid (when built) gives only the photon counts.
    bool interpolates() const { return phase_fits_ && !slot_.empty(); }
    /// Grid points built: the kernel density's and the moments'.
    size_t nodes() const { return density_.nodes() + slot_.size(); }

    /// Where the moments are kept: every medium fits_moment_grid (|g| <= kMomentGridMaxG,
    /// media/phase.h), the density grid at its full resolution (cells ≈ r / 2) and at most
    /// kMaxMomentNodes grid points with medium about them (124 bytes each). The phase's Legendre
    /// series cut after l = 2 misses at most Σ_{l≥3} (2l+1) (g g_p)^l / 4π of a photon field with
    /// Legendre moments g_p^l, such as once-scattered light (g_p = g): 3.6% of the l = 0 term at
    /// g 0.4 (docs/why.md).
    static constexpr size_t kMaxMomentNodes = size_t(1) << 21;
    /// Bytes the grids of a map of `budget` volume photons may take (the density grid, the
    /// moments with their batch sums and slots, and the σ_s table), for the memory pre-check.
    /// Their points follow the radius, which the map sets, so this is an envelope of measured
    /// runs (docs/measurements.md, Memory), never above the grids' caps.
    static double memory_bound(double budget);

    // FineEnough. A path ends at its D-th vertex only where σ̄_s r <= max_tau; elsewhere it
    // scatters on as in the path tracer and asks again at the next vertex, ending at vertex
    // kLatestEndFactor · D in any case. Where σ̄_s r exceeds max_tau the
    // smaller radius of AdaptiveRadius decides, from the grid's photon counts about the 8 points
    // kDecisionOffset r along each axis away from x (√3 r on average), which hold few of the
    // smaller ball's photons.
    // Why: a ball spanning several mean free paths blurs light that varies over one (under a
    // dense medium's lit face its σ_s-weighted average is darker than L_i at its centre), and a
    // count read at x would end paths where the lookup is high by the same chance (docs/why.md).
    static constexpr float kDecisionOffset = 1.0f;

    // AdaptiveRadius. Where the grid's ball holds n > 2k photons, the lookup gathers every photon
    // within r_a = r (k / n)^⅓ from the kd-tree (about k of them) and divides by σ_s averaged
    // over r_a's equal-volume cube (SigmaTable, built only when some grid point is crowded).
    // The caller scales k by (r / r₁)³ in progressive iterations, so r_a shrinks with r. Lookups
    // in the kd-tree (|g| > kMomentGridMaxG) take it too, the grid then holding only the counts
    // (k > 0).
    // Why: the map's one radius r, a median of k-th-neighbour distances, is set by a plume's thin,
    // wide parts and blurs its dense parts, where the light varies faster (docs/why.md).

    // LeanCorrection. The estimate is the σ_s-weighted average of the light over the ball, and
    // where σ_s varies across it that average is the light's at the σ_s-weighted centroid, not at
    // x: (ρ²/5) ∇σ_s / σ_s away (ρ the ball's radius; exact for linear σ_s and light). So the
    // estimate E is corrected to first order, E − (∂E/∂u) · offset along u = ∇σ̄_s / |∇σ̄_s|,
    // ∂E/∂u by central differences of the grid's estimate half a radius either side, the offset
    // at most a half ball's (3/8 ρ), the correction at most half of E; left out where the offset
    // is below kLeanMinOffset ρ, and where lookups search the kd-tree alone (|g| >
    // kMomentGridMaxG).
    // Why: uncorrected, the edge of a dense part leans into its darker inside (docs/why.md).
    static constexpr float kLeanMinOffset = 0.02f;

    // BlurCorrection, where lookups search the kd-tree (they have no LeanCorrection). Where σ_s
    // and the light both vary exponentially across the ball, σ_s ∝ e^{a·u} and L ∝ e^{b·u}, the
    // photons' density is ∝ σ_s L and the estimate is L(x) times the ball's mean of
    // e^{(a+b)·u} over the mean of e^{a·u} on the cube σ̄_s averages over (edge e): both above
    // 1, the first as 1 + s²/10 + s⁴/280 (s = |a + b| ρ), the second as the product over axes of
    // sinh(t)/t (t = a_i e / 2), each taken to fourth order. Under a dense medium's sun-lit face
    // the light falls off about exponentially, and the ball's average lies above its centre's
    // value. s comes from the photons' centroid, ρ (s/5 − s³/175 + …) along a + b, its square
    // from the product of the two photon halves' centroids (independent paths, so their noise
    // does not add to it; a half's own centroid squared would, and photons of one path
    // cluster); a = ∇σ̄_s / σ̄_s from the σ̄_s grid's cell about x, as the log of its two faces'
    // ratio along each axis (exact where σ_s is exponential, whose box averages vary as it
    // does; the trilinear slope where a face holds no medium). The estimate is divided by the
    // ratio, held within [kBlurFactorMin, kBlurFactorMax]; without a photon in each half it is
    // left as it is. It sees blur that follows a gradient; a symmetric bump is left to
    // RadiusBias.
    // Why: the Disney cloud's medium came out 1.4% bright at 16 spp (docs/why.md).
    static constexpr float kBlurFactorMin = 0.5f, kBlurFactorMax = 2.0f;

private:
    /// BlurCorrection's factor for a lookup within rho of x whose photon halves' centroids are
    /// `halves`.
    float blur_factor(float rho, const HalfCentroids& halves,
                      const KernelDensity::Corners& c) const;
    /// RadiusBias's κ at x for radius rho (kBallKappa without a table).
    float kappa(const Vec3& x, float rho) const;
    /// PhotonBatches' and RadiusBias's parts of a lookup from its batches' sums, whose inner sums
    /// are weighed by `kappa`.
    static void parts_of(const BatchSums& sums, float kappa, Parts* parts);
    /// The batches' sums at x from the grid's corners c, interpolated as the moments are, the
    /// inner ones weighed by each point's κ.
    BatchSums grid_sums(const KernelDensity::Corners& c) const;
    /// n photons within r call for AdaptiveRadius.
    bool crowded(float n) const { return table_ && k_ > 0.0f && n > 2.0f * k_; }
    /// `centroids` (may be null): its photon halves' centroids about x (volume_inscattered).
    Color smaller_ball(const Vec3& x, const Vec3& dir, const PhaseMix& phase, float n,
                       NeighborList& scratch, BatchSums* parts, HalfCentroids* centroids) const;
    // The estimate at a grid point p is Σ_p ΔΦ f(ω_p · ω_o) over the photons within r, and f's
    // Legendre series up to l = 2 makes it linear in the photons' moments Σ ΔΦ, Σ ΔΦ ω and
    // Σ ΔΦ ω ωᵀ: computed once per grid point, interpolated trilinearly at a lookup (one more
    // blur of a cell, ≈ r / 2, on the ball's r), and evaluated with the phase at x. This replaces
    // a kd-tree search of every photon within r per lookup by 8 grid points' reads (docs/why.md).
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
    /// capacity of the last one's instead of faulting in fresh pages (docs/why.md).
    struct Buffers {
        KernelDensity::Buffers density;
        std::vector<size_t> nodes;
        std::vector<int32_t> slot;
        std::vector<Moments> moments;
        std::vector<float> counts;
        std::vector<BatchSums> batch_power;
    };

private:
    struct Lattice;
    /// Moments for the grid points with medium about them (slot_, moments_); false, and none,
    /// above kMaxMomentNodes.
    bool assign_slots();
    /// Every photon's moments into the grid points within the radius of it.
    void add_photons();
    /// Photon p's into those of layer k (z) of lattice g.
    void add_photon(const Photon& p, const Lattice& g, int k);
    /// σ̄_s at x and, where the grid holds moments, the interpolated moments (else m stays 0);
    /// the corners used. False beyond the grid. `batches`: the corners' batch sums will be read
    /// (grid_sums), and are fetched from memory meanwhile.
    bool interpolate(const Vec3& x, Color* density, Moments* m, KernelDensity::Corners* c = nullptr,
                     bool batches = false) const;
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
    /// theirs: each photon batch's power, the channels' average (PhotonBatches), when batched_
    /// and moments_ are built; the inner sums weighed by κ (RadiusBias: each point's own once
    /// set_table has run)
    std::vector<BatchSums> batch_power_;
    const SigmaTable* table_ = nullptr;
    float k_;
    float max_tau_;
    bool crowded_anywhere_ = false;
    PhotonParts parts_;
};

}  // namespace fogmap
