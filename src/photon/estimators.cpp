#include "photon/estimators.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

namespace fogmap {

namespace {

// Radius of the estimate: the k-th photon's distance when k were found, else r_max.
float estimate_radius2(const NeighborList& found, int k, float r_max) {
    return k > 0 && static_cast<int>(found.size()) >= k ? found.max_dist2() : r_max * r_max;
}

// When the radius is the k-th photon's distance, that photon sits on the boundary and is left
// out: (k−1)/V is the unbiased k-nearest-neighbour density estimate (Loftsgaarden and
// Quesenberry 1965), k/V overestimates by k/(k−1) (5% at k = 20). Returns the index of the
// photon to skip, or size() when the radius is r_max.
size_t boundary_photon(const NeighborList& found, int k) {
    return k > 0 && static_cast<int>(found.size()) >= k ? 0 : found.size();  // heap top = farthest
}

// The photons to sum: the k nearest within r_max, or with k <= 0 every photon within r_max.
void find(const PhotonMap& map, const Vec3& x, int k, float r_max, NeighborList& out) {
    if (k > 0) {
        map.tree.knn(x, k, r_max, &out);
        return;
    }
    out.clear();
    const Photon* base = map.tree.records().data();
    map.tree.for_each_in_radius(x, r_max, [&](const Photon& p, float d2) {
        out.items().push_back({static_cast<uint32_t>(&p - base), d2});
    });
}

}  // namespace

Color surface_irradiance(const PhotonMap& map, const Vec3& x, const Vec3& n, int k, float r_max,
                         float cone_kf, uint8_t skip_flags, NeighborList& scratch,
                         BatchSums* batches) {
    find(map, x, k, r_max, scratch);
    if (scratch.empty()) return Color(0.0f);
    const float r2 = estimate_radius2(scratch, k, r_max);
    if (!(r2 > 0.0f)) return Color(0.0f);
    const float r = std::sqrt(r2);
    const std::vector<Photon>& photons = map.tree.records();
    const size_t skip = boundary_photon(scratch, k);
    Color sum(0.0f);
    for (size_t i = 0; i < scratch.size(); ++i) {
        const Photon& p = photons[scratch[i].index];
        if (i == skip || (p.flags & skip_flags) != 0) continue;
        if (glm::dot(p.direction(), n) <= 0.0f) continue;  // arrived on the other side
        float w = 1.0f;
        if (cone_kf > 0.0f) w = 1.0f - std::sqrt(scratch[i].dist2) / (cone_kf * r);
        sum += w * p.power();
        if (!batches) continue;
        // Over r/√2 the cone's weight falls to 0 at r/√2 (it is normalised as the whole's).
        const bool in = 2.0f * scratch[i].dist2 < r2;
        const float w_in = !in ? 0.0f
                           : cone_kf > 0.0f
                               ? 1.0f - std::sqrt(2.0f * scratch[i].dist2) / (cone_kf * r)
                               : 1.0f;
        batches->add(p, w * p.power(), w_in * p.power());
    }
    const float norm = cone_kf > 0.0f ? 1.0f - 2.0f / (3.0f * cone_kf) : 1.0f;
    return sum * (map.photon_power / (kPi * r2 * norm));
}

std::vector<float> knn_distances(const PhotonMap& map, const std::vector<Vec3>& points, int k,
                                 float r_max) {
    std::vector<float> r(points.size());
    tbb::parallel_for(tbb::blocked_range<size_t>(0, points.size(), 64), [&](const auto& range) {
        NeighborList scratch;
        for (size_t i = range.begin(); i != range.end(); ++i) {
            map.tree.knn(points[i], k, r_max, &scratch);
            r[i] = static_cast<int>(scratch.size()) == k ? std::sqrt(scratch.max_dist2()) : r_max;
        }
    });
    std::sort(r.begin(), r.end());
    return r;
}

float median_knn_distance(const PhotonMap& map, const std::vector<Vec3>& points, int k,
                          float r_max) {
    const std::vector<float> r = knn_distances(map, points, k, r_max);
    return r[r.size() / 2];
}

Color volume_inscattered(const PhotonMap& map, const Vec3& x, const Vec3& wo, const PhaseMix& phase,
                         int k, float r_max, NeighborList& scratch, BatchSums* batches,
                         HalfCentroids* centroids) {
    find(map, x, k, r_max, scratch);
    if (scratch.empty()) return Color(0.0f);
    const float r2 = estimate_radius2(scratch, k, r_max);
    if (!(r2 > 0.0f)) return Color(0.0f);
    const std::vector<Photon>& photons = map.tree.records();
    const size_t skip = boundary_photon(scratch, k);
    Color sum(0.0f);
    for (size_t i = 0; i < scratch.size(); ++i) {
        if (i == skip) continue;
        const Photon& p = photons[scratch[i].index];
        const Color power = p.power();
        const Color c = phase.eval(glm::dot(p.direction(), wo)) * power;
        sum += c;
        if (batches) batches->add(p, c, scratch[i].dist2, r2);
        if (centroids) centroids->add(p, p.position() - x, average(power));
    }
    const float volume = (4.0f / 3.0f) * kPi * r2 * std::sqrt(r2);
    return sum * (map.photon_power / volume);
}

}  // namespace fogmap
