#pragma once
// Beam radiance estimate (Jarosz, Zwicker, Jensen 2008) over a volume photon map: every photon
// gets a radius (the distance to its k-th neighbour, at most a maximum; one query serves the
// photons of a hierarchy leaf that lie within its radius), a bounding-volume
// hierarchy over the photon spheres is built, and one query per camera-ray segment visits every
// photon whose sphere the segment crosses. The 2D kernel is the sphere estimate's kernel
// integrated along the ray, K(d) = 3 sqrt(r² − d²) / (2π r³), so the beam estimate is the line
// integral of the spherical estimate Σ p ΔΦ / ((4/3) π r³) (with the transmittance taken at each
// photon's closest point) and the two agree in the limit. The photons are copied out decoded,
// in leaf order (48 bytes each), so a query reads them sequentially and decodes nothing.
// Immutable after construction; queries are thread-safe.

#include "photon/bvh.h"
#include "photon/estimators.h"
#include "photon/photon_pass.h"

#include <cstdint>
#include <vector>

namespace fogmap {

class BeamTree {
public:
    /// Radii: distance to the k-th nearest photon, clamped to (0, r_max] (the leaf's first
    /// photon's, for the photons of its leaf within that distance); with k <= 0, r_max for every
    /// photon. Radii in parallel.
    BeamTree(const PhotonMap& map, int k, float r_max);

    /// A photon as queries read it.
    struct Record {
        Vec3 position;
        float r2;        ///< squared radius
        Vec3 direction;  ///< travel direction
        float norm;      ///< 3 / (2π r³): K(d) = norm · sqrt(r² − d²)
        Color power;     ///< relative power, as stored (× the map's photon_power: watts)
        uint32_t batch;  ///< Photon::batch
    };

    /// Calls f(const Record&, float t, float kernel) for each photon whose sphere meets the ray
    /// segment o + t d, t in [t0, t1] (unit d): t is the photon's closest point along the ray
    /// (clamped into the part of the segment within the sphere), kernel = the uniform kernel
    /// 3 / (4π r³) integrated over that part, in 1/area: K(d) = norm · sqrt(r² − d²) for a chord
    /// the segment holds whole. Clipping matters where a segment starts inside the medium (a
    /// camera in fog) or ends there (at a surface): whole chords there would count the photons
    /// behind the camera too (docs/why.md).
    /// With `kInner`, f(const Record&, float t, float kernel, float inner) also has the kernel of
    /// the photon's sphere of radius r/√2 (the uniform kernel at that radius, normalised for it;
    /// 0 where the segment misses that sphere): RadiusBias's estimate over r/√2.
    template <bool kInner = false, class F>
    void for_each_hit(const Ray& ray, float t0, float t1, F&& f) const;

    size_t bytes() const;
    /// The photons with their radii, grouped by leaf.
    const std::vector<Record>& records() const { return records_; }

private:
    std::vector<Record> records_;  ///< grouped by leaf
    Bvh bvh_;                      ///< over the photon spheres
};

template <bool kInner, class F>
void BeamTree::for_each_hit(const Ray& ray, float t0, float t1, F&& f) const {
    bvh_.for_each_leaf(ray, t0, t1, [&](uint32_t begin, uint32_t end) {
        for (uint32_t i = begin; i < end; ++i) {
            const Record& p = records_[i];
            // In double: r² − d² of a grazing chord cancels most of a float's digits.
            const DVec3 v = DVec3(p.position) - DVec3(ray.o);
            const double t = glm::dot(v, DVec3(ray.d));
            const DVec3 closest = v - t * DVec3(ray.d);
            const double d2 = glm::dot(closest, closest);
            if (d2 >= p.r2) continue;
            const double h = std::sqrt(p.r2 - d2);
            const double a = std::max<double>(t - h, t0), b = std::min<double>(t + h, t1);
            if (!(b > a)) continue;
            const float at = static_cast<float>(std::clamp(t, a, b));
            const float kernel = p.norm * static_cast<float>(0.5 * (b - a));
            if constexpr (kInner) {
                const float in2 = static_cast<float>(0.5 * double(p.r2) - d2);
                float inner = 0.0f;
                if (in2 > 0.0f) {  // in float: an estimate of bias, not the image
                    const float hi = std::sqrt(in2), tf = static_cast<float>(t);
                    const float ai = std::max(tf - hi, t0), bi = std::min(tf + hi, t1);
                    if (bi > ai) inner = p.norm * kBallKappa * 0.5f * (bi - ai);  // (r / (r/√2))³
                }
                f(p, at, kernel, inner);
            } else {
                f(p, at, kernel);
            }
        }
    });
}

}  // namespace fogmap
