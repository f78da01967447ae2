#pragma once
// Beam radiance estimate (Jarosz, Zwicker, Jensen 2008) over a volume photon map: every photon
// gets a radius (the distance to its k-th neighbour, at most a maximum), a bounding-volume
// hierarchy over the photon spheres is built, and one query per camera-ray segment visits every
// photon whose sphere the segment crosses. The 2D kernel is the sphere estimate's kernel
// integrated along the ray, K(d) = 3 sqrt(r² − d²) / (2π r³), so the beam estimate is the line
// integral of the spherical estimate Σ p ΔΦ / ((4/3) π r³) (with the transmittance taken at each
// photon's closest point) and the two agree in the limit. Immutable after construction;
// queries are thread-safe.

#include "photon/photon_pass.h"

#include <cstdint>
#include <vector>

namespace fogmap {

class BeamTree {
public:
    /// Radii: distance to the k-th nearest photon, clamped to (0, r_max]; with k <= 0, r_max for
    /// every photon. Built in parallel.
    BeamTree(const PhotonMap& map, int k, float r_max);

    /// Calls f(const Photon&, float t, float kernel) for each photon whose sphere meets the ray
    /// segment o + t d, t in [t0, t1] (unit d): t is the photon's closest point along the ray
    /// (clamped into the segment), kernel = K(d) in 1/area.
    template <class F>
    void for_each_hit(const Ray& ray, float t0, float t1, F&& f) const;

    size_t bytes() const;
    float mean_radius() const { return mean_radius_; }

private:
    struct Node {
        Box3 bounds;           ///< of the photon spheres below
        uint32_t begin, end;   ///< leaf: photon range in order_; inner: end = 0
        uint32_t left, right;  ///< children (inner)
    };
    uint32_t build(uint32_t begin, uint32_t end);

    const PhotonMap* map_;
    std::vector<uint32_t> order_;  ///< photon indices, grouped by leaf
    std::vector<float> radius_;    ///< per photon (indexed like the map's records)
    std::vector<Node> nodes_;
    float mean_radius_ = 0.0f;
};

template <class F>
void BeamTree::for_each_hit(const Ray& ray, float t0, float t1, F&& f) const {
    if (nodes_.empty() || !(t1 > t0)) return;
    const std::vector<Photon>& photons = map_->tree.records();
    uint32_t stack[64];
    int top = 0;
    stack[top++] = 0;
    while (top > 0) {
        const Node& node = nodes_[stack[--top]];
        float te, tx;
        if (!intersect_box(node.bounds, ray, t0, t1, &te, &tx)) continue;
        if (node.end == 0) {
            stack[top++] = node.left;
            stack[top++] = node.right;
            continue;
        }
        for (uint32_t i = node.begin; i < node.end; ++i) {
            const uint32_t p = order_[i];
            const Vec3 v = photons[p].position() - ray.o;
            const float t = std::clamp(glm::dot(v, ray.d), t0, t1);
            const Vec3 closest = v - t * ray.d;
            const float d2 = glm::dot(closest, closest), r = radius_[p], r2 = r * r;
            if (d2 >= r2) continue;
            f(photons[p], t, 3.0f * std::sqrt(r2 - d2) / (2.0f * kPi * r2 * r));
        }
    }
}

}  // namespace fogmap
