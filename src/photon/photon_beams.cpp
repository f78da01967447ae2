#include "photon/photon_beams.h"

#include "photon/estimators.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

namespace fogmap {

namespace {

constexpr size_t kRadiusSamples = 4096;  // beams whose midpoints set the radius

}  // namespace

float PhotonBeams::map_radius(const PhotonMap& map, int k, float r_max) {
    const std::vector<PhotonBeam>& beams = map.beams;
    if (k <= 0 || map.tree.size() < static_cast<size_t>(k) || beams.empty()) return r_max;
    const size_t n = std::min(kRadiusSamples, beams.size());
    std::vector<Vec3> midpoints(n);
    for (size_t i = 0; i < n; ++i) {
        const PhotonBeam& b = beams[i * beams.size() / n];
        midpoints[i] = 0.5f * (b.start() + b.end());
    }
    return std::clamp(median_knn_distance(map, midpoints, k, r_max), 1e-6f * r_max, r_max);
}

PhotonBeams::PhotonBeams(const PhotonMap& map, int k, float r_max)
    : radius_(map_radius(map, k, r_max)) {
    const std::vector<PhotonBeam>& beams = map.beams;
    // Pieces of at most kPieceRadii radii, per beam in parallel, then joined in beam order.
    const float longest = kPieceRadii * radius_;
    std::vector<std::vector<Piece>> cut(beams.size());
    tbb::parallel_for(tbb::blocked_range<size_t>(0, beams.size(), 256), [&](const auto& range) {
        for (size_t i = range.begin(); i != range.end(); ++i) {
            const Vec3 a = beams[i].start(), e = beams[i].end();
            const float length = glm::length(e - a);
            if (!(length > 0.0f)) continue;
            const Vec3 w = (e - a) / length;
            const Color power = beams[i].power();
            const int n = static_cast<int>(std::ceil(length / longest));
            for (int j = 0; j < n; ++j) {
                const float s0 = length * j / n, s1 = j + 1 == n ? length : length * (j + 1) / n;
                cut[i].push_back(Piece{a + s0 * w, s1 - s0, w, power});
            }
        }
    });
    size_t n = 0;
    for (const auto& c : cut) n += c.size();
    pieces_.reserve(n);
    for (auto& c : cut) pieces_.insert(pieces_.end(), c.begin(), c.end());
    bvh_.build(pieces_, [](const Piece& p) { return p.start + 0.5f * p.length * p.dir; });
    bvh_.fit([&](uint32_t i) {
        const Piece& p = pieces_[i];
        const Vec3 b = p.start + p.length * p.dir;
        return Box3{glm::min(p.start, b) - Vec3(radius_), glm::max(p.start, b) + Vec3(radius_)};
    });
}

size_t PhotonBeams::bytes() const { return pieces_.capacity() * sizeof(Piece) + bvh_.bytes(); }

}  // namespace fogmap
