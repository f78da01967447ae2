#include "render/volume_map_end.h"

#include "photon/estimators.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

namespace fogmap {

KernelDensity::KernelDensity(const std::vector<Medium>& media, float radius) {
    Box3 bounds;
    for (const Medium& m : media) bounds.extend(m.world_bounds());
    if (bounds.empty() || !(radius > 0.0f)) return;
    // The cube of the ball's volume, (4π/3)^⅓ r on a side, averaged over 3 points per axis.
    const float edge = std::cbrt(4.0f * kPi / 3.0f) * radius;
    const Vec3 extent = bounds.extent() + Vec3(4.0f * edge);
    cell_ = edge / 3.0f;
    const double volume = double(extent.x) * extent.y * extent.z;
    if (volume / (double(cell_) * cell_ * cell_) > double(kMaxCells))
        cell_ = static_cast<float>(std::cbrt(volume / double(kMaxCells)));
    origin_ = bounds.lo - Vec3(2.0f * edge);
    for (int a = 0; a < 3; ++a) dims_[a] = static_cast<int>(std::ceil(extent[a] / cell_)) + 1;
    const size_t nx = dims_[0], ny = dims_[1], nz = dims_[2];
    std::vector<Color> points(nx * ny * nz);
    tbb::parallel_for(0, dims_[2], [&](int k) {
        std::vector<Medium::Sampler> samplers;
        for (const Medium& m : media) samplers.emplace_back(m);
        for (size_t j = 0; j < ny; ++j)
            for (size_t i = 0; i < nx; ++i) {
                const Vec3 p = origin_ + cell_ * Vec3(float(i), float(j), float(k));
                Color s(0.0f);
                for (Medium::Sampler& sm : samplers) s += sm.density(p) * sm.medium().params().sigma_s;
                points[(k * ny + j) * nx + i] = s;
            }
    });
    // Separable 3-point box average (three passes: the last writes values_); outside the grid,
    // two cube edges beyond the media, σ_s is 0.
    values_.resize(points.size());
    const size_t stride[3] = {1, nx, nx * ny};
    for (int a = 0; a < 3; ++a) {
        std::vector<Color>& from = a % 2 == 0 ? points : values_;
        std::vector<Color>& to = a % 2 == 0 ? values_ : points;
        tbb::parallel_for(size_t(0), from.size(), [&](size_t n) {
            const size_t c = (n / stride[a]) % dims_[a];
            Color s = from[n];
            if (c > 0) s += from[n - stride[a]];
            if (c + 1 < size_t(dims_[a])) s += from[n + stride[a]];
            to[n] = s / 3.0f;
        });
    }
}

Color KernelDensity::at(const Vec3& x) const {
    if (values_.empty()) return Color(0.0f);
    const Vec3 u = (x - origin_) / cell_;
    int c[3];
    float f[3];
    for (int a = 0; a < 3; ++a) {
        if (!(u[a] >= 0.0f) || u[a] >= float(dims_[a] - 1)) return Color(0.0f);
        c[a] = static_cast<int>(u[a]);
        f[a] = u[a] - float(c[a]);
    }
    const size_t nx = dims_[0], ny = dims_[1];
    Color s(0.0f);
    for (int dz = 0; dz < 2; ++dz)
        for (int dy = 0; dy < 2; ++dy)
            for (int dx = 0; dx < 2; ++dx) {
                const float w = (dx ? f[0] : 1.0f - f[0]) * (dy ? f[1] : 1.0f - f[1]) *
                                (dz ? f[2] : 1.0f - f[2]);
                s += w * values_[((c[2] + dz) * ny + c[1] + dy) * nx + c[0] + dx];
            }
    return s;
}

VolumeMapEnd::VolumeMapEnd(const PhotonMap& map, const std::vector<Medium>& media, float radius,
                           int depth)
    : map_(map), radius_(radius), depth_(depth), density_(media, radius) {}

Color VolumeMapEnd::inscattered(const Vec3& x, const Vec3& dir, const PhaseMix& phase,
                                NeighborList& scratch) const {
    // σ_s L_i from every photon within the radius (k = 0: the fixed-radius sphere estimate).
    const Color collisions = volume_inscattered(map_, x, -dir, phase, 0, radius_, scratch);
    if (!(max_component(collisions) > 0.0f)) return Color(0.0f);
    const Color density = density_.at(x);
    Color out(0.0f);
    for (int c = 0; c < 3; ++c)
        if (density[c] > 0.0f) out[c] = collisions[c] / density[c];
    return out;
}

}  // namespace fogmap
