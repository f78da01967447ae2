#include "photon/beam_tree.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>

namespace fogmap {

namespace {

constexpr uint32_t kBeamLeaf = 8;

}  // namespace

BeamTree::BeamTree(const PhotonMap& map, int k, float r_max) {
    const std::vector<Photon>& photons = map.tree.records();
    const size_t n = photons.size();
    records_.resize(n);
    for (size_t i = 0; i < n; ++i)
        records_[i] = Record{photons[i].position(), 0.0f, photons[i].direction(), 0.0f,
                             photons[i].power()};
    if (n == 0) return;
    nodes_.reserve(2 * (n / kBeamLeaf + 1));
    build(0, static_cast<uint32_t>(n));

    // Radii: one k-nearest query per leaf, at its first photon, shared by the leaf's photons
    // within that radius (a leaf spans about its 8 nearest neighbours); the others query too.
    std::vector<uint32_t> leaves;
    for (uint32_t i = 0; i < nodes_.size(); ++i)
        if (nodes_[i].end != 0) leaves.push_back(i);
    auto kth_radius = [&](const Vec3& x, NeighborList& scratch) {
        if (k <= 0) return r_max;
        map.tree.knn(x, k + 1, r_max, &scratch);  // +1: the photon itself
        return static_cast<int>(scratch.size()) == k + 1
                   ? std::max(std::sqrt(scratch.max_dist2()), 1e-6f * r_max)
                   : r_max;
    };
    tbb::parallel_for(tbb::blocked_range<size_t>(0, leaves.size()), [&](const auto& range) {
        NeighborList scratch;
        for (size_t l = range.begin(); l != range.end(); ++l) {
            const Node& leaf = nodes_[leaves[l]];
            const Vec3 x0 = records_[leaf.begin].position;
            const float r0 = kth_radius(x0, scratch);
            for (uint32_t i = leaf.begin; i < leaf.end; ++i) {
                Record& rec = records_[i];
                const float r =
                    glm::length(rec.position - x0) <= r0 ? r0 : kth_radius(rec.position, scratch);
                rec.r2 = r * r;
                rec.norm = 3.0f / (2.0f * kPi * r * r * r);
            }
        }
    });
    // Bounds of the spheres, bottom up (children come after their parent).
    for (size_t i = nodes_.size(); i-- > 0;) {
        Node& node = nodes_[i];
        node.bounds = Box3{};
        if (node.end != 0) {
            for (uint32_t j = node.begin; j < node.end; ++j) {
                const float r = std::sqrt(records_[j].r2);
                node.bounds.extend(records_[j].position - Vec3(r));
                node.bounds.extend(records_[j].position + Vec3(r));
            }
        } else {
            node.bounds.extend(nodes_[node.left].bounds);
            node.bounds.extend(nodes_[node.right].bounds);
        }
    }
}

// The hierarchy over the photon centres (median split along the widest axis); bounds come later.
uint32_t BeamTree::build(uint32_t begin, uint32_t end) {
    const uint32_t index = static_cast<uint32_t>(nodes_.size());
    nodes_.push_back(Node{});
    if (end - begin <= kBeamLeaf) {
        nodes_[index].begin = begin;
        nodes_[index].end = end;
        return index;
    }
    Box3 centres;
    for (uint32_t i = begin; i < end; ++i) centres.extend(records_[i].position);
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
