#pragma once
// A scalar density field read from an OpenVDB float grid (leaf voxels *and* active tiles), kept
// in index space. Sampling is trilinear between voxel centres at integer index points (OpenVDB's
// BoxSampler convention), with the background (forced to 0) outside, so density ramps to zero
// over the voxel beyond the outermost voxel centres. Voxel values that are NaN, ±Inf or negative
// are set to 0 and denormals flushed to 0 at load; the counts are kept in SanitizeStats.
// A coarse majorant grid (cells of kMajorantCell^3 voxels) bounds every trilinear sample inside
// each cell, for delta/ratio tracking and empty-space skipping.
// Thread-safety: a DensityGrid is immutable after load and shared const; each thread makes its
// own Sampler (it holds an OpenVDB ValueAccessor cache) — not thread-safe, copy per thread.
// OpenVDB headers stay in density_grid.cpp (pimpl).

#include "core/math.h"

#include <array>
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

/// Lists every grid of a VDB file. Throws InputError{path, "", reason} if unreadable.
std::vector<GridInfo> inspect_vdb(const std::string& path);

struct SanitizeStats {
    uint64_t nan = 0, inf = 0, negative = 0, denormal = 0;
    uint64_t total() const { return nan + inf + negative + denormal; }
};

/// Majorant grid: max density over the trilinear footprint of each coarse cell.
/// Cell (i,j,k) covers index-space points [origin + cell*i, origin + cell*(i+1)) per axis.
struct MajorantGrid {
    std::array<int, 3> origin{0, 0, 0};  ///< index coordinate of cell (0,0,0)'s lower corner
    std::array<int, 3> dims{0, 0, 0};    ///< number of cells per axis
    int cell = 8;                        ///< voxels per cell edge
    std::vector<float> max_density;      ///< dims[0]*dims[1]*dims[2], x fastest
    float at(int i, int j, int k) const {
        return max_density[(static_cast<size_t>(k) * dims[1] + j) * dims[0] + i];
    }
};

class DensityGrid {
public:
    static constexpr int kMajorantCell = 8;

    /// Reads float grid `grid_name` from `path`. `field` is the JSON pointer quoted in errors.
    /// Throws InputError: missing/unreadable file; no such grid (message lists the file's grids);
    /// grid not float (message names its type).
    static std::unique_ptr<DensityGrid> load(const std::string& path, const std::string& grid_name,
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

    /// Per-thread trilinear sampler. Not thread-safe: make one per thread/task.
    class Sampler {
    public:
        explicit Sampler(const DensityGrid& grid);
        ~Sampler();
        Sampler(Sampler&&) noexcept;
        Sampler(const Sampler&) = delete;
        /// Trilinear density at a continuous index-space point (voxel centres at integers).
        float density(const Vec3& p_index);

    private:
        struct Impl;
        std::unique_ptr<Impl> impl_;
    };

private:
    DensityGrid();
    struct Impl;
    std::unique_ptr<Impl> impl_;
    DMat4 index_to_world_{1.0};
    Box3 index_bounds_;
    float max_density_ = 0.0f;
    MajorantGrid majorants_;
    SanitizeStats sanitize_;
    uint64_t active_voxels_ = 0;
    std::string name_;
    friend class Sampler;
};

}  // namespace fogmap
