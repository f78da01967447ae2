#pragma once
// The sun's shadows inside and below grid media from tabulated optical depth (media/light_depth.h)
// instead of a ratio-tracked walk per shadow ray. The photon integrator's camera paths ask for
// the sun's transmittance at every vertex (up to three in media, and ground points); on smoke1
// over a ground the shadow rays' walks (sun and sky) were 31% of a 64-spp run's profile, and the
// grid (13.5·10⁶ nodes, 54 MB, 0.06–0.08 s) makes its render phase 24% faster. Surfaces still
// occlude by an Embree query. Only when every medium is a grid: homogeneous media keep their
// walks, which are exact there.
// Thread-safety: immutable after construction.

#include "media/light_depth.h"
#include "media/medium.h"
#include "scene/light.h"

#include <cstddef>
#include <vector>

namespace fogmap {

class SunShadows {
public:
    /// Grids for every sun light over every medium, nodes `spacing_voxels` × the medium's voxel
    /// apart; covers nothing when a medium has no grid or spacing_voxels <= 0.
    SunShadows(const std::vector<Light>& lights, const std::vector<Medium>& media,
               float spacing_voxels);

    /// Light `i`'s shadow rays take their media's transmittance from the grids.
    bool covers(size_t i) const { return i < grids_.size() && !grids_[i].empty(); }
    /// Transmittance of all media from x towards light i (covers(i)).
    Color transmittance(size_t i, const Vec3& x) const;
    /// Grids built and their bytes.
    size_t grids() const;
    size_t bytes() const;

private:
    std::vector<std::vector<LightDepth>> grids_;  ///< [light][medium]
    std::vector<Color> sigma_t_;                  ///< per medium
};

}  // namespace fogmap
