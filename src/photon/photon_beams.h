#pragma once
// The photon-beam estimate's hierarchy (Jarosz, Nowrouzezahrai, Sadeghi, Jensen 2011;
// docs/design.md, Photon beams). The volume map's beams (photon.h) share one radius,
// map_radius(); they are cut into pieces at most kPieceRadii radii long so that bounding boxes
// stay tight, and a bounding-volume hierarchy over the pieces answers, for a camera-ray segment,
// every piece whose cylinder the segment crosses. A beam is blurred across its axis by the
// uniform 2D kernel 1/(π r²), so a camera ray's in-scattered radiance is
// Σ Φ_b σ_s f(θ) T / (π r²) × the length of the ray's chord through the cylinder, σ_s and T at
// the chord's point closest to the beam. Short beams: a beam's own transmittance is the
// probability that its free path got that far, so it is 1 here — which needs free paths sampled
// exactly ∝ transmittance, and the pipeline delta-tracks them (ray-marched free paths left the
// multiple scattering dark). The chord is bounded by the piece's length (the 1D kernel's
// 1/sin θ has infinite variance when beams run along camera rays), and the radius is one per map
// (a radius per beam blurred a plume's light out across its edges); docs/why.md.
// Immutable after construction; queries are thread-safe.

#include "photon/bvh.h"
#include "photon/photon_pass.h"

#include <cstdint>
#include <vector>

namespace fogmap {

class PhotonBeams {
public:
    /// Beams of `map` (map.beams), all with the radius map_radius(map, k, r_max).
    PhotonBeams(const PhotonMap& map, int k, float r_max);

    /// One radius for a map's beams: the median, over up to 4096 beams spread through the map,
    /// of the distance from the beam's midpoint to its k-th nearest point photon (r_max if there
    /// are fewer within r_max), clamped to (0, r_max]; r_max when k <= 0.
    static float map_radius(const PhotonMap& map, int k, float r_max);
    float radius() const { return radius_; }

    static constexpr float kPieceRadii = 8.0f;  ///< longest piece, in its radii

    /// A piece of a beam as queries read it.
    struct Piece {
        Vec3 start;
        float length;
        Vec3 dir;     ///< unit, the photon's travel direction
        Color power;  ///< relative power, as stored (× the map's photon_power: watts)
    };

    /// Calls f(const Piece&, float t, float kernel) for each piece whose finite cylinder of
    /// radius r = radius() the ray segment o + t d, t in [t0, t1] (unit d), crosses: t is the
    /// point of the chord closest to the piece's axis, kernel = chord length / (π r²) (1/area).
    template <class F>
    void for_each_hit(const Ray& ray, float t0, float t1, F&& f) const;

    size_t bytes() const;
    const std::vector<Piece>& pieces() const { return pieces_; }

private:
    float radius_;
    std::vector<Piece> pieces_;  ///< grouped by leaf
    Bvh bvh_;                    ///< over the pieces' capsules
};

template <class F>
void PhotonBeams::for_each_hit(const Ray& ray, float t0, float t1, F&& f) const {
    const DVec3 o(ray.o), d(ray.d);
    const double r2 = double(radius_) * radius_;
    bvh_.for_each_leaf(ray, t0, t1, [&](uint32_t begin, uint32_t end) {
        for (uint32_t i = begin; i < end; ++i) {
            const Piece& p = pieces_[i];
            // In double: near-parallel lines and grazing chords cancel most of a float's digits.
            const DVec3 w(p.dir), u = DVec3(p.start) - o;
            const double b = glm::dot(d, w), sin2 = 1.0 - b * b;
            const double du = glm::dot(d, u), wu = glm::dot(w, u);
            // The ray's chord through the infinite cylinder: around the closest point t_c.
            double lo = t0, hi = t1, tc;
            if (sin2 > 1e-12) {
                const double s = (b * du - wu) / sin2;
                tc = du + b * s;
                const DVec3 gap = tc * d - s * w - u;
                const double g2 = glm::dot(gap, gap);
                if (g2 >= r2) continue;
                const double h = std::sqrt((r2 - g2) / sin2);
                lo = std::max(lo, tc - h);
                hi = std::min(hi, tc + h);
            } else {  // parallel: inside for all t or none
                const DVec3 gap = u - wu * w;
                if (glm::dot(gap, gap) >= r2) continue;
                tc = du;
            }
            // ... within the piece's extent: s(t) = b t − w·u in [0, length].
            if (std::abs(b) > 1e-12) {
                const double e0 = wu / b, e1 = (p.length + wu) / b;
                lo = std::max(lo, std::min(e0, e1));
                hi = std::min(hi, std::max(e0, e1));
            } else if (-wu < 0.0 || -wu > p.length) {
                continue;
            }
            if (!(hi > lo)) continue;
            f(p, static_cast<float>(std::clamp(tc, lo, hi)),
              static_cast<float>((hi - lo) / (kPi * r2)));
        }
    });
}

}  // namespace fogmap
