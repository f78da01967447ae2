#pragma once
// The sun's shadows inside and below grid media from tabulated optical depth (media/light_depth.h)
// instead of a ratio-tracked walk per shadow ray: the photon integrator's camera paths ask for the
// sun's transmittance at every vertex (up to three in media, and ground points), and those walks
// were a large share of its render time (docs/why.md). Surfaces still occlude by an Embree query.
// Only when every medium is a grid: homogeneous media keep their walks, which are exact there.
// Thread-safety: immutable after construction.

#include "media/light_depth.h"
#include "media/medium.h"
#include "scene/light.h"

#include <cstddef>
#include <vector>

namespace fogmap {

/// advanced.sun_grid: suns wider than this (angular radius, degrees) keep their shadow-ray walks;
/// the grid sees the sun's disc as its centre direction, and a wider penumbra is not a voxel's
/// blur.
inline constexpr float kSunGridMaxRadiusDeg = 1.0f;

/// Nodes of all grids' light-aligned boxes together; each grid grows its spacing to fit its
/// share (and stores only the nodes on its medium's chords, fewer).
inline constexpr size_t kSunGridMaxNodes = size_t(1) << 25;

class SunShadows {
public:
    /// Grids for every sun light of angular radius up to 1° over every medium, nodes
    /// `spacing_voxels` × the medium's voxel apart (or more, to fit kSunGridMaxNodes); covers
    /// nothing when a medium has no grid or spacing_voxels <= 0.
    SunShadows(const std::vector<Light>& lights, const std::vector<Medium>& media,
               float spacing_voxels);

    /// Light `i`'s shadow rays take their media's transmittance from the grids.
    bool covers(size_t i) const { return i < grids_.size() && !grids_[i].empty(); }
    /// Transmittance of all media from x towards light i (covers(i)).
    Color transmittance(size_t i, const Vec3& x) const;
    /// Grids built (suns covered × media).
    size_t grids() const;
    /// Nodes of all grids.
    size_t nodes() const;

private:
    std::vector<std::vector<LightDepth>> grids_;  ///< [light][medium]
    std::vector<Color> sigma_t_;                  ///< per medium
};

}  // namespace fogmap
