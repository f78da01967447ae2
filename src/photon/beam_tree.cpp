#include "photon/beam_tree.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>

namespace fogmap {

namespace {

constexpr uint32_t kBeamLeaf = 8;
constexpr size_t kRadiusStride = 8;

}  // namespace

BeamTree::BeamTree(const PhotonMap& map, int k, float r_max) {
    const std::vector<Photon>& photons = map.tree.records();
    const size_t n = photons.size();
    records_.resize(n);
    // Radii: a k-nearest query at every kRadiusStride-th photon of the map's in-order (Hooley)
    // layout, shared with the photons after it, which are its spatial neighbours.
    const size_t groups = (n + kRadiusStride - 1) / kRadiusStride;
    tbb::parallel_for(tbb::blocked_range<size_t>(0, groups), [&](const auto& range) {
        NeighborList scratch;
        for (size_t g = range.begin(); g != range.end(); ++g) {
            const size_t first = g * kRadiusStride, last = std::min(n, first + kRadiusStride);
            float r = r_max;
            if (k > 0) {
                map.tree.knn(photons[first].position(), k + 1, r_max, &scratch);  // +1: itself
                if (static_cast<int>(scratch.size()) == k + 1)
                    r = std::max(std::sqrt(scratch.max_dist2()), 1e-6f * r_max);
            }
            for (size_t i = first; i < last; ++i)
                records_[i] = Record{photons[i].position(), r * r, photons[i].direction(),
                                     3.0f / (2.0f * kPi * r * r * r), photons[i].power()};
        }
    });
    double sum = 0.0;
    for (const Record& rec : records_) sum += std::sqrt(rec.r2);
    mean_radius_ = n ? static_cast<float>(sum / n) : 0.0f;
    if (n > 0) {
        nodes_.reserve(2 * (n / kBeamLeaf + 1));
        build(0, static_cast<uint32_t>(n));
    }
}

uint32_t BeamTree::build(uint32_t begin, uint32_t end) {
    const uint32_t index = static_cast<uint32_t>(nodes_.size());
    nodes_.push_back(Node{});
    Box3 bounds, centres;
    for (uint32_t i = begin; i < end; ++i) {
        const Vec3 p = records_[i].position;
        const float r = std::sqrt(records_[i].r2);
        bounds.extend(p - Vec3(r));
        bounds.extend(p + Vec3(r));
        centres.extend(p);
    }
    nodes_[index].bounds = bounds;
    if (end - begin <= kBeamLeaf) {
        nodes_[index].begin = begin;
        nodes_[index].end = end;
        return index;
    }
    // Median split of the sphere centres along the widest axis.
    const Vec3 e = centres.extent();
    const int axis = (e.x >= e.y && e.x >= e.z) ? 0 : (e.y >= e.z ? 1 : 2);
    const uint32_t mid = begin + (end - begin) / 2;
    std::nth_element(records_.begin() + begin, records_.begin() + mid, records_.begin() + end,
                     [&](const Record& a, const Record& b) {
                         return a.position[axis] < b.position[axis];
                     });
    const uint32_t left = build(begin, mid);
    const uint32_t right = build(mid, end);
    nodes_[index].begin = begin;
    nodes_[index].end = 0;
    nodes_[index].left = left;
    nodes_[index].right = right;
    return index;
}

size_t BeamTree::bytes() const {
    return records_.capacity() * sizeof(Record) + nodes_.capacity() * sizeof(Node);
}

}  // namespace fogmap
