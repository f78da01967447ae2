#pragma once
// Participating media: σ_s(x) = density(x)·sigma_s, σ_a(x) = density(x)·sigma_a, homogeneous
// (density 1 inside a world box) or heterogeneous (a DensityGrid under the grid's own transform
// times the scene transform). Free paths are found by weighted delta tracking against
// piecewise-constant majorants (one per majorant cell, walked by a 3D DDA; empty cells are skipped)
// and transmittance by residual ratio tracking (Novák, Selle & Jarosz 2014) against each cell's
// minimum density as control: exp(−σ_t ∫ d_min) exactly, times ratio tracking of what lies above
// it, so homogeneous media and uniform cells add no variance. Several media superpose: their
// majorant processes are walked side by side and the nearest tentative collision is processed
// (Poisson superposition). Rays must have unit world-space direction; t is world distance.
// A grid medium may carry a colour grid C (Houdini's Cd, Blender's color): the scattering's albedo
// per channel, σ_s(x) = density·sigma_s·C(x) and σ_a(x) = density·(sigma_a + sigma_s·(1 − C(x))),
// so σ_t, and with it every majorant and transmittance, is the colourless medium's.
// A grid medium may carry a velocity grid v (Houdini's vel, Blender's velocity; world units per
// second) for motion blur: a sampler set to a time Δt (seconds from the frame) looks the density,
// colour and emission up where the fluid there was, x − v(x) Δt (Eulerian back-advection, one
// step, as production renderers do); the majorants and bounds are widened by the farthest such
// move, so tracking stays unbiased at every time.
// A medium may emit (media/emission.h): σ_a(x)·L_e(x) enters the RTE, and emission sampling
// draws points ∝ that source for photons (tables over majorant cells and then voxel cells,
// rejection within a voxel cell).
// Thread-safety: a Medium is immutable and shared const; Medium::Sampler is per thread.

#include "core/math.h"
#include "core/rng.h"
#include "media/density_grid.h"
#include "media/emission.h"

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

namespace fogmap {

/// Most media one scene may hold (scene loading rejects more).
constexpr int kMaxMedia = 16;

struct MediumParams {
    Color sigma_s{1.0f};  ///< per unit density, 1/world unit (density_scale already applied)
    Color sigma_a{0.0f};  ///< per unit density, 1/world unit
    float g = 0.0f;       ///< Henyey–Greenstein asymmetry
};

class Medium {
public:
    /// Density 1 inside `bounds_world` (world units), 0 outside.
    static Medium homogeneous(const MediumParams& params, const Box3& bounds_world);
    /// Density from `grid` (shared), placed by scene_transform * grid.index_to_world().
    static Medium heterogeneous(const MediumParams& params, std::shared_ptr<const DensityGrid> grid,
                                const Mat4& scene_transform);

    const MediumParams& params() const { return params_; }
    Color sigma_t() const { return params_.sigma_s + params_.sigma_a; }
    /// World-space box outside which the density is 0.
    const Box3& world_bounds() const { return world_bounds_; }
    const DensityGrid* grid() const { return grid_.get(); }
    /// Smallest world-space voxel edge of a grid medium; 0 for a homogeneous one.
    float voxel_world() const { return voxel_world_; }

    /// Colours the medium's scattering by `channels` (DensityGrid::load_channels), placed by
    /// scene_transform * their grid's own index_to_world. Load time only.
    void set_colour(std::array<std::shared_ptr<const DensityGrid>, 3> channels,
                    const Mat4& scene_transform);

    /// Moves the medium by `parts` (DensityGrid::load_velocity, world units per second in its
    /// grid's world, placed by scene_transform * its own index_to_world) for samplers set to
    /// times within ±max_seconds: widens the majorants and bounds by the farthest move. Before
    /// set_emission; load time only.
    void set_velocity(std::array<std::shared_ptr<const DensityGrid>, 6> parts,
                      const Mat4& scene_transform, float max_seconds);
    /// A bound of the speed (world units per second) of velocity `parts` placed by
    /// scene_transform: each axis's largest part, stretched by the map's Frobenius norm.
    static double max_speed(const std::array<std::shared_ptr<const DensityGrid>, 6>& parts,
                            const Mat4& scene_transform);
    /// The farthest a lookup moves (world units): max speed × max_seconds; 0 without velocity.
    float max_shift() const { return max_shift_; }

