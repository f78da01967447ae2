#include "photon/beam_tree.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>

namespace fogmap {

BeamTree::BeamTree(const PhotonMap& map, int k, float r_max) {
    const std::vector<Photon>& photons = map.tree.records();
    const size_t n = photons.size();
    records_.resize(n);
    for (size_t i = 0; i < n; ++i)
        records_[i] = Record{photons[i].position(),  0.0f,
                             photons[i].direction(), 0.0f,
                             photons[i].power(),     uint32_t(photons[i].batch())};
    if (n == 0) return;
    bvh_.build(records_, [](const Record& r) { return r.position; });

    // Radii: one k-nearest query per leaf, at its first photon, shared by the leaf's photons
    // within that radius (a leaf spans about its 8 nearest neighbours); the others query too.
    const std::vector<Bvh::Node>& nodes = bvh_.nodes();
    std::vector<uint32_t> leaves;
    for (uint32_t i = 0; i < nodes.size(); ++i)
        if (nodes[i].end != 0) leaves.push_back(i);
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
            const Bvh::Node& leaf = nodes[leaves[l]];
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
    bvh_.fit([&](uint32_t i) {
        const float r = std::sqrt(records_[i].r2);
        return Box3{records_[i].position - Vec3(r), records_[i].position + Vec3(r)};
    });
}

size_t BeamTree::bytes() const { return records_.capacity() * sizeof(Record) + bvh_.bytes(); }

}  // namespace fogmap
