#pragma once
// Procedural density grids fogmap generates itself (the bundled volumes/), and a writer for
// small test grids. Output is a VDB file with one float fog-volume grid named "density"
// (values in [0, 1], background 0) — the fireball adds a "temperature" grid in kelvin —
// written atomically (temp file + rename).

#include "core/math.h"

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace fogmap {

enum class VolumeShape { Cloud, Plume, Fireball };

struct VolumeGenSettings {
    VolumeShape shape = VolumeShape::Plume;
    int resolution = 64;       ///< voxels along the longest axis
    float voxel_size = 0.05f;  ///< world units per voxel
    uint64_t seed = 1;         ///< noise seed
    float time = 0.0f;         ///< frame of a sequence: the noise field drifts upward with it
    /// Plume and fireball: also a vec3s grid "vel", the velocity of that drift in world units per
    /// second at kVelocityFps (uniform, over the density's voxels and 2 around them).
    bool velocity = false;
};

/// The frame rate the generated "vel" grid assumes (camera.shutter.fps's default).
inline constexpr float kVelocityFps = 24.0f;

/// Writes a procedural cloud (billowy fBm blob), plume (rising, widening, turbulent column) or
/// fireball (a billowing hot core, up to ~2500 K, under a rising column of smoke that cools
/// with height to ~600 K; density and temperature grids), with settings.velocity their motion.
/// Throws std::runtime_error naming the path on I/O failure.
void generate_volume(const VolumeGenSettings& settings, const std::string& path);

/// About the most memory generate_volume takes for `settings` (0 when small, at most 128^3):
/// the leaves of the grids made at two coarser resolutions (at most 256^3: a few seconds),
/// extrapolated as a volume's and a surface's, and a quarter more.
uint64_t volume_memory_estimate(const VolumeGenSettings& settings);

/// A float grid "name" whose voxel (i,j,k) for 0 <= i < nx, ... holds value(i,j,k) (zero values
/// stay inactive), with per-axis voxel sizes (world units) and an index→world translation.
struct FloatGridSpec {
    std::string name;
    int nx = 1, ny = 1, nz = 1;
    std::function<float(int, int, int)> value;
    Vec3 voxel_size{1.0f};
    Vec3 translation{0.0f};
};

/// Writes the grids into one VDB file. For tests and fixtures. Throws std::runtime_error on I/O
/// failure.
void write_float_grids(const std::string& path, const std::vector<FloatGridSpec>& grids);

/// One grid: write_float_grids(path, {{name, nx, ny, nz, value, voxel_size, translation}}).
void write_float_grid(const std::string& path, const std::string& name, int nx, int ny, int nz,
                      const std::function<float(int, int, int)>& value,
                      Vec3 voxel_size = Vec3(1.0f), Vec3 translation = Vec3(0.0f));

}  // namespace fogmap
