#pragma once
// Path guiding in media from the volume photon map (Jensen 1995; Vorba et al. 2014;
// docs/design.md, Guided path tracing). At a scattering vertex x of a path travelling along d,
// the k photons nearest to x say where light arrives from: photon j came travelling along d_j, so
// light reaches x from ω_j = −d_j. The guide is a mixture of von Mises–Fisher lobes around the
// ω_j, lobe j weighted by the photon's power times the phase function toward it (a product with
// the phase, so the lobes that matter for this path come first). Directions are drawn by
// one-sample MIS between the phase function (probability `phase_fraction`) and the guide, and
// always weighted by f / p_mix, never f / p_guide: a poor guide costs variance, never bias (with
// no photon near x the phase function alone is used). Immutable; the lobes are per vertex (per
// thread).

#include "core/rng.h"
#include "media/medium.h"
#include "media/phase.h"
#include "photon/kd_tree.h"
#include "photon/photon_pass.h"

#include <array>
#include <vector>

namespace fogmap {

/// Guiding settings; advanced.guide_vertices (`vertices`) is 0 unless a scene asks: guiding every
/// vertex made fireflies in long random walks, and guiding the first medium vertex only did not
/// beat the plain path tracer (docs/measurements.md; docs/why.md).
struct GuideSettings {
    int k = 16;                   ///< photons per guide
    float radius = 0.0f;          ///< world units: the largest distance of a guide photon
    float phase_fraction = 0.8f;  ///< probability of sampling the phase function, in (0, 1]
    float kappa = 20.0f;          ///< vMF concentration of each lobe (20: ~15° wide)
    int vertices = 0;             ///< medium vertices guided along a path (the first ones)
};

/// One vertex's guide: lobe axes and their cumulative normalised weights.
struct GuideLobes {
    std::vector<Vec3> axis;
    std::vector<float> cdf;
    bool empty() const { return axis.empty(); }
};

class VolumeGuide {
public:
    VolumeGuide(const PhotonMap& map, const GuideSettings& settings);

    /// The guide at x for a path travelling along unit `dir` through `phase`; empty when no photon
    /// lies within the radius or none scatters towards the path.
    void prepare(const Vec3& x, const Vec3& dir, const PhaseMix& phase, NeighborList& scratch,
                 GuideLobes* lobes) const;
    /// A direction for the path's next segment and its mixture pdf (solid angle).
    Vec3 sample(const GuideLobes& lobes, const PhaseMix& phase, const Vec3& dir, Rng& rng,
                float* pdf) const;
    /// The mixture pdf of choosing direction w.
    float pdf(const GuideLobes& lobes, const PhaseMix& phase, const Vec3& dir, const Vec3& w) const;
    const GuideSettings& settings() const { return settings_; }

private:
    float guide_pdf(const GuideLobes& lobes, const Vec3& w) const;

    const PhotonMap& map_;
    GuideSettings settings_;
};

/// The light to come at a medium vertex, for adjoint-driven splitting (Vorba & Křivánek 2016;
/// AdjointSplit in render/path_tracer.h): L̃(x, ω_o), the light that arrived after at least one
/// interaction scattered towards ω_o, from the volume map's photons binned in cubic cells:
/// Σ ΔΦ (1 + 3 a₁ ω_o · ω̄) / (4π V σ̄_s) per cell — the phase's Legendre series to l = 1, ω̄ the
/// photons' power-weighted mean direction, σ̄_s the mean of σ_s at kPoints³ points of the cell
/// (fewer points missed cells the medium fills in part; docs/why.md). One read a lookup: a rough
/// picture is enough, it decides how many paths go on, never what they carry. Cells hold at
/// least kMinPhotons photons to count (else L̃ = 0).
class AdjointGrid {
public:
    static constexpr size_t kMaxCells = size_t(1) << 18;
    static constexpr int kMinPhotons = 4;
    static constexpr int kPoints = 4;  ///< σ̄_s from kPoints³ points a cell
    /// Cells of edge `cell` (world units, > 0; larger where the grid would exceed kMaxCells)
    /// over the media's bounds.
    AdjointGrid(const PhotonMap& map, const std::vector<Medium>& media, float cell);
    /// Density evaluations the build made (the report counts them).
    size_t evaluations() const { return evaluations_; }
    /// L̃ at world point x towards −dir (dir: the path's travel direction into x) through
    /// `phase`, per channel; 0 beyond the grid.
    Color at(const Vec3& x, const Vec3& dir, const PhaseMix& phase) const;

private:
    bool cell_of(const Vec3& x, size_t* index) const;
    Vec3 origin_{0.0f};
    float cell_ = 1.0f;
    std::array<int, 3> dims_{0, 0, 0};
    std::vector<Color> values_;   ///< Σ ΔΦ / (4π V σ̄_s), x fastest
    std::vector<Vec3> mean_dir_;  ///< ω̄ (of the channels' average power)
    size_t evaluations_ = 0;
};

}  // namespace fogmap
