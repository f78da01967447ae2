#pragma once
// Optical depth towards a distant light, tabulated once per render: a grid aligned with the
// light (columns along the direction towards it, nodes `spacing` apart on all three axes) over a
// medium's world bounds, each column a running sum of the density from the light's side (the
// density at each step's midpoint: one lookup per node). depth(x) interpolates it trilinearly:
// ∫ density ds from x towards the light, so the transmittance of medium m is exp(−σ_t,m · depth).
// Its error is the interpolation's between columns, h² τ''/8 (docs/why.md). The photon
// integrator's camera paths take the sun's shadow rays from it (render/sun_shadows.h): a
// ratio-tracked shadow ray walks the plume, this is eight loads.
// Thread-safety: immutable after construction; depth() is safe from any thread.

#include "core/math.h"
#include "media/medium.h"

#include <cstddef>
#include <vector>

namespace fogmap {

class LightDepth {
public:
    /// Tabulates `medium` (a grid medium) towards unit direction `to_light`, nodes `spacing`
    /// world units apart; the spacing grows (×1.26 steps) until the grid around the box has at
    /// most `max_nodes` nodes (it stores only those on the box's chords, about the box's volume
    /// / spacing³). Parallel over columns; deterministic.
    LightDepth(const Medium& medium, const Vec3& to_light, float spacing, size_t max_nodes);

    /// ∫ density ds from x towards the light (density × world length): 0 where the ray misses
    /// the medium's bounds.
    float depth(const Vec3& x) const;
    /// Nodes stored (each one density evaluation to build).
    size_t nodes() const { return depth_.size(); }

private:
    Vec3 u_{0.0f}, v_{0.0f}, w_{0.0f};  ///< light-space axes (w towards the light)
    Vec3 origin_{0.0f};                 ///< world position of node (0, 0, 0)
    float h_ = 0.0f;
    int n_[3] = {0, 0, 0};  ///< nodes per axis (columns n_[0] × n_[1], n_[2] along w)
    struct Column {
        size_t first = 0;  ///< depth_ index of node k0
        int k0 = 0;        ///< the lowest node stored (below it: the same depth)
        int count = 0;     ///< nodes stored (above them: 0); 0 = the line misses the box
    };
    std::vector<Column> columns_;  ///< j * n_[0] + i
    std::vector<float> depth_;
};

}  // namespace fogmap
