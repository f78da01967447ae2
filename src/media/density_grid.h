#pragma once
// A scalar density field read from an OpenVDB float grid (leaf voxels *and* active tiles), kept
// in index space. Sampling is trilinear between voxel centres at integer index points (OpenVDB's
// BoxSampler convention), with the background (forced to 0) outside, so density ramps to zero
// over the voxel beyond the outermost voxel centres. Voxel values that are NaN, ±Inf or negative
// are set to 0 and denormals flushed to 0 at load; the counts are kept in SanitizeStats.
// A coarse majorant grid (cells of kMajorantCell^3 voxels) bounds every trilinear sample inside
// each cell, for delta/ratio tracking and empty-space skipping.
// For sampling, load() copies each majorant cell's 9^3 footprint out of the tree, so that a sample
// costs about a dense array's (bench/march_bench.cpp): a cell holding one value (empty space, tile
// interiors) keeps that value, any other owns a brick of the 9^3 values stored as 16-bit steps
// between the footprint's least and greatest value (as NanoVDB's Fp16: 2 bytes a value, each
// within half a step, 1/131070 of the footprint's range, of the file's); the OpenVDB tree is then
// freed.
// Thread-safety: a DensityGrid is immutable after load and shared const. A Sampler holds only
// views of it (no cache), so density() is thread-safe; making one per thread/task stays the rule.
// OpenVDB headers stay in density_grid.cpp.

#include "core/math.h"

#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace fogmap {

/// What `fogmap info` prints for one grid of a VDB file.
struct GridInfo {
    std::string name;
    std::string value_type;  ///< "float", "double", "vec3s", ...
    std::string grid_class;  ///< "fog volume", "level set", "unknown", ...
    Vec3 voxel_size{0.0f};   ///< world units per voxel along x, y, z
    Vec3 translation{0.0f};  ///< index → world translation
    std::array<int, 3> index_min{0, 0, 0}, index_max{-1, -1, -1};  ///< active voxel bbox
    Box3 world_bounds;                                             ///< active bbox in world space
    uint64_t active_voxels = 0;  ///< including voxels covered by active tiles
    uint64_t active_tiles = 0;
    double min_value = 0.0, max_value = 0.0;  ///< over active values (scalar grids only)
    bool scalar = false;                      ///< min/max are meaningful
};

/// What reading grid `grid_name` of a VDB file will take, from the metadata OpenVDB writes with
/// each grid (read without the grid): its tree (file_mem_bytes) and, at most, a density
/// sampler's for its active box. Not known when the file lacks that metadata or cannot be read.
struct GridMemory {
    bool known = false;
    uint64_t tree = 0, sampler = 0;
    uint64_t cells = 0;  ///< the sampler's cells of 8^3 voxels
};
GridMemory grid_memory(const std::string& path, const std::string& grid_name);

/// Lists every grid of a VDB file. Throws InputError{path, "", reason} if unreadable.
std::vector<GridInfo> inspect_vdb(const std::string& path);

/// `fogmap __probe-vdb` (media/vdb_probe.h): the child reading a VDB file for its parent, which
/// receives what `what` asks: "info" (inspect_vdb), "density" (DensityGrid::load), "colour"
/// (load_channels) or "velocity" (load_velocity) of grid `grid`, built on `threads` threads
/// within `cpu_s` CPU seconds and `memory_bytes` of address space. Returns the exit code.
struct VdbChildTask {
    std::string what, path, grid;
    int threads = 0;
    double cpu_s = 0.0;
    uint64_t memory_bytes = 0;
};
int run_vdb_child(const VdbChildTask& task);

/// The grid names of a VDB file, in file order, from its header alone (no grid is read).
/// Throws InputError{path, field, reason} if unreadable.
std::vector<std::string> vdb_grid_names(const std::string& path, const std::string& field);

struct SanitizeStats {
    uint64_t nan = 0, inf = 0, negative = 0, denormal = 0;
    uint64_t total() const { return nan + inf + negative + denormal; }
};

