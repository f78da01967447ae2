#include "photon/beam_tree.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>

namespace fogmap {

namespace {

constexpr uint32_t kBeamLeaf = 8;

}  // namespace

BeamTree::BeamTree(const PhotonMap& map, int k, float r_max) : map_(&map) {
    const std::vector<Photon>& photons = map.tree.records();
    const size_t n = photons.size();
    radius_.assign(n, r_max);
    if (k > 0) {
        tbb::parallel_for(tbb::blocked_range<size_t>(0, n), [&](const auto& r) {
            NeighborList scratch;
            for (size_t i = r.begin(); i != r.end(); ++i) {
                map.tree.knn(photons[i].position(), k + 1, r_max, &scratch);  // +1: itself
                if (static_cast<int>(scratch.size()) == k + 1)
                    radius_[i] = std::max(std::sqrt(scratch.max_dist2()), 1e-6f * r_max);
            }
        });
    }
    double sum = 0.0;
    for (float r : radius_) sum += r;
    mean_radius_ = n ? static_cast<float>(sum / n) : 0.0f;
    order_.resize(n);
    for (size_t i = 0; i < n; ++i) order_[i] = static_cast<uint32_t>(i);
    if (n > 0) {
        nodes_.reserve(2 * (n / kBeamLeaf + 1));
        build(0, static_cast<uint32_t>(n));
    }
}

uint32_t BeamTree::build(uint32_t begin, uint32_t end) {
    const std::vector<Photon>& photons = map_->tree.records();
    const uint32_t index = static_cast<uint32_t>(nodes_.size());
    nodes_.push_back(Node{});
    Box3 bounds, centres;
    for (uint32_t i = begin; i < end; ++i) {
        const Vec3 p = photons[order_[i]].position();
        const float r = radius_[order_[i]];
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
    std::nth_element(order_.begin() + begin, order_.begin() + mid, order_.begin() + end,
                     [&](uint32_t a, uint32_t b) {
                         return photons[a].position()[axis] < photons[b].position()[axis];
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
    return order_.capacity() * sizeof(uint32_t) + radius_.capacity() * sizeof(float) +
           nodes_.capacity() * sizeof(Node);
}

}  // namespace fogmap