    /// Makes the medium emit; a grid emission is placed by scene_transform * its grid's own
    /// index_to_world (the density's scene transform). Load time only.
    void set_emission(Emission emission, const Mat4& scene_transform);
    /// The emission, or null.
    const Emission* emission() const { return emission_ ? &*emission_ : nullptr; }
    /// Radiant power the medium emits, 4π ∫ average(σ_a L_e) dV (W), estimated at set_emission
    /// from 65536 points of the sampling tables (fixed seeds: deterministic); 0 if it does not
    /// emit.
    double emitted_power() const { return emitted_power_; }
    /// 4π Σ over the emission table's cells of its bound × volume (W): the power one attempt of
    /// Sampler::sample_emission stands for, of which it accepts emitted_power / this on average.
    double emission_bound_power() const { return emission_bound_power_; }

    /// Per-thread access: density lookups and majorant walks. Not thread-safe; one per thread.
    class Sampler {
    public:
        explicit Sampler(const Medium& medium);
        const Medium& medium() const { return *medium_; }
        /// The time (seconds from the frame) of the lookups that follow (0 at construction): a
        /// medium with a velocity grid is looked up where it was then.
        void set_time(float seconds) { time_s_ = seconds; }
        /// Density at a world point (0 outside the medium).
        float density(const Vec3& p_world);
        /// L_e at a world point (0 outside the emission grid or when the medium does not emit).
        Color emission(const Vec3& p_world);
        /// σ_s per unit density at a world point: sigma_s, times the colour there when the
        /// medium has one (then 0 outside the colour grid).
        Color sigma_s_unit(const Vec3& p_world) {
            return colour_sampler_[0] ? coloured_sigma_s(p_world) : medium_->params_.sigma_s;
        }
        /// One attempt at a point ∝ average(σ_a L_e): a majorant cell, then a voxel-sized unit
        /// cell in it (corners at voxel centres), each ∝ its bound × volume, a uniform point in
        /// that, kept with probability average(σ_a L_e)(x) / the unit's bound. Unit bounds are
        /// exact maxima of the density (trilinear: the largest of the 8 corners) times bounds of
        /// L_e from the emission voxels around the unit's image in the emission grid. True, the
        /// point and the colour σ_a L_e / average(σ_a L_e) there, or false (rejected). Draws only
        /// from rng. A moving medium's point is drawn at rest and carried forward by its velocity
        /// over the sampler's time (x + v(x) Δt: exact for a uniform flow, approximate where the
        /// flow converges or shears).
        bool sample_emission(Rng& rng, Vec3* p_world, Color* color);
        /// Starts a walk of tentative collisions of the majorant process along the ray on
        /// [t0, t1]. Returns false if the medium is not met there. With `residual`, the process
        /// runs at the residual majorant (max − min density of each cell) × max σ_t, so a
        /// uniform cell yields no collision; control_density_length() then accumulates the
        /// control's ∫ d_min dt over the cells walked.
        bool begin_walk(const Ray& ray, float t0, float t1, bool residual = false);
        /// Next tentative collision: *t (world distance) and *sigma_maj (majorant of σ_t at
        /// *t — the residual majorant in a residual walk —, 1/world unit). False when the walk
        /// passes t1, or when it has produced kMaxTentatives collisions (then exhausted() is true
        /// until the next begin_walk).
        bool next_tentative(Rng& rng, float* t, float* sigma_maj);
        /// Residual walks: the control (minimum) density of the cell holding the last tentative.
        float control_density() const { return seg_min_; }
        /// Residual walks: ∫ d_min dt over the cells walked so far (world units × density); the
        /// whole walked range once next_tentative has returned false.
        double control_density_length() const { return control_length_; }

        /// Work bound per walk. Entering a grid, the density ramps from 0 over one voxel under a
        /// cell majorant, which costs ~sqrt(2 τ_voxel) null collisions (2e4 at τ_voxel = 2.5e8,
        /// 7e9 at 1e19): past this bound the medium is opaque at every scale a pixel resolves,
        /// and callers end the walk as if it were (delta_track: absorbed; ratio_track: T = 0).
        static constexpr uint32_t kMaxTentatives = 1000000;
        /// The current walk was cut at kMaxTentatives.
        bool exhausted() const { return exhausted_; }
        /// Walks cut at kMaxTentatives since this sampler was made (for reports).
        uint64_t exhausted_walks() const { return exhausted_walks_; }
        /// Density evaluations and tentative collisions since this sampler was made: the work
        /// the report counts (Report::steps).
        uint64_t steps() const { return steps_; }