/// Majorant grid: max and min density over the trilinear footprint of each coarse cell (the
/// max bounds delta and ratio tracking; the min is residual ratio tracking's control density).
/// Cell (i,j,k) covers index-space points [origin + cell*i, origin + cell*(i+1)) per axis.
struct MajorantGrid {
    std::array<int, 3> origin{0, 0, 0};  ///< index coordinate of cell (0,0,0)'s lower corner
    std::array<int, 3> dims{0, 0, 0};    ///< number of cells per axis
    int cell = 8;                        ///< voxels per cell edge
    std::vector<float> max_density;      ///< dims[0]*dims[1]*dims[2], x fastest
    std::vector<float> min_density;      ///< same layout; <= every sample in the cell
    size_t index(int i, int j, int k) const {
        return (static_cast<size_t>(k) * dims[1] + j) * dims[0] + i;
    }
    float at(int i, int j, int k) const { return max_density[index(i, j, k)]; }
    float min_at(int i, int j, int k) const { return min_density[index(i, j, k)]; }
};

namespace detail {

/// Sampling layout of a DensityGrid, one cell per majorant cell (same order as MajorantGrid).
/// Cell c's brick holds voxels c*8 .. c*8+8 per axis (its 8^3 voxels and the low faces of its
/// +1 neighbours: every 2^3 stencil of a point in the cell), x slowest, z fastest, as steps q:
/// a voxel's value is value + step * q.
inline constexpr int kBrickEdge = 9;
inline constexpr int kBrickValues = kBrickEdge * kBrickEdge * kBrickEdge;
inline constexpr int kBrickSteps = 65535;  ///< q in 0 .. kBrickSteps
struct BrickCell {
    int32_t brick = -1;  ///< index into Bricks::values / kBrickValues; -1: all 9^3 equal `value`
    float value = 0.0f;  ///< the one value, or the brick's least
    float step = 0.0f;   ///< the brick's (greatest − least) / kBrickSteps
};
struct Bricks {
    std::vector<BrickCell> cells;
    std::vector<uint16_t> values;
};

}  // namespace detail

class DensityGrid {
public:
    static constexpr int kMajorantCell = 8;

    /// Reads float grid `grid_name` from `path`: in a child process when the probe is on
    /// (vdb_probe.h; the same grid, sent back), else here. load_channels and load_velocity read
    /// likewise. `field` is the JSON pointer quoted in errors.
    /// Throws InputError: missing/unreadable file; no such grid (message lists the file's grids);
    /// grid not float (message names its type).
    static std::unique_ptr<DensityGrid> load(const std::string& path, const std::string& grid_name,
                                             const std::string& field);
    /// Reads vec3s grid `grid_name` (a colour per voxel) as one grid per channel, values above 1
    /// clamped to 1 (*clamped: how many channel values were, voxels of tiles counted); sampled
    /// as density grids are. Throws InputError as load, when the grid is not vec3s, or when a
    /// value is below 0 or not finite.
    static std::array<std::unique_ptr<DensityGrid>, 3> load_channels(const std::string& path,
                                                                     const std::string& grid_name,
                                                                     const std::string& field,
                                                                     uint64_t* clamped);
    /// Reads vec3s grid `grid_name` (a velocity per voxel) — or, where the file has no such grid,
    /// float grids grid_name.x, .y and .z of one transform (Houdini's split vector volumes) — as
    /// six grids, each axis's positive and negative part (x+, x-, y+, y-, z+, z-), so that a
    /// component is the difference of two samples (trilinear sampling is linear). Throws
    /// InputError as load, when the grid is not vec3s (or a component not float, or their
    /// transforms differ), or when a value is not finite.
    static std::array<std::unique_ptr<DensityGrid>, 6> load_velocity(const std::string& path,
                                                                     const std::string& grid_name,
                                                                     const std::string& field);
    ~DensityGrid();
    DensityGrid(const DensityGrid&) = delete;
    DensityGrid& operator=(const DensityGrid&) = delete;

    /// Grid index space → the grid's own world space (affine, possibly non-uniform scale).
    const DMat4& index_to_world() const { return index_to_world_; }
    /// Box (index space) outside which the density is exactly 0: active bbox grown by 1 voxel.
    const Box3& index_bounds() const { return index_bounds_; }
    /// True when the grid has no active value above 0 (renders as vacuum).
    bool empty() const { return index_bounds_.empty(); }
    float max_density() const { return max_density_; }
    const MajorantGrid& majorants() const { return majorants_; }
    const SanitizeStats& sanitize_stats() const { return sanitize_; }
    uint64_t active_voxels() const { return active_voxels_; }
    const std::string& name() const { return name_; }
    /// What load changed or found wrong (background, non-finite values, no density), one line
    /// each for the caller to print: under MPI only rank 0 speaks.
    const std::vector<std::string>& warnings() const { return warnings_; }

