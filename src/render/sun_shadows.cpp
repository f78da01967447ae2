#include "render/sun_shadows.h"

#include <algorithm>
#include <cmath>

namespace fogmap {

SunShadows::SunShadows(const std::vector<Light>& lights, const std::vector<Medium>& media,
                       float spacing_voxels) {
    if (!(spacing_voxels > 0.0f) || media.empty()) return;
    for (const Medium& m : media)
        if (!m.grid()) return;
    const float max_one_minus_cos = sun_one_minus_cos(kSunGridMaxRadiusDeg);
    const auto small_sun = [&](const Light& l) {
        return l.type == LightType::Sun && l.sun_one_minus_cos <= max_one_minus_cos;
    };
    size_t suns = 0;
    for (const Light& l : lights) suns += small_sun(l) ? 1 : 0;
    if (suns == 0) return;
    for (const Medium& m : media) sigma_t_.push_back(m.sigma_t());
    grids_.resize(lights.size());
    const size_t budget = std::max(kSunGridMaxNodes / (suns * media.size()), size_t(64));
    for (size_t i = 0; i < lights.size(); ++i) {
        if (!small_sun(lights[i])) continue;
        for (const Medium& m : media)
            grids_[i].emplace_back(m, -lights[i].direction, spacing_voxels * m.voxel_world(),
                                   budget);
    }
}

Color SunShadows::transmittance(size_t i, const Vec3& x) const {
    Color tau(0.0f);
    for (size_t m = 0; m < grids_[i].size(); ++m) tau += grids_[i][m].depth(x) * sigma_t_[m];
    return Color(std::exp(-tau.x), std::exp(-tau.y), std::exp(-tau.z));
}

size_t SunShadows::grids() const {
    size_t n = 0;
    for (const auto& g : grids_) n += g.size();
    return n;
}

size_t SunShadows::nodes() const {
    size_t n = 0;
    for (const auto& g : grids_)
        for (const LightDepth& d : g) n += d.nodes();
    return n;
}

}  // namespace fogmap
