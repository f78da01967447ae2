#include "media/emission.h"

#include "media/blackbody.h"

#include <algorithm>
#include <cmath>

namespace fogmap {

namespace {

constexpr int kTableSize = 4096;

}  // namespace

Emission Emission::constant(const EmissionParams& params) {
    Emission e;
    e.params_ = params;
    e.params_.kind = EmissionKind::Constant;
    return e;
}

Emission Emission::from_grid(const EmissionParams& params,
                             std::shared_ptr<const DensityGrid> grid) {
    Emission e;
    e.params_ = params;
    e.grid_ = std::move(grid);
    const float v_max = e.grid_->max_density();
    e.table_.resize(kTableSize + 1);
    e.running_max_.resize(kTableSize + 1);
    e.inv_step_ = v_max > 0.0f ? kTableSize / v_max : 0.0f;
    float running = 0.0f;
    for (int i = 0; i <= kTableSize; ++i) {
        const double v = v_max * double(i) / kTableSize;
        Color L;
        if (params.kind == EmissionKind::Blackbody) {
            const double kelvin = v * params.temperature_scale + params.temperature_offset;
            L = blackbody_radiance(kelvin) * params.scale;
        } else {
            L = static_cast<float>(v) * params.color * params.scale;
        }
        e.table_[i] = L;
        e.running_max_[i] = running = std::max(running, average(L));
    }
    return e;
}

Color Emission::radiance_of_value(float v) const {
    if (!grid_) return params_.color * params_.scale;
    const float x = std::clamp(v * inv_step_, 0.0f, float(kTableSize));
    const int i = std::min(static_cast<int>(x), kTableSize - 1);
    const float f = x - static_cast<float>(i);
    return table_[i] + (table_[i + 1] - table_[i]) * f;
}

float Emission::average_bound(float v) const {
    if (!grid_) return average(params_.color * params_.scale);
    const int i = static_cast<int>(std::ceil(std::clamp(v * inv_step_, 0.0f, float(kTableSize))));
    return running_max_[std::min(i, kTableSize)];
}

double Emission::max_kelvin() const {
    if (!grid_ || params_.kind != EmissionKind::Blackbody) return 0.0;
    return double(grid_->max_density()) * params_.temperature_scale + params_.temperature_offset;
}

}  // namespace fogmap