    /// Bytes of the sampling layout (cells and bricks): what the grid keeps after load.
    size_t sampler_bytes() const {
        return bricks_.cells.size() * sizeof(detail::BrickCell) +
               bricks_.values.capacity() * sizeof(uint16_t);
    }

    /// Trilinear sampler: a view of the grid's cells and bricks. Cheap to make; one per
    /// thread/task (density() only reads the shared grid, so it would also be safe to share).
    class Sampler {
    public:
        explicit Sampler(const DensityGrid& grid);
        Sampler(Sampler&&) noexcept = default;
        Sampler(const Sampler&) = delete;
        /// Trilinear density at a continuous index-space point (voxel centres at integers), 0
        /// outside the majorant grid (so outside index_bounds()). openvdb::tools::BoxSampler on
        /// the sanitized grid, but for the bricks' steps: within half a step of the cell's
        /// footprint (and float rounding); exact in a cell of one value. Inline: it is the
        /// march's inner loop.
        float density(const Vec3& p_index) const;

    private:
        const detail::BrickCell* cells_ = nullptr;
        const uint16_t* values_ = nullptr;
        std::array<int, 3> origin_{0, 0, 0};  ///< index coordinate of cell (0,0,0)
        int dim_x_ = 0, dim_y_ = 0;           ///< cells per axis (x, y)
        Vec3 lo_{0.0f}, hi_{0.0f};            ///< floor(p) in [lo_, hi_) lies in a cell
    };

private:
    DensityGrid() = default;
    friend struct GridBuilder;  ///< density_grid.cpp: a grid from an OpenVDB tree
    detail::Bricks bricks_;
    DMat4 index_to_world_{1.0};
    Box3 index_bounds_;
    float max_density_ = 0.0f;
    MajorantGrid majorants_;
    SanitizeStats sanitize_;
    uint64_t active_voxels_ = 0;
    std::string name_;
    std::vector<std::string> warnings_;
};

inline float DensityGrid::Sampler::density(const Vec3& p_index) const {
    static_assert(kMajorantCell == 8 && detail::kBrickEdge == kMajorantCell + 1,
                  "8^3 cells (>> 3, & 7 below) with a 1-voxel apron");
    const Vec3 f = glm::floor(p_index);
    // Float bounds first: also false for NaN, and keeps the int conversions in range.
    if (!(f.x >= lo_.x && f.y >= lo_.y && f.z >= lo_.z && f.x < hi_.x && f.y < hi_.y &&
          f.z < hi_.z))
        return 0.0f;
    const int i = static_cast<int>(f.x) - origin_[0], j = static_cast<int>(f.y) - origin_[1];
    const int k = static_cast<int>(f.z) - origin_[2];
    const detail::BrickCell cell =
        cells_[(static_cast<size_t>(k >> 3) * dim_y_ + (j >> 3)) * dim_x_ + (i >> 3)];
    if (cell.brick < 0) return cell.value;
    constexpr int kY = detail::kBrickEdge, kX = kY * kY;
    const uint16_t* c = values_ + static_cast<size_t>(cell.brick) * detail::kBrickValues +
                        ((i & 7) * kX + (j & 7) * kY + (k & 7));
    const Vec3 w = p_index - f;
    // BoxSampler's order (z, then y, then x) and form a + (b - a) t, on the steps (trilinear is
    // linear: value + step * q once at the end). The steps are exact floats and so are their
    // differences; a result stays within the least and greatest step, so the sample within the
    // cell's majorants (build_bricks), unless the compiler fuses a product into an FMA: fogmap
    // builds without -march.
    const auto lerp = [](float a, float b, float t) { return a + (b - a) * t; };
    const auto q = [c](int n) { return static_cast<float>(c[n]); };
    const float steps =
        lerp(lerp(lerp(q(0), q(1), w.z), lerp(q(kY), q(kY + 1), w.z), w.y),
             lerp(lerp(q(kX), q(kX + 1), w.z), lerp(q(kX + kY), q(kX + kY + 1), w.z), w.y), w.x);
    return cell.value + cell.step * steps;
}

}  // namespace fogmap
