#pragma once
// What an emissive medium radiates (docs/design.md, Emission): L_e(x), entering the RTE as
// σ_a(x)·L_e(x). Constant (one colour), or from a grid of its own (its own active region and
// transform, sampled trilinearly like density): scalar (L_e = value · colour · scale) or blackbody
// (T = value · temperature_scale + temperature_offset kelvin, L_e = blackbody_radiance(T) ·
// scale; temperatures below 0 emit nothing). Grid values map to L_e through a table over
// [0, the grid's largest value], linear in between (exact for scalar grids; for blackbody 4096
// entries keep the interpolation within 1e-4 of Planck). Immutable; thread-safe.

#include "core/math.h"
#include "media/density_grid.h"

#include <array>
#include <memory>
#include <vector>

namespace fogmap {

enum class EmissionKind { Blackbody, Scalar, Constant };

/// The grids an emission without a named grid looks for in its medium's file, in this order
/// (Houdini's and Blender's names).
inline constexpr std::array<const char*, 4> kEmissionGridNames{"temperature", "heat", "flame",
                                                               "flames"};

struct EmissionParams {
    EmissionKind kind = EmissionKind::Constant;
    Color color{1.0f};  ///< scalar and constant: radiance per unit value (constant: L_e itself)
    float scale = 1.0f;
    float temperature_scale = 1.0f;   ///< blackbody: kelvin per grid unit
    float temperature_offset = 0.0f;  ///< blackbody: kelvin at grid value 0
};

class Emission {
public:
    /// L_e = params.color · params.scale everywhere (kind Constant).
    static Emission constant(const EmissionParams& params);
    /// L_e from `grid`'s values (kind Blackbody or Scalar).
    static Emission from_grid(const EmissionParams& params,
                              std::shared_ptr<const DensityGrid> grid);

    const EmissionParams& params() const { return params_; }
    /// The emission grid; null for constant emission.
    const DensityGrid* grid() const { return grid_.get(); }
    /// L_e of a grid value v >= 0 (constant emission: the constant).
    Color radiance_of_value(float v) const;
    /// An upper bound of average(L_e) over grid values in [0, v] (constant: its average).
    float average_bound(float v) const;
    /// Hottest temperature in the grid (blackbody), kelvin: largest value · scale + offset.
    double max_kelvin() const;

private:
    Emission() = default;
    EmissionParams params_;
    std::shared_ptr<const DensityGrid> grid_;
    std::vector<Color> table_;        ///< L_e at v = i / inv_step_
    std::vector<float> running_max_;  ///< max over j <= i of average(table_[j])
    float inv_step_ = 0.0f;
};

}  // namespace fogmap