    private:
        friend class Medium;
        bool next_segment();
        /// A tentative emission point: a unit cell ∝ bound × volume (its bound in *bound),
        /// uniform in it.
        Vec3 emission_point(Rng& rng, float* bound);
        const Medium* medium_;
        std::optional<DensityGrid::Sampler> grid_sampler_;
        std::optional<DensityGrid::Sampler> emission_sampler_;
        std::array<std::optional<DensityGrid::Sampler>, 3> colour_sampler_;
        Color coloured_sigma_s(const Vec3& p_world);
        /// Velocity at a world point (world units per second).
        Vec3 velocity(const Vec3& p_world);
        /// Where the fluid at p_world was at the sampler's time: p − v(p) Δt.
        /// The last point asked for is kept: density, colour and emission at one point look the
        /// velocity up once.
        Vec3 moved(const Vec3& p_world) {
            if (!moving_ || time_s_ == 0.0f) return p_world;
            if (p_world != moved_from_ || time_s_ != moved_time_) {
                moved_from_ = p_world;
                moved_time_ = time_s_;
                moved_to_ = p_world - velocity(p_world) * time_s_;
            }
            return moved_to_;
        }
        Vec3 moved_from_{kInfinity}, moved_to_{0.0f};
        float moved_time_ = 0.0f;
        /// The velocity's parts that are not 0 everywhere (the others are not looked up).
        std::array<std::optional<DensityGrid::Sampler>, 6> velocity_sampler_;
        bool moving_ = false;  ///< some part is not 0
        float time_s_ = 0.0f;
        // Walk state (index space for grids; t shared with world space). Distances are double:
        // in stiff media a step 1/σ_maj (1e-9 at density scale 1e9) is below a float's
        // resolution of t, and a float walk would stop advancing (a hang in empty space).
        double t_end_ = 0.0, seg_t0_ = 0.0, seg_t1_ = 0.0;
        float seg_maj_ = 0.0f;
        float seg_min_ = 0.0f;  ///< residual walks: control density of the segment
        bool residual_ = false;
        double control_length_ = 0.0;  ///< residual walks: ∫ d_min dt over segments entered
        int cell_[3] = {0, 0, 0}, step_[3] = {0, 0, 0};
        double t_next_[3] = {0, 0, 0}, t_delta_[3] = {0, 0, 0};
        bool walking_ = false;
        bool exhausted_ = false;
        uint32_t tentatives_ = 0;
        uint64_t exhausted_walks_ = 0;
        uint64_t steps_ = 0;
    };

private:
    Medium() = default;
    /// The walks' majorants: the grid's, or widened by the velocity's farthest move.
    const MajorantGrid& majorants() const {
        return moved_majorants_ ? *moved_majorants_ : grid_->majorants();
    }
    MediumParams params_;
    float sigma_t_max_ = 0.0f;  ///< max channel of sigma_t()
    Box3 world_bounds_;
    std::shared_ptr<const DensityGrid> grid_;
    Mat4 world_to_index_{1.0f};
    Mat4 index_to_world_{1.0f};
    float voxel_world_ = 0.0f;
    std::optional<Emission> emission_;
    Mat4 world_to_emission_index_{1.0f};
    std::array<std::shared_ptr<const DensityGrid>, 3> colour_;
    Mat4 world_to_colour_index_{1.0f};
    std::array<std::shared_ptr<const DensityGrid>, 6> velocity_;
    Mat4 world_to_velocity_index_{1.0f};
    Mat3 velocity_to_world_{1.0f};  ///< the scene transform's linear part
    float max_shift_ = 0.0f;
    std::optional<MajorantGrid> moved_majorants_;
    Box3 index_support_;  ///< index box outside which the density is 0 at every time
    /// Emission sampling, two levels: majorant cells (index into the majorant grid; 0 for a
    /// homogeneous medium's box) with the cumulative Σ bound × volume of their units; units
    /// [emission_cell_begin_[c], emission_cell_begin_[c + 1]) of cell c: local index (x + 8y +
    /// 64z), bound of average(σ_a L_e), and cumulative bound within the cell.
    std::vector<uint32_t> emission_cells_;
    std::vector<uint32_t> emission_cell_begin_;
    std::vector<double> emission_cdf_;
    std::vector<uint16_t> unit_local_;
    std::vector<float> unit_bounds_;
    std::vector<float> unit_cdf_;
    double unit_volume_ = 0.0;  ///< world volume of one unit (voxel; homogeneous: the box)
    double emitted_power_ = 0.0, emission_bound_power_ = 0.0;
};

/// Sets every sampler's time (Medium::Sampler::set_time).
inline void set_time(std::vector<Medium::Sampler>& media, float seconds) {
    for (Medium::Sampler& m : media) m.set_time(seconds);
}

enum class TrackEvent { Escaped, Scattered, Absorbed };

struct TrackResult {
    TrackEvent event = TrackEvent::Escaped;
    float t = 0.0f;   ///< distance of the scattering event
    int medium = -1;  ///< which medium scattered
};

/// What delta tracking does at a real collision.
enum class Collision {
    Analog,    ///< absorb with probability σ_a/σ_t (photons: power stays constant)
    Weighted,  ///< always scatter, *beta multiplied by the albedo σ_s/σ_t (camera paths, which
               ///< end by the caller's Russian roulette on the throughput)
};

/// The tentative-collision walks of every medium along one ray on (t0, t1), merged in distance
/// order (delta tracking, the camera segment's walk, the photon march's delta-tracked paths):
/// next() is the medium whose collision comes first; the caller advances that one's walk.
struct MergedWalks {
    std::array<float, kMaxMedia> t_next, mu;  ///< each medium's next collision (kInfinity: none)
                                              ///< and the majorant there
    int n;
    MergedWalks(std::vector<Medium::Sampler>& media, const Ray& ray, float t0, float t1, Rng& rng);
    /// The medium whose next tentative collision comes first; -1 when every walk has ended.
    int next() const;
};

/// Weighted delta tracking through all media on (0, t_max) of a unit-direction ray. Multiplies
/// *beta by the null/scatter weights (exactly 1 for grey media in Analog mode). Unbiased for any
/// majorant that bounds σ_t; t_max may be infinite. With `emitted`, adds the media's emission
/// seen along the ray: β σ_a L_e / μ at every tentative collision of an emitting medium, β the
/// throughput before the collision's weight (pbrt-v4's estimator: the tentative collisions are
/// a Poisson process of rate μ, so the sum's expectation is ∫ T σ_a L_e dt; unbiased).
TrackResult delta_track(std::vector<Medium::Sampler>& media, const Ray& ray, float t_max, Rng& rng,
                        Color* beta, Collision collision = Collision::Analog,
                        Color* emitted = nullptr);

/// One in-scattering point along a ray and the ray's transmittance, from one ratio-tracking walk
/// (no scattering decision): every tentative collision t_i of the majorant's Poisson process
/// scores a_i = T_i σ_s(t_i) / μ_i (T_i the ratio-tracking product before t_i, so Σ a_i is an
/// unbiased estimate of ∫ T σ_s dt); one t_i is picked ∝ average(a_i) and carries
/// weight = a_i Σ_j average(a_j) / average(a_i), so weight · f(t_pick) estimates ∫ T σ_s f dt
/// without bias for any f. `transmittance` is the walk's product at t_max (Russian roulette once
/// it falls below 0.1, as ratio_track). With `emitted`, adds T_i σ_a L_e / μ_i at every tentative
/// collision of an emitting medium.
struct InscatterPick {
    Color transmittance{1.0f};
    Color weight{0.0f};  ///< 0: no point picked (the ray misses every σ_s > 0)
    float t = 0.0f;
    int medium = -1;
};
InscatterPick ratio_track_pick(std::vector<Medium::Sampler>& media, const Ray& ray, float t_max,
                               Rng& rng, Color* emitted = nullptr);

/// Transmittance exp(−∫σ_t) on (0, t_max), per channel, by residual ratio tracking: the control
/// part exp(−σ_t ∫ d_min) exactly (all of it in homogeneous media and uniform cells), the residual
/// by ratio tracking with Russian roulette once its product falls below 0.1 (unbiased, bounded
/// work).
Color ratio_track(std::vector<Medium::Sampler>& media, const Ray& ray, float t_max, Rng& rng);

/// σ_s of every medium at world point p (density 0 outside a medium).
Color sigma_s_at(std::vector<Medium::Sampler>& media, const Vec3& p);

}  // namespace fogmap
